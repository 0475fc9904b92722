"""Repository-relative paths, independent of the working directory.

Inputs (``data/problems``, ``data/paper``) are always read from the repository.
Where a notebook run writes its figures and tables is decided by
:mod:`compendium.outputs` (the published record, ``build/runs/``, or
``OCPKIT_OUTPUT_DIR``), never by a module writing on its own.
"""

from __future__ import annotations

import os
from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent


def repo_root() -> Path:
    """The compendium's root folder (the one holding ``data/`` and ``notebooks/``).

    ``OCPKIT_ROOT`` overrides the location found from this package
    (``src/compendium`` lives two levels below the root).
    """
    env = os.environ.get("OCPKIT_ROOT")
    root = Path(env).resolve() if env else _PACKAGE_DIR.parents[1]
    if not (root / "data").is_dir():
        raise FileNotFoundError(
            f"cannot find the compendium's data/ folder under {root}; "
            "use the repository's environment (make setup puts src/ on its path) "
            "or set OCPKIT_ROOT to the repository root"
        )
    return root


def data_dir() -> Path:
    return repo_root() / "data"


def problem_data_dir() -> Path:
    """Constants of the test problems (TOML files with their provenance)."""
    return data_dir() / "problems"


def paper_dir() -> Path:
    """Published values transcribed from the source documents (CSV)."""
    return data_dir() / "paper"


def notebooks_dir() -> Path:
    return repo_root() / "notebooks"


def _ensure(path: Path) -> Path:
    path.mkdir(parents=True, exist_ok=True)
    return path


def published_derived_dir() -> Path:
    """The published tables, ``data/derived/`` of the repository (read-only for the studies: caches)."""
    return data_dir() / "derived"


def build_dir() -> Path:
    """Untracked build products: executed notebooks, runs with other parameters, report, benchmark tables."""
    return _ensure(repo_root() / "build")
