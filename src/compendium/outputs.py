"""Where a notebook run writes its figures and tables, and when: the published record is protected.

A notebook opens one :class:`Outputs` in its first code cell and publishes it in its last:

1. **Destination.** ``OCPKIT_OUTPUT_DIR``, when set, is an explicit choice and wins. Otherwise a
   run whose parameters are the notebook's published ones (:func:`published_parameters`) writes
   the published record, ``figures/`` and ``data/derived/`` of the repository; any other run
   writes under ``build/runs/<notebook>/``, so exploring never overwrites what the README cites.
2. **All or nothing.** Files are written to a staging folder (``build/staging/``) and moved into
   place by :meth:`Outputs.publish` when the notebook completes: a run that fails midway leaves
   the destination as it was, never outputs of two runs side by side.
3. **Timings apart.** Measured times vary from run to run; they go to the run's record
   ``data/derived/runs/<notebook>.json`` (git-ignored), with the parameters, whether they are the
   published ones, and the files written. The tracked files of a default re-run are byte-identical.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import warnings
from pathlib import Path

import pandas as pd

from . import paths
from .plotting import save_figure

RUNS = Path("data") / "derived" / "runs"


def published_parameters(notebook: str) -> dict:
    """The parameters of the notebook's published run: its parameters cell, updated by ``notebooks/published.toml``."""
    from .notebooks import literal_parameters, published_overrides

    path = paths.notebooks_dir() / f"{notebook}.ipynb"
    params, overrides = literal_parameters(path), published_overrides(path)
    unknown = sorted(set(overrides) - set(params))
    if unknown:
        raise ValueError(f"notebooks/published.toml names unknown parameter(s) {unknown} of {notebook}")
    return params | overrides


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
        explicit = os.environ.get("OCPKIT_OUTPUT_DIR")
        if explicit:
            self.root = Path(explicit).resolve()
        elif self.is_published_run:
            self.root = paths.repo_root()
        else:
            self.root = paths.repo_root() / "build" / "runs" / notebook
        staging = paths.repo_root() / "build" / "staging"
        staging.mkdir(parents=True, exist_ok=True)
        self._staging = Path(tempfile.mkdtemp(prefix=f"{notebook}-", dir=staging))
        self.files: list[str] = []
        self.timings: dict[str, list[dict]] = {}
        self.published = False

    @classmethod
    def start(cls, notebook: str, namespace: dict) -> Outputs:
        """Open the outputs of a run whose parameters are variables of ``namespace`` (a notebook's ``globals()``).

        Also shows warnings as ``Category: message``, without the file path Python prints by default: a
        stored notebook must not carry the paths of the machine that ran it.
        """
        warnings.formatwarning = _format_warning
        out = cls(notebook, {k: namespace[k] for k in published_parameters(notebook) if k in namespace})
        print(out.describe())
        return out

    def describe(self) -> str:
        where = self._display(self.root)
        if os.environ.get("OCPKIT_OUTPUT_DIR"):
            reason = "OCPKIT_OUTPUT_DIR is set"
        elif self.is_published_run:
            reason = "the published parameters"
        else:
            reason = "parameters differ from the published run: " + ", ".join(
                f"{k} = {v!r}" for k, v in self.changed.items()
            )
        return f"outputs go to {where} when the notebook completes ({reason})"

    @staticmethod
    def _display(path: Path) -> str:
        try:
            rel = path.relative_to(paths.repo_root())
            return "figures/ and data/derived/ of the repository" if rel == Path(".") else f"{rel}/"
        except ValueError:
            return f"{path.name}/ (outside the repository)"

    # -- writing (into the staging folder) ------------------------------------------------------
    def _path(self, relative: Path) -> Path:
        if self.published:
            raise RuntimeError(f"the outputs of {self.notebook} are already published; start a new Outputs")
        path = self._staging / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        if str(relative) not in self.files:
            self.files.append(str(relative))
        return path

    def figure(self, fig, name: str) -> None:
        """``figures/<name>.png`` and ``.pdf`` (deterministic bytes)."""
        for path in save_figure(fig, name, self._staging / "figures"):
            self._path(Path("figures") / path.name)

    def table(self, df: pd.DataFrame, name: str, float_format: str = "%.10g") -> None:
        """``data/derived/<name>.csv`` (no index)."""
        df.to_csv(self._path(Path("data") / "derived" / f"{name}.csv"), index=False, float_format=float_format)

    def text(self, text: str, filename: str) -> None:
        """``data/derived/<filename>`` (Markdown tables, notes)."""
        self._path(Path("data") / "derived" / filename).write_text(text)

    def json(self, obj: dict, name: str) -> None:
        """``data/derived/<name>.json``."""
        self._path(Path("data") / "derived" / f"{name}.json").write_text(json.dumps(obj, indent=2) + "\n")

    def timing(self, name: str, rows) -> None:
        """Measured times (a DataFrame, a dict or a list of dicts): kept in the run's record, not in tracked files."""
        if isinstance(rows, pd.DataFrame):
            rows = rows.to_dict("records")
        elif isinstance(rows, dict):
            rows = [rows]
        self.timings[name] = [{k: _plain(v) for k, v in r.items()} for r in rows]

    # -- publishing -------------------------------------------------------------------------------
    def publish(self) -> None:
        """Move every staged file into place and write the run's record; print where they went."""
        if self.published:
            raise RuntimeError(f"the outputs of {self.notebook} are already published")
        for rel in self.files:
            target = self.root / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.move(self._staging / rel, target)
        record = {
            "notebook": self.notebook,
            "published_parameters": self.is_published_run,
            "parameters": {k: _plain(v) for k, v in self.parameters.items()},
            "files": self.files,
            "timings": self.timings,
        }
        runs = self.root / RUNS
        runs.mkdir(parents=True, exist_ok=True)
        (runs / f"{self.notebook}.json").write_text(json.dumps(record, indent=2) + "\n")
        shutil.rmtree(self._staging, ignore_errors=True)
        self.published = True
        figures = sum(f.startswith("figures/") for f in self.files)
        print(f"wrote {figures} figure files and {len(self.files) - figures} tables to {self._display(self.root)}")


def _format_warning(message, category, filename, lineno, line=None) -> str:
    return f"{category.__name__}: {message}\n"


def _plain(value):
    """JSON-ready: numpy scalars and arrays to Python numbers and lists."""
    if hasattr(value, "tolist"):
        return value.tolist()
    return value


def read_run_record(root: Path, notebook: str) -> dict:
    """The record :meth:`Outputs.publish` wrote for ``notebook`` under ``root``."""
    return json.loads((Path(root) / RUNS / f"{notebook}.json").read_text())
