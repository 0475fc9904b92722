"""Boundary conditions and guesses as a statement gives them, and their one parser each."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, overload

import numpy as np

if TYPE_CHECKING:
    pass

Bound = None | float | tuple[float, float]
"""A boundary condition, one of ``None`` (free), a value (fixed) or a ``(lower, upper)`` tuple."""

GuessSpec = None | float | tuple[float, float] | Callable
"""A guess, one of ``None`` (derived from bounds), a constant, ``(start, end)`` linear in time, or a function of
time."""


def as_interval(spec: Bound, what: str) -> tuple[float, float]:
    """``(lower, upper)`` of a boundary condition or bound pair; the one parser of :data:`Bound`."""
    if spec is None:
        return (-math.inf, math.inf)
    if isinstance(spec, list):
        raise TypeError(
            f"{what}: a list {spec!r} is ambiguous; give a value, or a (lower, upper) tuple for an interval"
        )
    if isinstance(spec, tuple):
        if len(spec) != 2:
            raise ValueError(f"{what}: expected a value or a (lower, upper) tuple, got {spec!r}")
        lo, hi = float(spec[0]), float(spec[1])
    else:
        lo = hi = float(spec)
    if math.isnan(lo) or math.isnan(hi):
        raise ValueError(f"{what}: NaN in {spec!r}")
    if lo > hi:
        raise ValueError(f"{what}: impossible bounds, lower {lo} > upper {hi}")
    return lo, hi


def fixed_value(spec: Bound) -> float | None:
    """The value of a fixed boundary condition, None for a free or interval one."""
    lo, hi = as_interval(spec, "boundary condition")
    return lo if lo == hi else None


@overload
def guess_function(spec: None, what: str) -> None: ...


@overload
def guess_function(
    spec: float | tuple[float, float] | list[float] | Callable[..., Any], what: str
) -> Callable[[Any, Any], np.ndarray]: ...


def guess_function(spec: GuessSpec | list[float], what: str) -> Callable[[Any, Any], np.ndarray] | None:
    """The one parser of :data:`GuessSpec`: a function ``(s, t) -> values`` of normalised and physical time.

    A constant is constant, ``(start, end)`` (a tuple or a two-element list) linear in
    ``s`` in [0, 1], a callable is evaluated at ``t`` (and must return ``t``'s shape);
    ``None`` gives None.
    """
    if spec is None:
        return None
    if callable(spec):

        def from_callable(s: Any, t: Any) -> np.ndarray:
            val = np.asarray(spec(t), dtype=float)
            if val.shape != np.shape(t):
                raise ValueError(f"{what} returned shape {val.shape}, expected {np.shape(t)}")
            return val

        return from_callable
    if isinstance(spec, (tuple, list)):
        if len(spec) != 2:
            raise ValueError(f"{what}: expected a value or (start, end), got {spec!r}")
        a, b = float(spec[0]), float(spec[1])
        return lambda s, t: a + (b - a) * np.asarray(s, dtype=float)
    value = float(spec)
    return lambda s, t: np.full(np.shape(s), value)


def midpoint(lo: float, hi: float) -> float:
    if math.isfinite(lo) and math.isfinite(hi):
        return 0.5 * (lo + hi)
    if math.isfinite(lo):
        return max(lo, 0.0)
    if math.isfinite(hi):
        return min(hi, 0.0)
    return 0.0
