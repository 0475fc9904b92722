"""Constraints of a statement: path and boundary constraints by name, and their compiled form."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import casadi as ca
import numpy as np


@dataclass(frozen=True)
class Constraint:
    """``lower <= function(...) <= upper``: a path or a boundary constraint, named.

    As a path constraint ``function(x, u, t)`` (``x``, ``u`` CasADi column vectors, and a
    dict of the problem's parameter symbols after ``t`` when it has parameters); as a
    boundary constraint ``function(x0, xf, t0, tf)`` (likewise). It returns one
    expression or a list of them; ``lower`` and ``upper`` are numbers or one per
    expression (equality where they are equal). ``scale``: the NLP holds
    ``function / scale``; choose it so that the constraint is of order one.
    """

    name: str
    function: Callable
    lower: float | Sequence[float] = -math.inf
    upper: float | Sequence[float] = math.inf
    scale: float = 1.0

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise ValueError(f"constraint name must be an identifier, got {self.name!r}")
        if not callable(self.function):
            raise TypeError(f"constraint {self.name!r}: function must be callable, got {type(self.function).__name__}")
        if not (self.scale > 0 and math.isfinite(self.scale)):
            raise ValueError(f"constraint {self.name!r}: scale must be positive and finite, got {self.scale}")

    def bounds(self, size: int) -> tuple[np.ndarray, np.ndarray]:
        """``(lower, upper)`` of a constraint with ``size`` expressions, checked."""
        out = []
        for which in ("lower", "upper"):
            v = np.asarray(getattr(self, which), dtype=float).ravel()
            if v.size == 1:
                v = np.full(size, v[0])
            if v.size != size:
                raise ValueError(f"constraint {self.name!r}: {which} has {v.size} values for {size} expression(s)")
            if np.any(np.isnan(v)):
                raise ValueError(f"constraint {self.name!r}: NaN in {which}")
            out.append(v)
        lo, hi = out
        bad = np.flatnonzero(lo > hi)
        if bad.size:
            raise ValueError(f"constraint {self.name!r}: lower > upper in entry {bad.tolist()}: the bounds cannot hold")
        if np.all(np.isinf(lo)) and np.all(np.isinf(hi)):
            raise ValueError(f"constraint {self.name!r} has no finite bound: give lower, upper or both")
        return lo, hi


def checked_constraints(given: Iterable[Constraint], kind: str) -> tuple[Constraint, ...]:
    """``given`` as a tuple of :class:`Constraint` with distinct names; a TypeError or ValueError naming ``kind``."""
    given = tuple(given)
    for c in given:
        if not isinstance(c, Constraint):
            raise TypeError(f"{kind} must be Constraint objects, got {c!r}")
    names = [c.name for c in given]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"duplicate constraint names in {kind}: {dup}")
    return given


@dataclass(frozen=True)
class ConstraintSet:
    """Compiled constraints of one kind: the stacked function, bounds, names and the rows of each constraint."""

    function: ca.Function
    lower: np.ndarray
    upper: np.ndarray
    scale: np.ndarray
    names: tuple[str, ...]
    sizes: tuple[int, ...]

    @property
    def size(self) -> int:
        return int(sum(self.sizes))

    @property
    def labels(self) -> list[str]:
        """One label per expression, the constraint's name, indexed when it has several."""
        return [n if k == 1 else f"{n}[{i}]" for n, k in zip(self.names, self.sizes) for i in range(k)]
