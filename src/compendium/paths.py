"""Repository-relative paths, independent of the working directory.

Inputs (``data/problems``, ``data/paper``) are always read from the repository.
Outputs (``figures/``, ``data/derived/``) go to the repository too, unless the
environment variable ``OCPKIT_OUTPUT_DIR`` names another root: the test suite
uses it so that running the notebooks under nbval never rewrites tracked files.
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


def output_root() -> Path:
    """Root for generated outputs: ``OCPKIT_OUTPUT_DIR`` if set, else the repository."""
    env = os.environ.get("OCPKIT_OUTPUT_DIR")
    return Path(env).resolve() if env else repo_root()


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


def derived_dir() -> Path:
    """Tables computed by the notebooks (created on demand)."""
    return _ensure(output_root() / "data" / "derived")


def figures_dir() -> Path:
    """Figures written by the notebooks (created on demand)."""
    return _ensure(output_root() / "figures")


def build_dir() -> Path:
    """Untracked build products: executed notebooks, report, benchmark tables."""
    return _ensure(output_root() / "build")
