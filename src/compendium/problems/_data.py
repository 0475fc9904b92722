"""Reading problem constants from ``data/problems/<name>.toml``."""

from __future__ import annotations

import tomllib

from ..paths import problem_data_dir


def load_problem_data(name: str) -> dict:
    """The constants of test problem ``name`` as a nested dict."""
    path = problem_data_dir() / f"{name}.toml"
    if not path.is_file():
        known = sorted(p.stem for p in problem_data_dir().glob("*.toml"))
        raise FileNotFoundError(f"no problem data {path.name!r}; available: {known}")
    with path.open("rb") as fh:
        return tomllib.load(fh)
