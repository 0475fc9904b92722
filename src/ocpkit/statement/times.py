"""Free times of a statement: a free initial time, a free final time, a phase's duration."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .bounds import as_interval


@dataclass(frozen=True)
class FreeFinalTime:
    """A free final time ``tf`` in ``[lower, upper]``; the NLP holds ``tf / scale``."""

    lower: float
    upper: float
    guess: float
    scale: float = 1.0

    _what = "final time"

    def __post_init__(self) -> None:
        lo, hi = as_interval((self.lower, self.upper), f"{self._what} bounds")
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise ValueError(f"{self._what} bounds must be finite, got [{lo}, {hi}]")
        if not lo <= self.guess <= hi:
            raise ValueError(f"{self._what} guess {self.guess} lies outside [{lo}, {hi}]")
        if not (self.scale > 0 and math.isfinite(self.scale)):
            raise ValueError(f"{self._what} scale must be positive and finite, got {self.scale}")


@dataclass(frozen=True)
class FreeInitialTime(FreeFinalTime):
    """A free initial time ``t0`` in ``[lower, upper]`` (below every admissible final time)."""

    _what = "initial time"


@dataclass(frozen=True)
class Duration(FreeFinalTime):
    """A free final time given by the phase's duration: ``tf = t0 + d`` with ``d`` in ``[lower, upper]``
    (``lower > 0``); the NLP holds ``d / scale``. With a free initial time (:class:`FreeInitialTime`) the windows
    of consecutive phases may overlap, each phase's start and duration bounded apart (as GPOPS-II and Dymos
    parametrise phases); with a fixed t0 it is ``FreeFinalTime(t0 + lower, t0 + upper, t0 + guess)``."""

    _what = "duration"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.lower > 0:
            raise ValueError(f"a duration's lower bound must be positive, got {self.lower}")
