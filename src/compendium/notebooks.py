"""Run the compendium's notebooks headless (papermill), publish their runs, refresh stored outputs, build the report.

Command line::

    python -m compendium.notebooks run notebooks/01_lunar_ascent.ipynb -p segments 40   # build/runs/01_lunar_ascent/segments-40/
    python -m compendium.notebooks reproduce notebooks/*.ipynb --report build/report   # the published runs, published
    python -m compendium.notebooks store notebooks/*.ipynb       # re-execute in place (nbval reference), published
    python -m compendium.notebooks publish build/runs/01_lunar_ascent/defaults   # a complete run, into the record
    python -m compendium.notebooks report build/notebooks --output build/report

A run writes the executed notebook, its figures and tables and its record into its own folder
(:mod:`compendium.outputs`), and the executed notebook keeps a copy of that record (:func:`keep_run_record`);
only ``reproduce``, ``store`` and ``publish`` copy a run into the published record, and only a complete run of the
committed notebook, unchanged, with its published parameters, on one BLAS and one OpenMP thread (:func:`publish_run`).
Unlike plain papermill, which only warns, an unknown parameter is an error. Kernels talk over IPC sockets in a
private temporary folder (no unencrypted TCP, nothing left in the user's folders), and long work reports its
progress in the terminal (``OCPKIT_PROGRESS=terminal``, see :mod:`compendium.progress`), not in the stored notebooks.

The top of the compendium's run machinery: it reads notebooks through :mod:`compendium.notebook_source`, finds run
folders and records through :mod:`compendium.provenance` and builds the report with :mod:`compendium.report`; none
of them imports it back.
"""

from __future__ import annotations

import argparse
import ast
import sys
import traceback
from collections.abc import Callable
from pathlib import Path

from . import paths
from .contract import load_contract
from .notebook_source import (
    check_parameters,
    code_digest,
    literal_parameters,
    notebook_code,
    published_overrides,
    published_parameters,
    static_views,
    written_to,
)
from .progress import NotebookETA, duration, longest_first, measured_durations, notebook_estimates, prior_durations
from .provenance import ONE_THREAD, RUN_RECORD_KEY, RUNS, run_folder
from .report import UNFINISHED, Unfinished, build_report

KERNEL_NAME = "ocpkit"

# metadata written by papermill/nbclient that changes on every run
_VOLATILE_CELL_METADATA = ("papermill", "execution")
# papermill's record of the run, the run's record (its times and commit; kept by execute), and the state of live
# widgets (nbclient and Lab save it; new model ids every run, and their views are not stored: static_views)
_VOLATILE_NB_METADATA = ("papermill", RUN_RECORD_KEY, "widgets")


def _kernel_manager_class(ipc_dir: str | None = None):
    """jupyter_client's kernel manager over IPC sockets: local, and without ipykernel's TCP warning.

    ``ipc_dir``: the folder of the sockets (a private temporary one), so that none is left in the folder the
    kernel runs in. The kernel is the one JupyterLab starts (the ``ocpkit`` kernelspec, its output captured
    the same way), so a stored notebook is what Lab's Run All gives; progress bars reach the terminal through
    the kernel's original standard error (:mod:`compendium.progress`).
    """
    import os

    from jupyter_client import AsyncKernelManager

    class IPCKernelManager(AsyncKernelManager):
        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.transport = "ipc"
            if ipc_dir is not None:
                self.ip = os.path.join(ipc_dir, "kernel")

    return IPCKernelManager


def execute(
    path: str | Path,
    output: str | Path,
    parameters: dict | None = None,
    *,
    kernel: str = KERNEL_NAME,
    cwd: str | Path | None = None,
    timeout: int = 3600,
    progress: bool = False,
    env: dict[str, str] | None = None,
) -> Path:
    """Execute a notebook with papermill into ``output``; unknown parameters are rejected first.

    The kernel starts in ``cwd`` (default: the output's folder), not in the
    notebook's folder: the notebooks find the repository through
    :mod:`compendium.paths`, whatever folder they run in. ``progress``: a bar over the
    notebook's cells, and the notebook's own bars, in this process's terminal. ``env``:
    environment variables for the kernel (``OCPKIT_RUNS_DIR``, ``OCPKIT_OUTPUT_DIR``).

    The kernel runs with one BLAS and one OpenMP thread (:data:`~compendium.provenance.ONE_THREAD`), whoever starts
    the run: as ``make`` runs the notebooks, so that a run started by hand takes the published record's paths.

    The executed notebook keeps the record of its run (:func:`keep_run_record`), so that its report shows that
    run whatever runs write into the same folder later.
    """
    import os
    import shutil
    import tempfile
    import time

    import papermill as pm

    path, output = Path(path), Path(output)
    parameters = dict(parameters or {})
    check_parameters(path, parameters)
    output.parent.mkdir(parents=True, exist_ok=True)
    settings = {"OCPKIT_PROGRESS": "terminal" if progress else "off", **ONE_THREAD, **(env or {})}  # the kernel's
    previous = {k: os.environ.get(k) for k in settings}
    os.environ.update(settings)
    ipc_dir = tempfile.mkdtemp(prefix="ocpkit-ipc-")  # short: a Unix socket path has at most ~107 characters
    started = time.time()
    try:
        pm.execute_notebook(
            str(path),
            str(output),
            parameters=parameters,
            kernel_name=kernel,
            cwd=str(cwd or output.parent),
            execution_timeout=timeout,
            progress_bar={"desc": path.stem, "leave": False} if progress else False,
            kernel_manager_class=_kernel_manager_class(ipc_dir),
        )
    except BaseException:
        try:  # a run that stopped wrote no record: its executed notebook says so (an earlier run's is not its own)
            keep_run_record(output, started, notebook=path.stem)
        except (OSError, ValueError):
            pass
        raise
    else:
        try:
            keep_run_record(output, started, notebook=path.stem)
        except (OSError, ValueError) as exc:  # the run completed: its report falls back on the folder's record
            print(f"{path.name}: the run's record could not be kept in {output} ({exc})", file=sys.stderr)
    finally:
        shutil.rmtree(ipc_dir, ignore_errors=True)
        for k, v in previous.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    return output


def keep_run_record(executed: Path, since: float, notebook: str | None = None) -> dict | None:
    """Put the record of the run ``executed`` shows into its metadata (:data:`~compendium.provenance.RUN_RECORD_KEY`)
    and return it: the record of ``notebook`` (the source notebook's name without ``.ipynb``; default the executed
    notebook's) in the folder its first output line names (:func:`~compendium.notebook_source.written_to`),
    written at or after ``since`` (a :func:`time.time`; one second earlier, for file systems that keep coarse
    times), ``None`` if that folder holds none so recent (the run did not complete). Another notebook's record in the
    same folder is never taken. Nothing is written into a notebook that names no folder, or into none at all."""
    import json

    import nbformat

    if not executed.is_file():
        return None
    folder = written_to(executed)
    if folder is None:
        return None
    own = folder / RUNS / f"{notebook or executed.stem}.json"
    record = json.loads(own.read_text()) if own.is_file() and own.stat().st_mtime >= since - 1.0 else None
    nb = nbformat.read(str(executed), as_version=4)
    nb.metadata[RUN_RECORD_KEY] = record
    nbformat.write(nb, str(executed))
    return record


def strip_volatile_metadata(path: str | Path) -> None:
    """Remove timings and timestamps, and store the outputs as JupyterLab does, so that a stored notebook changes
    only when its results do, whether papermill or Lab's Run All ran it.

    A cell that prints, computes a while, then prints again sends two stream messages: papermill stores them as
    two outputs, Lab as one (it merges consecutive stream outputs of the same name); where the split falls
    depends on timing. Consecutive stream outputs of one name are merged here, as Lab does.
    """
    import nbformat

    nb = nbformat.read(str(path), as_version=4)
    for key in _VOLATILE_NB_METADATA:
        nb.metadata.pop(key, None)
    for cell in nb.cells:
        for key in _VOLATILE_CELL_METADATA:
            cell.metadata.pop(key, None)
        if cell.cell_type == "code":
            cell.outputs = static_views(_merged_streams(cell.outputs))
    nbformat.write(nb, str(path))


def pre_save_hook(model: dict, **_) -> None:
    """Jupyter server's pre-save hook (``make lab`` sets it): a notebook is saved with
    :func:`~compendium.notebook_source.static_views` of its outputs and without the widgets' state, as
    ``make store`` stores it."""
    if model.get("type") != "notebook" or not isinstance(model.get("content"), dict):
        return
    model["content"].get("metadata", {}).pop("widgets", None)
    for cell in model["content"].get("cells", []):
        if cell.get("cell_type") == "code":
            static_views(cell.get("outputs", []))


def _merged_streams(outputs: list) -> list:
    merged: list = []
    for out in outputs:
        last = merged[-1] if merged else None
        if out.output_type == "stream" and last is not None and last.output_type == "stream" and last.name == out.name:
            last.text = last.text + out.text
        else:
            merged.append(out)
    return merged


def _run_parameters(path: Path, given: dict) -> dict:
    """Every parameter of a run of ``path`` with ``given``: the defaults, updated."""
    return literal_parameters(path) | given


def run(
    path: str | Path,
    parameters: dict | None = None,
    *,
    runs: str | Path | None = None,
    kernel: str = KERNEL_NAME,
    progress: bool = False,
) -> tuple[Path, Path]:
    """Execute a notebook into a run folder (:func:`compendium.provenance.run_folder`): the executed notebook, its
    figures, tables and record side by side. ``runs``: the folder of run folders (default ``build/runs``).

    Returns the folder of the executed notebook and that of the run's figures and tables, as the run's first output
    line names it: a copy of a compendium notebook writes where the notebook it copies would.
    """
    path, parameters = Path(path), dict(parameters or {})
    check_parameters(path, parameters)
    defaults = literal_parameters(path)
    folder = run_folder(path.stem, defaults | parameters, runs, defaults)
    env = {"OCPKIT_RUNS_DIR": str(Path(runs).resolve())} if runs is not None else {}
    executed = execute(path, folder / path.name, parameters, kernel=kernel, cwd=folder, progress=progress, env=env)
    return folder, written_to(executed) or folder


class PublishError(ValueError):
    """A run that may not become the published record (the message says why)."""


def committed_code(notebook: str) -> tuple[list[str], str]:
    """Digests of the code cells of ``notebooks/<notebook>.ipynb`` as committed (git's ``HEAD``), and what they are
    of; outside a git checkout, of the file itself."""
    import subprocess

    import nbformat

    root = paths.repo_root()
    rel = f"notebooks/{notebook}.ipynb"
    inside = subprocess.run(["git", "-C", str(root), "rev-parse", "--show-toplevel"], capture_output=True, text=True)
    if inside.returncode != 0 or Path(inside.stdout.strip()).resolve() != root.resolve():
        return notebook_code(root / rel), rel
    shown = subprocess.run(["git", "-C", str(root), "show", f"HEAD:{rel}"], capture_output=True, text=True)
    if shown.returncode != 0:
        raise PublishError(f"{rel} is not committed: commit it, then run it again, to publish its run")
    nb = nbformat.reads(shown.stdout, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code" and "injected-parameters" not in c.metadata.get("tags", [])]
    return [code_digest(c.source) for c in code], f"{rel} as committed (HEAD)"


def publish_run(folder: str | Path) -> list[str]:
    """Copy a complete run into the published record (``figures/``, ``data/derived/``); the files copied.

    Only a complete run of the committed notebook publishes: the digests of the code cells its kernel executed are
    those of ``notebooks/<name>.ipynb`` as committed (:func:`committed_code`), in order, once each; its kernel ran
    with one BLAS and one OpenMP thread (:data:`~compendium.provenance.ONE_THREAD`); its parameters are the
    published ones; it wrote every file the contract declares for the notebook and nothing else. Anything
    else raises :class:`PublishError` naming the reason.
    """
    import json
    import os
    import shutil

    folder = Path(folder)
    records = sorted((folder / RUNS).glob("*.json"))
    if len(records) != 1:
        raise PublishError(f"{folder} holds {len(records)} run records; a run folder holds one (is the run complete?)")
    record = json.loads(records[0].read_text())
    notebook = record["notebook"]
    tracked = paths.notebooks_dir() / f"{notebook}.ipynb"
    if not tracked.is_file():
        raise PublishError(f"{notebook} is not a notebook of the compendium ({tracked} does not exist)")
    if record.get("code") is None:
        raise PublishError(f"the run of {notebook} in {folder} recorded no executed code (not run in a Jupyter kernel)")
    code, what = committed_code(notebook)
    if record["code"] != code:
        raise PublishError(
            f"the code the kernel ran in {folder} is not that of {what}: an edited or copied notebook, or cells run "
            "out of order (commit the notebook, restart the kernel and run all cells)"
        )
    ran = record.get("threads")
    if ran != ONE_THREAD:
        said = ", ".join(f"{k}={'unset' if v is None else v}" for k, v in (ran or {}).items()) or "no record of threads"
        needed = ", ".join(f"{k}={v}" for k, v in ONE_THREAD.items())
        raise PublishError(
            f"the run of {notebook} in {folder} ran with {said}: the published record is computed with {needed}, as "
            "make exports them and the ocpkit kernel is registered with them (make setup), since a refinement's path "
            "depends on the last bits of its solves; publish a run of make reproduce or make store, or of a kernel "
            "registered by make setup"
        )
    published = published_parameters(notebook)
    if record["parameters"] != json.loads(json.dumps(published)):
        changed = sorted(k for k in published if record["parameters"].get(k) != json.loads(json.dumps(published[k])))
        raise PublishError(f"the run of {notebook} in {folder} has other parameters than the published run: {changed}")
    contract = load_contract()
    if notebook not in contract:
        raise PublishError(f"notebooks/contract.toml has no section for {notebook}: declare what it publishes")
    declared, written = set(contract[notebook].files()), set(record["files"])
    if declared != written:
        raise PublishError(
            f"the run of {notebook} in {folder} did not write what the contract declares: "
            f"missing {sorted(declared - written)[:5]}, undeclared {sorted(written - declared)[:5]}"
        )
    missing = [rel for rel in record["files"] if not (folder / rel).is_file()]
    if missing:
        raise PublishError(f"the run of {notebook} in {folder} lists files it does not hold: {missing[:5]}")
    root = paths.repo_root()
    for rel in record["files"]:
        target = root / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = target.with_name(f".{target.name}.{os.getpid()}")
        shutil.copyfile(folder / rel, tmp)
        os.replace(tmp, target)
    (root / RUNS).mkdir(parents=True, exist_ok=True)
    shutil.copyfile(records[0], root / RUNS / f"{notebook}.json")
    return list(record["files"])


def store(path: str | Path, *, kernel: str = KERNEL_NAME, progress: bool = False) -> tuple[Path, bool]:
    """Re-execute a notebook in place with its default parameters (the nbval reference outputs).

    Where the defaults are the published parameters, the run is published (:func:`publish_run`). Returns the
    run's folder and whether it was published.
    """
    path = Path(path)
    execute(path, path, {}, kernel=kernel, cwd=path.parent, progress=progress)
    strip_volatile_metadata(path)
    defaults = literal_parameters(path)
    folder = run_folder(path.stem, defaults)
    publishes = defaults == published_parameters(path.stem)
    if publishes:
        publish_run(folder)
    return folder, publishes


def reproduce(
    notebooks: list[Path],
    output: str | Path,
    *,
    kernel: str = KERNEL_NAME,
    report: str | Path | None = None,
    jobs: int = 1,
) -> dict[Path, Unfinished]:
    """The published runs: each notebook executed with its published parameters (notebooks/published.toml) into
    ``output``, and its run published (:func:`publish_run`); then, if ``report`` names a folder, the report of the
    executed notebooks in it (:func:`compendium.report.build_report`). The executed notebooks an earlier call left
    in ``output`` (those papermill wrote; a notebook put there by hand stays, and is reported too) are removed first.

    Everything is checked before anything is removed or run, and every problem named in one ``ValueError``: each
    notebook exists and is one of the compendium's ``notebooks/`` (only those publish; one given twice runs once),
    ``published.toml`` gives its parameters as Python literals and the notebook declares them, and ``output`` and
    ``report`` are folders (or do not exist yet), ``output`` not the notebooks' own.

    A notebook that stops (a cell raised, a check failed, the kernel died) or whose complete run may not be published
    publishes nothing; the others still run, the report is still built, with the reason on that notebook's page, and
    the reasons are returned, ``{notebook: Unfinished}``, empty when every run completed and was published. They are
    also written beside the executed notebooks (:data:`compendium.report.UNFINISHED`), so that a report built from
    them later says the same.

    ``jobs``: how many notebooks run at once, each in a process of its own (its kernel's environment is its own), the
    longest expected first (:func:`~compendium.progress.longest_first`); each run is published by this process as it
    ends. One (the default) runs them in the order given, with each notebook's bar over its cells.
    """
    import json

    output = Path(output)
    published = _checked_runs(notebooks, output, None if report is None else Path(report))
    measured = measured_durations(output, {nb.stem: params for nb, params in published.items()})
    eta = NotebookETA(notebook_estimates([nb.stem for nb in published], measured, prior_durations()))
    if output.is_dir():
        for path in sorted(output.glob("*.ipynb")):
            if _executed_by_papermill(path):
                path.unlink()
        (output / UNFINISHED).unlink(missing_ok=True)
    failed: dict[Path, Unfinished] = {}

    def settle(nb: Path, stopped: tuple[str, str] | None) -> None:
        """Publish a run that completed; record and say why one did not (every kind of stop is reported, and none
        stops the other notebooks)."""
        executed = output / nb.name
        if stopped is None:
            try:
                files = publish_run(run_folder(nb.stem, _run_parameters(nb, published[nb])))
            except PublishError as exc:
                failed[nb] = Unfinished("not published", str(exc))
                _say(f"FAILED {nb}: {failed[nb].sentence()}")
                return
            except Exception as exc:  # noqa: BLE001 - reported as a stop, with where it came from
                stopped = (_error(exc), traceback.format_exc().rstrip())
            else:
                _say(f"executed {nb} -> {executed}; published {len(files)} files")
                return
        line, where = stopped
        failed[nb] = Unfinished("stopped" if executed.is_file() else "did not run", line)
        _say(f"FAILED {nb}: {failed[nb].sentence()}")
        if where:
            _say(where)  # not a stop the notebook explains: where it came from

    if jobs <= 1 or len(published) <= 1:
        for nb in _each(list(published), "reproduce", eta):
            settle(nb, _execute_run(nb, output / nb.name, published[nb], kernel, True))
    else:
        _reproduce_at_once(published, output, kernel, jobs, eta, settle)
    failed = {nb: failed[nb] for nb in published if nb in failed}  # in the order given, whichever ended first
    if failed:
        output.mkdir(parents=True, exist_ok=True)
        (output / UNFINISHED).write_text(json.dumps({nb.name: list(u) for nb, u in failed.items()}, indent=1))
    if report is not None:
        index = build_report(output, report)
        ran = f" ({len(failed)} of {len(published)} notebooks failed)" if failed else ""
        _say(f"report: {index}{ran}")
    return failed


def _execute_run(nb: Path, executed: Path, params: dict, kernel: str, progress: bool) -> tuple[str, str] | None:
    """Execute one published run (:func:`reproduce`; in a process of its own where several run at once): None, or
    why it stopped, in a line (:func:`_error`), and where it came from where the notebook does not explain it."""
    try:
        execute(nb, executed, params, kernel=kernel, progress=progress)
    except Exception as exc:  # noqa: BLE001 - every kind of stop is reported by reproduce
        explained = type(exc).__name__ == "PapermillExecutionError"
        return _error(exc), "" if explained else traceback.format_exc().rstrip()
    return None


#: Notebooks whose published run reads another's published record, and that other: with ``--jobs``, each starts only
#: once the run it reads has been settled (published or not), so that it reads what a run one at a time would
#: (:func:`compendium.studies.direct_to_indirect` reads notebook 05's energy solutions from ``data/derived``).
READS_PUBLISHED = {"10_direct_to_indirect": ("05_orbit_transfer",)}


def _reproduce_at_once(
    published: dict[Path, dict],
    output: Path,
    kernel: str,
    jobs: int,
    eta: NotebookETA,
    settle: Callable[[Path, tuple[str, str] | None], None],
) -> None:
    """:func:`reproduce`'s runs, ``jobs`` at once, each in a process of its own, the longest first, a run that reads
    another's published record after it (:data:`READS_PUBLISHED`); each settled here as it ends, under a bar over
    the notebooks finished. Each run has a one-process pool of its own, so a process that dies (``BrokenProcessPool``)
    stops only its own run: the runs beside it go on, and the notebooks left start as before. (In one shared pool, a
    death fails every run in it, and a run submitted after the death but before its future reports it is refused.)"""
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    from tqdm import tqdm

    by_name = {nb.stem: nb for nb in published}
    order, expected = longest_first(list(by_name), eta.estimates, jobs, READS_PUBLISHED)
    _say(
        f"reproduce: {len(order)} notebooks, {jobs} at once, the longest expected first ({', '.join(order)}); "
        f"expected ~{duration(expected)} from the estimates"
    )
    waiting, settled = list(order), set()
    running: dict[Future, tuple[Path, ProcessPoolExecutor]] = {}
    pools: set[ProcessPoolExecutor] = set()  # each run's own, until its run is settled
    bar = tqdm(total=len(order), desc="reproduce", file=sys.stderr, bar_format=_BAR, dynamic_ncols=True)
    context = multiprocessing.get_context("spawn")  # a fresh interpreter: nothing of this process's state shared
    try:
        while waiting or running:
            ready = [n for n in waiting if all(d in settled or d not in by_name for d in READS_PUBLISHED.get(n, ()))]
            for name in ready[: max(jobs - len(running), 0)]:
                waiting.remove(name)
                nb = by_name[name]
                pool = ProcessPoolExecutor(max_workers=1, mp_context=context)
                pools.add(pool)
                running[pool.submit(_execute_run, nb, output / nb.name, published[nb], kernel, False)] = (nb, pool)
            if not running:  # (cannot happen with READS_PUBLISHED as it is: no notebook waits on itself)
                raise RuntimeError(f"reproduce: {', '.join(waiting)} wait on each other (READS_PUBLISHED)")
            bar.set_postfix_str(", ".join(nb.stem for nb, _ in running.values()))
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in done:
                nb, pool = running.pop(future)
                try:
                    stopped = future.result()
                except BrokenProcessPool as exc:
                    stopped = (f"its process ended abruptly ({exc})", "")
                finally:
                    pool.shutdown(wait=False)
                    pools.discard(pool)
                settle(nb, stopped)
                settled.add(nb.stem)
                bar.update()
    finally:
        for pool in pools:  # (an interrupt: every run still going is waited for, the pools stopped together)
            pool.shutdown(wait=False, cancel_futures=True)
        for pool in pools:
            pool.shutdown(wait=True)
        bar.close()


def _checked_runs(notebooks: list[Path], output: Path, report: Path | None) -> dict[Path, dict]:
    """Each notebook's published parameters, checked (:func:`reproduce`): every problem found, in one ``ValueError``."""
    problems: list[str] = []
    for option, folder in (("--output", output), ("--report", report)):
        if folder is not None and folder.exists() and not folder.is_dir():
            problems.append(f"{option} {folder} is a file, not a folder")
    home = paths.notebooks_dir().resolve()
    if output.resolve() == home:
        problems.append(f"--output {output} is the notebooks' own folder: the executed notebooks would replace them")
    published: dict[Path, dict] = {}
    seen: set[Path] = set()
    for nb in notebooks:
        if not nb.is_file():
            problems.append(f"{nb}: no such notebook")
            continue
        if nb.resolve() in seen:
            continue  # given twice: run once
        seen.add(nb.resolve())
        if nb.resolve().parent != home:
            problems.append(f"{nb}: not one of the compendium's notebooks ({home}): only those publish")
            continue
        try:
            published[nb] = published_overrides(nb)
        except (ValueError, SyntaxError, OSError) as exc:
            problems.append(f"{nb}: its published parameters (notebooks/published.toml): {exc}")
            continue
        try:
            check_parameters(nb, published[nb])
        except (ValueError, SyntaxError, OSError) as exc:
            problems.append(f"{nb}: {exc}")
    if problems:
        raise ValueError("nothing was run:\n  " + "\n  ".join(problems))
    return published


def _check_each(notebooks: list[Path], given: dict) -> None:
    """``given`` checked against every notebook's parameters cell before any kernel starts
    (:func:`~compendium.notebook_source.check_parameters`): every problem found, in one ``ValueError``."""
    problems = []
    for nb in notebooks:
        if not nb.is_file():
            problems.append(f"{nb}: no such notebook")
            continue
        try:
            check_parameters(nb, given)
        except ValueError as exc:
            problems += str(exc).splitlines()
    if problems:
        raise ValueError("nothing was run:\n  " + "\n  ".join(problems))


def _executed_by_papermill(path: Path) -> bool:
    """Whether ``path`` is a notebook papermill wrote (its record in the metadata): one :func:`reproduce` may remove."""
    import json

    try:
        return "papermill" in json.loads(path.read_text(encoding="utf-8")).get("metadata", {})
    except (OSError, ValueError, AttributeError):
        return False


def _error(exc: Exception) -> str:
    """An error that stopped a run, in a line: the cell and its error for a cell that raised."""
    if type(exc).__name__ == "PapermillExecutionError":
        return _cell_error(exc)
    return f"{type(exc).__name__}: {exc}"


def _cell_error(exc: Exception) -> str:
    """papermill's error, in a line: the cell that raised and its error."""
    return f"the notebook stopped in cell {exc.exec_count}: {exc.ename}: {exc.evalue}"  # type: ignore[attr-defined]


def _jobs(text: str) -> int:
    """``--jobs``: a count (0 or 1: one at a time), or ``auto``, one per core."""
    import os

    if text == "auto":
        return max(os.cpu_count() or 1, 1)
    try:
        return max(int(text), 1)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--jobs takes a count or auto, got {text!r}") from None


def _parse_value(text: str):
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


#: the runner's bar over the notebooks: how many have run, and the time elapsed (not tqdm's average-based estimate)
_BAR = "{desc}: {n_fmt}/{total_fmt} notebooks |{bar:12}| {elapsed} elapsed{postfix}"


def _each(notebooks, verb: str, eta: NotebookETA | None = None):
    """The notebooks with a bar over them (one line per finished notebook stays). With ``eta``, the time each
    notebook and all those left are expected to take, in a line when each starts and on the bar (tqdm's own
    estimate, an average over notebooks, is left out)."""
    from tqdm import tqdm

    fmt = None if eta is None else _BAR
    bar = tqdm(notebooks, desc=verb, unit="notebook", file=sys.stderr, bar_format=fmt, dynamic_ncols=True)
    for nb in bar:
        if eta is None:
            bar.set_postfix_str(nb.name)
        else:
            line = eta.line(nb.stem)
            _say(line)
            bar.set_postfix_str(line)
        yield nb


def _say(line: str) -> None:
    from tqdm import tqdm

    tqdm.write(line, file=sys.stderr)


def _where(folder: Path) -> str:
    try:
        return f"{folder.resolve().relative_to(paths.repo_root())}/"
    except ValueError:
        return f"{folder}/"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m compendium.notebooks", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run_p = sub.add_parser("run", help="execute notebooks headless, each into its own run folder (never published)")
    run_p.add_argument("notebooks", nargs="+", type=Path)
    run_p.add_argument("--output", type=Path, default=None, help="the folder of run folders (default build/runs)")
    run_p.add_argument("-p", "--parameter", nargs=2, action="append", default=[], metavar=("NAME", "VALUE"))
    run_p.add_argument("--kernel", default=KERNEL_NAME)
    rp = sub.add_parser(
        "reproduce",
        help="the published runs: each notebook with the parameters of notebooks/published.toml, then published",
    )
    rp.add_argument("notebooks", nargs="+", type=Path)
    rp.add_argument(
        "--output",
        type=Path,
        default=Path("build/notebooks"),
        help="the executed notebooks (default build/notebooks; the ones an earlier run left there are replaced)",
    )
    rp.add_argument("--kernel", default=KERNEL_NAME)
    rp.add_argument("--report", type=Path, default=None, help="also build the report of the runs into this folder")
    rp.add_argument(
        "--jobs",
        type=_jobs,
        default=1,
        help="how many notebooks run at once, each in its own process, the longest first (auto: one per core)",
    )
    st = sub.add_parser("store", help="re-execute notebooks in place with default parameters (published if those are)")
    st.add_argument("notebooks", nargs="+", type=Path)
    st.add_argument("--kernel", default=KERNEL_NAME)
    pb = sub.add_parser("publish", help="copy complete runs of the committed notebooks into the published record")
    pb.add_argument("runs", nargs="+", type=Path)
    rep = sub.add_parser("report", help="HTML report of executed notebooks")
    rep.add_argument("executed", type=Path)
    rep.add_argument("--output", type=Path, default=Path("build/report"))
    args = parser.parse_args(argv)

    try:
        if args.command == "run":
            given = {k: _parse_value(v) for k, v in args.parameter}
            _check_each(args.notebooks, given)
            for nb in _each(args.notebooks, "run"):
                folder, outputs = run(nb, given, runs=args.output, kernel=args.kernel, progress=True)
                if outputs.resolve() == folder.resolve():
                    _say(f"executed {nb}: the executed notebook, figures and tables are in {_where(folder)}")
                else:
                    _say(f"executed {nb} into {_where(folder)}; its figures and tables are in {_where(outputs)}")
        elif args.command == "reproduce":
            failed = reproduce(args.notebooks, args.output, kernel=args.kernel, report=args.report, jobs=args.jobs)
            if failed:
                for nb, reason in failed.items():
                    print(f"error: {nb} {reason.sentence()}", file=sys.stderr)
                return 1
        elif args.command == "store":
            for nb in _each(args.notebooks, "store"):
                folder, published = store(nb, kernel=args.kernel, progress=True)
                what = "and published its run" if published else f"(its run, with other parameters: {_where(folder)})"
                _say(f"stored outputs of {nb} {what}")
        elif args.command == "publish":
            for folder in args.runs:
                files = publish_run(folder)
                _say(f"published {len(files)} files from {_where(folder)}")
        else:
            print(f"report: {build_report(args.executed, args.output)}")
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:  # a cell that raised: papermill's error names it; the executed notebook shows it
        if type(exc).__name__ != "PapermillExecutionError":
            raise
        print(f"error: {_cell_error(exc)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
