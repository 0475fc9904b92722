"""Reading problem constants from ``data/problems/<name>.toml``, each file parsed once while it is unchanged."""

from __future__ import annotations

import copy
import threading
import tomllib

from ..paths import problem_data_dir

_PARSED: dict[str, tuple[tuple[int, int], dict]] = {}
_LOCK = threading.Lock()


def load_problem_data(name: str) -> dict:
    """The constants of test problem ``name`` as a nested dict (a fresh copy: the caller may change it).

    The file is parsed on first use and again only when its modification time or size changes, so posing a
    problem many times (a sweep, the explorer) reads it once, and an edit made in a session is still seen.
    """
    path = problem_data_dir() / f"{name}.toml"
    if not path.is_file():
        known = sorted(p.stem for p in problem_data_dir().glob("*.toml"))
        raise FileNotFoundError(f"no problem data {path.name!r}; available: {known}")
    stat = path.stat()
    stamp = (stat.st_mtime_ns, stat.st_size)
    key = str(path)
    with _LOCK:
        cached = _PARSED.get(key)
    if cached is None or cached[0] != stamp:
        with path.open("rb") as fh:
            data = tomllib.load(fh)
        cached = (stamp, data)
        with _LOCK:
            _PARSED[key] = cached
    return copy.deepcopy(cached[1])
