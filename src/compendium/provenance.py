"""Where a run came from and where it went: the git checkout, the machine and packages, and the run records.

What :mod:`compendium.outputs` writes into a run's record and :mod:`compendium.report` shows beside it, and what
:mod:`compendium.notebooks` and :mod:`compendium.guard` read back: the commit a run was of and what was changed since
(:func:`git_state`), the machine and the versions of :data:`PACKAGES` (:func:`environment`), the folder of a run's
records (:data:`RUNS`, :func:`read_run_record`, :data:`RUN_RECORD_KEY`) and the folder a run writes
(:func:`run_folder`, named by :func:`run_key` under :func:`runs_root`). Below it only :mod:`compendium.paths` and :mod:`compendium.notebook_source`.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import re
import subprocess
from pathlib import Path

from . import paths
from .notebook_source import default_parameters

#: the packages whose versions a report names
PACKAGES = ("casadi", "numpy", "scipy", "matplotlib", "pandas", "ocpkit")
#: the published record: what the notebooks' published runs rewrite (not the code or inputs a run is of)
RECORD = ("figures/", "data/derived/")
#: the folder of run records, in a run's folder and in the published record
RUNS = Path("data") / "derived" / "runs"
#: The threads the published record is computed with: one BLAS (OpenBLAS) and one OpenMP thread, as the Makefile
#: exports them and :func:`compendium.notebooks.execute` sets them for every kernel it starts. A refinement's path
#: depends on the last bits of its solves, which the BLAS's threads change: COPS's hang glider from global Radau 60
#: took 14 meshes and 1028 points in a run started by hand with OpenBLAS' own threads, 10 and 731 under ``make``.
#: A run's record keeps what its kernel had (:func:`threads`), and only a run with these publishes.
ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
#: the key of an executed notebook's metadata under which the runner keeps the record of the run it shows
#: (:func:`compendium.notebooks.execute`; ``null``: the run wrote none, it did not complete)
RUN_RECORD_KEY = "compendium_run_record"

# -- the machine and its software ------------------------------------------------------------------------------------


def environment() -> dict:
    """The machine and the software of this process (``make reproduce`` runs the notebooks on the ``ocpkit``
    kernel, the same environment): platform, CPU, Python and the versions of :data:`PACKAGES`."""
    from importlib import metadata

    versions = {}
    for name in PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return {
        "platform": platform.platform(),
        "cpu": f"{_cpu_model()}, {os.cpu_count()} logical CPUs",
        "python": f"{platform.python_implementation()} {platform.python_version()}",
        "packages": versions,
    }


def threads() -> dict[str, str | None]:
    """This process's thread settings of :data:`ONE_THREAD` (``None`` for one not set): what a run's record keeps."""
    return {name: os.environ.get(name) for name in ONE_THREAD}


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


# -- the checkout ----------------------------------------------------------------------------------------------------


def git_state(root: Path | None = None) -> dict | None:
    """The commit checked out in ``root`` (default the repository), its date, the tracked files changed since but
    for the published record (``changed``; ``dirty`` if any) and the files of the record changed since (``record``:
    rewritten by runs, as ``make reproduce``'s are on another machine); ``None`` outside a git checkout."""
    root = Path(root) if root is not None else paths.repo_root()

    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True)
        except OSError:  # no git on this machine
            return None
        return done.stdout if done.returncode == 0 else None

    top = git("rev-parse", "--show-toplevel")
    if top is None or Path(top.strip()).resolve() != root.resolve():  # a copy inside another repository's tree
        return None
    commit = git("rev-parse", "HEAD")
    if commit is None:
        return None
    every = [line[3:] for line in (git("status", "--porcelain", "--untracked-files=no") or "").splitlines()]
    record = [f for f in every if f.startswith(RECORD)]
    changed = [f for f in every if f not in record]
    date = (git("log", "-1", "--format=%cI", "HEAD") or "").strip()
    return {"commit": commit.strip(), "date": date, "dirty": bool(changed), "changed": changed, "record": record}


# -- run folders and their records -----------------------------------------------------------------------------------

_SLUG = re.compile(r"[A-Za-z0-9.+-]+")


def run_key(notebook: str, parameters: dict, defaults: dict | None = None) -> str:
    """The name of a run's folder: ``defaults``, or the parameters that differ from the defaults.

    ``segments=40`` gives ``segments-40``; a value that is not a short plain word (a list, a path) is named by a
    digest of its ``repr``, and a key longer than 80 characters by a digest of all of it: the run's record holds
    the parameters themselves. ``defaults``: the notebook's (read from ``notebooks/<notebook>.ipynb`` if not given).
    """
    defaults = default_parameters(notebook) if defaults is None else defaults
    changed = {k: v for k, v in parameters.items() if k in defaults and v != defaults[k]}
    if not changed:
        return "defaults"
    parts = []
    for name, value in sorted(changed.items()):
        text = repr(value)
        if not _SLUG.fullmatch(text) or len(text) > 24:
            text = hashlib.sha256(text.encode()).hexdigest()[:8]
        parts.append(f"{name}-{text}")
    key = "_".join(parts)
    if len(key) > 80:
        key = "p-" + hashlib.sha256(repr(sorted(changed.items())).encode()).hexdigest()[:12]
    return key


def runs_root() -> Path:
    """The folder of run folders: ``OCPKIT_RUNS_DIR``, else ``build/runs`` of the repository."""
    given = os.environ.get("OCPKIT_RUNS_DIR")
    return Path(given).resolve() if given else paths.repo_root() / "build" / "runs"


def run_folder(notebook: str, parameters: dict, runs: Path | None = None, defaults: dict | None = None) -> Path:
    """Where a run of ``notebook`` with ``parameters`` writes: ``OCPKIT_OUTPUT_DIR`` when set, else its folder under
    ``runs`` (default :func:`runs_root`)."""
    explicit = os.environ.get("OCPKIT_OUTPUT_DIR")
    if explicit:
        return Path(explicit).resolve()
    key = run_key(notebook, parameters, defaults)
    return (Path(runs).resolve() if runs is not None else runs_root()) / notebook / key


def read_run_record(root: Path, notebook: str) -> dict:
    """The record :meth:`compendium.outputs.Outputs.publish` wrote for ``notebook`` under ``root``."""
    return json.loads((Path(root) / RUNS / f"{notebook}.json").read_text())
