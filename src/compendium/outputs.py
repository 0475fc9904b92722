"""Where a notebook run writes its figures and tables, and when: the published record is protected.

A notebook opens one :class:`Outputs` in its first code cell and publishes it in its last:

1. **Every run writes its own folder.** A notebook never writes the published record (``figures/`` and
   ``data/derived/`` of the repository) itself. A run writes under ``build/runs/<notebook>/<key>/``, where the
   key names the parameters that differ from the notebook's defaults (``defaults`` when none do,
   ``segments-40`` ...; see :func:`compendium.provenance.run_key`), so runs with other parameters never overwrite
   each other and a run with the same parameters replaces the earlier one whole. ``OCPKIT_RUNS_DIR`` moves
   ``build/runs``; ``OCPKIT_OUTPUT_DIR`` is the explicit choice of one folder for the run (nbval's runs write
   ``build/test-output``). The run's first output line says where, and why.
2. **Only the committed notebook publishes.** ``make reproduce`` and ``make store`` (and
   ``python -m compendium.notebooks publish RUN``) copy a run into the published record, and only a complete
   run of the committed notebook, unchanged, with its published parameters
   (:func:`compendium.notebook_source.published_parameters`): the run's record holds a digest of every code cell
   the kernel executed (:func:`executed_code`), which must be the code cells of the notebook as committed (git's
   ``HEAD``; :func:`compendium.notebooks.publish_run`), and the kernel's threads, which must be one BLAS and one
   OpenMP thread (:data:`compendium.provenance.ONE_THREAD`). Lab's Run All, a copy of a notebook and an edited one stay
   in ``build/runs/``.
3. **All or nothing.** Files are staged in ``<folder>/.staging/`` and moved into place by :meth:`Outputs.publish`
   when the notebook completes: a run that fails midway leaves its folder as it was. The staging folder of a
   failed run is removed when its kernel exits, and that of a killed one by the next run into the same folder.
4. **Timings apart.** Measured times go to the run's record, ``<folder>/data/derived/runs/<notebook>.json``,
   with the parameters and the files written; tracked files and stored notebooks hold none.

Below it: what it reads of the notebook (:mod:`compendium.notebook_source`) and where the run's folder and record
are, with the git state the record holds (:mod:`compendium.provenance`).
"""

from __future__ import annotations

import atexit
import json
import os
import re
import shutil
import socket
import tempfile
import warnings
from pathlib import Path

import pandas as pd

from . import contract, paths
from .figure_data import write_figure_data
from .notebook_source import code_digest, none_meanings, notebook_parameters, parameters_cell, published_parameters
from .plotting import add_note, note_figures, run_note, save_figure
from .provenance import RUNS, git_state, run_folder, threads

STAGING = ".staging"
FIGURE_DATA = Path(contract.FIGURE_DATA)


class ContractWarning(UserWarning):
    """A run wrote something ``notebooks/contract.toml`` does not declare (the guard reports it as a difference)."""


def _ipython():
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython is part of the environment
        return None
    return get_ipython()


def _kernel_inputs() -> list[str] | None:
    """The sources the running kernel has executed, in order (``None`` outside IPython)."""
    shell = _ipython()
    if shell is None or getattr(shell, "history_manager", None) is None:
        return None
    return [s for s in shell.history_manager.input_hist_raw[1:]]


def _is_injected_parameters(source: str) -> bool:
    """papermill's injected cell: ``# Parameters`` and assignments only."""
    import ast

    if not source.lstrip().startswith("# Parameters"):
        return False
    try:
        body = ast.parse(source).body
    except SyntaxError:
        return False
    return all(isinstance(node, ast.Assign) for node in body)


def _assigned(source: str) -> list[str]:
    import ast

    return [
        t.id
        for node in ast.parse(source).body
        if isinstance(node, ast.Assign)
        for t in node.targets
        if hasattr(t, "id")
    ]


def executed_code(inputs: list[str], parameters_source: str | None = None) -> list[str]:
    """Digests of the code cells a kernel executed, papermill's injected parameters cell left out: a cell of
    ``# Parameters`` and assignments right after the notebook's parameters cell (``parameters_source``), where
    papermill puts it; the same cell anywhere else is code like any other."""
    parameters = code_digest(parameters_source) if parameters_source is not None else None
    out = []
    for k, source in enumerate(inputs):
        after_parameters = k > 0 and code_digest(inputs[k - 1]) == parameters
        if not (after_parameters and _is_injected_parameters(source)):
            out.append(code_digest(source))
    return out


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class Outputs:
    """The files of one notebook run (see the module docstring).

    ``notebook``: the notebook's stem (``"01_lunar_ascent"``); ``parameters``: the values of
    every parameter of its parameters cell for this run.
    """

    def __init__(self, notebook: str, parameters: dict):
        published = published_parameters(notebook)
        missing = sorted(set(published) - set(parameters))
        if missing:
            raise ValueError(f"Outputs of {notebook} needs every parameter of its parameters cell; missing {missing}")
        self.notebook = notebook
        self.parameters = {k: parameters[k] for k in published}
        self.changed = {k: v for k, v in self.parameters.items() if v != published[k]}
        self.is_published_run = not self.changed
        #: what each figure of a run with other parameters says of it (:func:`compendium.plotting.run_note`)
        self.note = None
        if self.changed:
            meanings = none_meanings(paths.notebooks_dir() / f"{notebook}.ipynb")
            self.note = run_note(self.changed, published, meanings)
        self.explicit = bool(os.environ.get("OCPKIT_OUTPUT_DIR"))
        self.root = run_folder(notebook, self.parameters)
        if self.root == paths.repo_root().resolve():
            raise ValueError(
                "OCPKIT_OUTPUT_DIR is the repository itself: the published record is written only by "
                "`make reproduce` or `make store` (python -m compendium.notebooks publish), from a complete run"
            )
        self._sweep_stale_staging()
        staging = self.root / STAGING
        staging.mkdir(parents=True, exist_ok=True)
        prefix = f"{notebook}-{socket.gethostname()}-{os.getpid()}-"
        self._staging = Path(tempfile.mkdtemp(prefix=prefix, dir=staging))
        atexit.register(self._discard)
        self.files: list[str] = []
        self.timings: dict[str, list[dict]] = {}
        self.published = False
        self._contract = _contract_of(notebook)

    @classmethod
    def start(cls, notebook: str, namespace: dict) -> Outputs:
        """Open the outputs of a run whose parameters are variables of ``namespace`` (a notebook's ``globals()``).

        Rejects parameters papermill passed that the notebook does not declare (papermill itself only warns, then
        runs the defaults). A run with other parameters than the published run's puts :attr:`note` on every figure
        pyplot draws from now on (:func:`compendium.plotting.note_figures`), inline ones too. Also shows warnings as
        ``Category: message``, without the file path Python prints by default: a stored notebook must not carry the paths of the machine that ran it.
        """
        warnings.formatwarning = _format_warning
        _reject_unknown_injected(notebook)
        out = cls(notebook, {k: namespace[k] for k in published_parameters(notebook) if k in namespace})
        note_figures(out.note)
        print(out.describe())
        return out

    def describe(self) -> str:
        where = self._display(self.root)
        if self.explicit:
            reason = "OCPKIT_OUTPUT_DIR is set"
        elif self.is_published_run:
            reason = "the published parameters"
        else:
            reason = "parameters differ from the published run: " + ", ".join(
                f"{k} = {v!r}" for k, v in self.changed.items()
            )
        return (
            f"This run writes its figures and tables to {where} when it completes ({reason}).\n"
            "The published record (figures/, data/derived/) is written only by `make reproduce` and `make store`, "
            "from a complete run of this notebook as committed, with its published parameters."
        )

    @staticmethod
    def _display(path: Path) -> str:
        try:
            return f"{path.relative_to(paths.repo_root())}/"
        except ValueError:
            return f"{path}/"

    @property
    def record(self) -> str:
        """Where the run's record (its parameters, files and measured times) is written when the run completes."""
        return self._display(self.root / RUNS / f"{self.notebook}.json").rstrip("/")

    # -- staging --------------------------------------------------------------------------------------------------
    def _sweep_stale_staging(self) -> None:
        """Remove the staging folders that runs killed on this machine left in this run's folder."""
        staging = self.root / STAGING
        if not staging.is_dir():
            return
        host = socket.gethostname()
        for entry in staging.iterdir():
            m = re.fullmatch(rf"{re.escape(self.notebook)}-(.+)-(\d+)-[^-]+", entry.name)
            if m and m.group(1) == host and not _alive(int(m.group(2))):
                shutil.rmtree(entry, ignore_errors=True)

    def _discard(self) -> None:
        if not self.published:
            shutil.rmtree(self._staging, ignore_errors=True)
            _remove_if_empty(self._staging.parent)

    # -- writing (into the staging folder) ------------------------------------------------------------------------
    def _path(self, relative: Path) -> Path:
        if self.published:
            raise RuntimeError(f"the outputs of {self.notebook} are already published; start a new Outputs")
        path = self._staging / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        if str(relative) not in self.files:
            self.files.append(str(relative))
        return path

    def figure(self, fig, name: str) -> None:
        """``figures/<name>.png`` and ``.pdf`` (deterministic bytes), and ``figures/data/<name>.json``, the
        arrays the figure draws (:mod:`compendium.figure_data`), which the guard compares. A run with other
        parameters than the published run's writes its :attr:`note` on the figure first (the published run's
        figures carry none)."""
        self._declared("figures", name)
        if self.note is not None:
            add_note(fig, self.note)
        for path in save_figure(fig, name, self._staging / "figures"):
            self._path(Path("figures") / path.name)
        write_figure_data(fig, self._path(FIGURE_DATA / f"{name}.json"))

    def table(self, df: pd.DataFrame, name: str, float_format: str = "%.10g") -> None:
        """``data/derived/<name>.csv`` (no index)."""
        spec = self._declared("tables", name)
        if spec is not None and spec.undeclared(df.columns):
            self._warn(f"columns {spec.undeclared(df.columns)} of table {name!r} have no class")
        df.to_csv(self._path(Path("data") / "derived" / f"{name}.csv"), index=False, float_format=float_format)

    def text(self, text: str, filename: str) -> None:
        """``data/derived/<filename>`` (Markdown tables, notes)."""
        if filename.endswith(".md"):
            self._declared("markdown", filename)
        self._path(Path("data") / "derived" / filename).write_text(text)

    def json(self, obj: dict, name: str) -> None:
        """``data/derived/<name>.json``."""
        spec = self._declared("json", name)
        if spec is not None and spec.undeclared(obj):
            self._warn(f"keys {spec.undeclared(obj)} of {name}.json have no class")
        self._path(Path("data") / "derived" / f"{name}.json").write_text(json.dumps(obj, indent=2) + "\n")

    def timing(self, name: str, rows) -> None:
        """Measured times (a DataFrame, a dict or a list of dicts): kept in the run's record, not in tracked files."""
        if isinstance(rows, pd.DataFrame):
            rows = rows.to_dict("records")
        elif isinstance(rows, dict):
            rows = [rows]
        self.timings[name] = [{k: _plain(v) for k, v in r.items()} for r in rows]

    def _declared(self, kind: str, name: str):
        if self._contract is None:
            return None
        spec = getattr(self._contract, kind).get(name)
        if spec is None:
            self._warn(f"{kind[:-1] if kind != 'json' else 'JSON file'} {name!r} is not declared")
        return spec

    def _warn(self, what: str) -> None:
        warnings.warn(
            f"{self.notebook}: {what} in notebooks/contract.toml; the guard cannot compare it",
            ContractWarning,
            stacklevel=3,
        )

    # -- publishing -----------------------------------------------------------------------------------------------
    def publish(self) -> None:
        """Move every staged file into this run's folder and write the run's record; print where they went."""
        if self.published:
            raise RuntimeError(f"the outputs of {self.notebook} are already published")
        previous = self.root / RUNS / f"{self.notebook}.json"
        stale = []
        if previous.is_file():
            try:
                stale = [f for f in json.loads(previous.read_text()).get("files", []) if f not in self.files]
            except (ValueError, OSError):
                stale = []
        for rel in self.files:
            target = self.root / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(self._staging / rel, target)
        for rel in stale:  # what the earlier run of this notebook here wrote and this one did not
            (self.root / rel).unlink(missing_ok=True)
        inputs = _kernel_inputs()
        tracked = paths.notebooks_dir() / f"{self.notebook}.ipynb"
        record = {
            "notebook": self.notebook,
            "published_parameters": self.is_published_run,
            "parameters": {k: _plain(v) for k, v in self.parameters.items()},
            "files": self.files,
            "code": executed_code(inputs, parameters_cell(tracked).source) if inputs is not None else None,
            "timings": self.timings,
            "threads": threads(),  # the kernel's BLAS and OpenMP threads: only one of each publishes
            "git": git_state(),  # the commit the run's code was at when it ended, and what was changed since
        }
        (self.root / RUNS).mkdir(parents=True, exist_ok=True)
        tmp = previous.with_suffix(f".json.{os.getpid()}")
        tmp.write_text(json.dumps(record, indent=2) + "\n")
        os.replace(tmp, previous)
        shutil.rmtree(self._staging, ignore_errors=True)
        _remove_if_empty(self._staging.parent)
        self.published = True
        figures = sum(f.startswith("figures/") and not f.startswith(f"{FIGURE_DATA}/") for f in self.files)
        tables = sum(f.startswith("data/") for f in self.files)
        print(f"wrote {figures} figure files and {tables} tables to {self._display(self.root)}")


def _remove_if_empty(folder: Path) -> None:
    try:
        folder.rmdir()
    except OSError:
        pass


def _contract_of(notebook: str):
    """The notebook's section of ``notebooks/contract.toml`` (``None``, with a warning, when it has none)."""
    try:
        sections = contract.load_contract()
    except FileNotFoundError:
        return None
    if notebook not in sections:
        warnings.warn(f"notebooks/contract.toml has no section for {notebook}", ContractWarning, stacklevel=3)
        return None
    return sections[notebook]


def _reject_unknown_injected(notebook: str) -> None:
    """Raise when papermill injected a parameter the notebook does not declare (papermill only warns)."""
    inputs = _kernel_inputs()
    if not inputs:
        return
    injected = [s for s in inputs if _is_injected_parameters(s)]
    if not injected:
        return
    known = notebook_parameters(paths.notebooks_dir() / f"{notebook}.ipynb")
    unknown = sorted(set(_assigned(injected[-1])) - set(known))
    if unknown:
        raise ValueError(f"unknown parameter(s) {unknown} for {notebook}; its parameters are {sorted(known)}")


def _format_warning(message, category, filename, lineno, line=None) -> str:
    return f"{category.__name__}: {message}\n"


def _plain(value):
    """JSON-ready: numpy scalars and arrays to Python numbers and lists."""
    if hasattr(value, "tolist"):
        return value.tolist()
    return value
