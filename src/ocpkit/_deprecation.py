"""Renamed public names, kept for one release: each use warns (DeprecationWarning) and names the new spelling."""

from __future__ import annotations

import warnings
from typing import TypeVar

_T = TypeVar("_T")


def renamed(old: str, new: str, stacklevel: int = 3) -> None:
    """Warn that ``old`` is deprecated in favour of ``new`` (``stacklevel``: the user's call, counted from here)."""
    warnings.warn(
        f"{old} is deprecated; use {new} (the old name goes in the next release)", DeprecationWarning, stacklevel
    )


def renamed_argument(
    old: str, new: str, old_value: _T | None, new_value: _T | None, default: _T, where: str, stacklevel: int = 4
) -> _T:
    """The value of an argument renamed from ``old`` to ``new`` in ``where``: ``new_value`` unless the deprecated
    ``old_value`` is given (then a DeprecationWarning); both given is a TypeError."""
    if old_value is None:
        return default if new_value is None else new_value
    if new_value is not None:
        raise TypeError(f"{where}: give {new}= only ({old}= is its deprecated name)")
    renamed(f"{where}({old}=...)", f"{new}=...", stacklevel)
    return old_value
