"""The variables of a statement: states, controls and free parameters, with bounds and an affine NLP scaling."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast, overload

import casadi as ca
import numpy as np

from .bounds import Bound, GuessSpec, as_interval, fixed_value, guess_function, midpoint

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


@dataclass(frozen=True)
class AffineScaling:
    """NLP variables ``(value - shift) / scale``, component by component."""

    shift: np.ndarray
    scale: np.ndarray

    @classmethod
    def of(cls, variables: Sequence[Variable]) -> AffineScaling:
        """The scaling of a sequence of :class:`Variable`."""
        return cls(
            np.array([v.shift for v in variables], dtype=float), np.array([v.scale for v in variables], dtype=float)
        )

    def subset(self, index: Sequence[int] | np.ndarray) -> AffineScaling:
        return AffineScaling(self.shift[index], self.scale[index])

    def to_nlp(self, values: ArrayLike) -> np.ndarray:
        """Physical values (last axis = components) to NLP values."""
        return (np.asarray(values, dtype=float) - self.shift) / self.scale

    @overload
    def from_nlp(self, z: ca.SX) -> ca.SX: ...

    @overload
    def from_nlp(self, z: ca.MX) -> ca.MX: ...

    @overload
    def from_nlp(self, z: ArrayLike) -> np.ndarray: ...

    def from_nlp(self, z: ca.SX | ca.MX | ArrayLike) -> ca.SX | ca.MX | np.ndarray:
        """NLP values to physical values; ``z`` may be a numpy array or a CasADi column."""
        if isinstance(z, (ca.SX, ca.MX)):
            if z.numel() == 0:
                return type(z)(0, 1)
            return z * ca.DM(self.scale) + ca.DM(self.shift)
        return np.asarray(z, dtype=float) * self.scale + self.shift


@dataclass(frozen=True)
class Variable:
    """A named scalar variable with box bounds and an affine scaling.

    The NLP works with ``(value - shift) / scale``; choose them so the NLP
    variable is of order one over the range the variable actually spans (for
    a radius that stays within 3 km of the planet's, shift by the radius and
    scale by the 3 km).
    """

    name: str
    lower: float = -math.inf
    upper: float = math.inf
    scale: float = 1.0
    shift: float = 0.0
    guess: GuessSpec = None
    unit: str = ""
    description: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise ValueError(f"variable name must be an identifier, got {self.name!r}")
        as_interval((self.lower, self.upper), f"bounds of {self.name!r}")
        if not (self.scale > 0 and math.isfinite(self.scale)):
            raise ValueError(f"scale of {self.name!r} must be positive and finite, got {self.scale}")
        if not math.isfinite(self.shift):
            raise ValueError(f"shift of {self.name!r} must be finite, got {self.shift}")
        guess_function(self.guess, f"guess of {self.name!r}")  # validates

    def _default_guess(self) -> Callable[[Any, Any], np.ndarray]:
        """Midpoint of the bounds (or the finite bound, or 0), as a guess function."""
        return guess_function(midpoint(self.lower, self.upper), self.name)

    def guess_function(self) -> Callable[[Any, Any], np.ndarray]:
        """This variable's guess as a function ``(s, t) -> values``."""
        return guess_function(self.guess, f"guess of {self.name!r}") or self._default_guess()

    def guess_at(self, s: ArrayLike) -> np.ndarray:
        """The guess at normalised times ``s`` in [0, 1] (not for callable guesses, which need physical times)."""
        return self.guess_function()(np.asarray(s, dtype=float), None)


@dataclass(frozen=True)
class EndValues(Variable):
    """A variable with optional values at the phase's ends, ``initial`` at t0 and ``final`` at tf (each a
    :data:`~ocpkit.statement.bounds.Bound`: free, a value, or a ``(lower, upper)`` interval), within its bounds."""

    initial: Bound = None
    final: Bound = None

    def __post_init__(self) -> None:
        super().__post_init__()
        for which in ("initial", "final"):
            lo, hi = as_interval(getattr(self, which), f"{which} condition of {self.name!r}")
            if lo > self.upper or hi < self.lower:
                raise ValueError(
                    f"{which} condition of {self.name!r} ({getattr(self, which)!r}) lies outside "
                    f"its bounds [{self.lower}, {self.upper}]"
                )

    def boundary_interval(self, which: str) -> tuple[float, float]:
        """Bounds at t0 (``which='initial'``) or tf (``'final'``), intersected with the path bounds."""
        lo, hi = as_interval(getattr(self, which), which)
        return max(lo, self.lower), min(hi, self.upper)

    @property
    def has_end_values(self) -> bool:
        """Whether an initial or a final condition is given."""
        return self.initial is not None or self.final is not None

    @property
    def fixed_initial(self) -> float | None:
        """The initial value when it is fixed, else None."""
        return fixed_value(self.initial)

    @property
    def fixed_final(self) -> float | None:
        """The final value when it is fixed, else None."""
        return fixed_value(self.final)


@dataclass(frozen=True)
class State(EndValues):
    """A state with optional initial and final conditions (see :data:`~ocpkit.statement.bounds.Bound`)."""

    def _default_guess(self) -> Callable[[Any, Any], np.ndarray]:
        """Linear from the fixed initial to the fixed final value (either alone: constant), else the bounds."""
        a, b = self.fixed_initial, self.fixed_final
        if a is None:
            if b is None:
                return super()._default_guess()
            a = b
        elif b is None:
            b = a
        return guess_function((a, b), self.name)


@dataclass(frozen=True)
class Control(EndValues):
    """A control with box bounds, and optional values at the phase's ends (``initial``, ``final``: a cart-pole that
    ends with no force, ``Control("f", -20, 20, final=0.0)``). Each transcription holds an end value where it has a
    control point there, by the point's bounds, and by its control interpolant where it has none (Radau at tf).

    Attributes
    ----------
    period : float or None
        Set for an angle, or any control the problem's functions see only through periodic functions of this
        period (``Control("beta", period=2 * math.pi)``). The NLP may then move a node's value by whole periods at
        no cost (orbit raising on Radau 4 x 20: node values 233.7, -109.7 and -417 degrees in one interval), and a
        polynomial through such values sweeps whole turns between the nodes. A solution's control interpolant
        unwraps each interval's node values first (:func:`unwrap_periodic`): between nodes it takes the short way
        round, which is the control the dynamics saw. Give such a control no bounds, or bounds at least a period
        apart (bounds closer than that hold it within them, and it is reported as any bounded control).

        A solution reports such a control as a continuous angle (``control``, ``sample``, ``to_dataframe``, and
        what is drawn of them): unwrapped along the trajectory, so that it never jumps by a whole period (where
        the control does jump, at a breakpoint, by the short way round, at most half a period), and shifted by
        whole periods so that its value at the first phase's t0 lies in the declared turn ``[a, a + period)``
        (:func:`declared_turn`: ``a`` the lower bound when finite, else the upper bound less a period when
        finite, else ``-period / 2``); a later phase continues the one before. The dynamics see the control only
        through periodic functions, so re-integration and the flown cost are the same as for the wrapped
        values; the control may then leave ``[lower, upper]`` by whole periods, as an angle unwrapped does. The
        NLP's node values (``control_values``) are the NLP's own.
    """

    period: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.period is not None and not (math.isfinite(self.period) and self.period > 0):
            raise ValueError(f"period of {self.name!r} must be positive and finite, got {self.period!r}")


def declared_turn(control: Control) -> float | None:
    """The start ``a`` of the turn ``[a, a + period)`` a periodic control (:attr:`Control.period`) is reported in at
    the start of a solution: its lower bound when finite, else its upper bound less a period when finite, else
    ``-period / 2``. None for a control that is not periodic or whose bounds are less than a period apart (they
    hold it, not its period)."""
    period = control.period
    if period is None or not control.upper - control.lower >= period:
        return None
    if math.isfinite(control.lower):
        return float(control.lower)
    if math.isfinite(control.upper):
        return float(control.upper) - period
    return -period / 2


def wrap_periodic(values: ArrayLike, controls: Sequence[Control]) -> np.ndarray:
    """``values`` (controls on the last axis) with every periodic control that has a finite bound and bounds at least
    a period apart moved by whole periods into its declared turn (:func:`declared_turn`), which lies within its
    bounds; the others as given. The same angles, as an NLP's bounds admit them."""
    values = np.array(values, dtype=float, copy=True)
    for j, c in enumerate(controls):
        a = declared_turn(c)
        if a is not None and (math.isfinite(c.lower) or math.isfinite(c.upper)):
            period = cast(float, c.period)  # (a declared turn is a periodic control's)
            values[..., j] -= period * np.floor((values[..., j] - a) / period)
    return values


def unwrap_periodic(values: ArrayLike, controls: Sequence[Control], axis: int = 0) -> np.ndarray:
    """``values`` (controls on the last axis) with every periodic control (:attr:`Control.period`) unwrapped along
    ``axis``: consecutive values differ by at most half a period (``numpy.unwrap``)."""
    values = np.array(values, dtype=float, copy=True)
    for j, c in enumerate(controls):
        if c.period is not None and values.shape[axis] > 1:
            values[..., j] = np.unwrap(values[..., j], period=c.period, axis=axis if axis >= 0 else axis + 1)
    return values


@dataclass(frozen=True)
class FreeParameter(Variable):
    """A static parameter the NLP optimises, within ``[lower, upper]``, from a constant ``guess``.

    It reaches the problem's functions with the fixed ``parameters``, in the same dict of
    symbols by name (a design variable, an unknown physical constant).
    """

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.guess is not None and (callable(self.guess) or isinstance(self.guess, (tuple, list))):
            raise ValueError(f"free parameter {self.name!r}: the guess must be a number, got {self.guess!r}")

    @property
    def guess_value(self) -> float:
        # a number: __post_init__ refuses a callable or (start, end) guess
        return float(cast(float, self.guess)) if self.guess is not None else float(midpoint(self.lower, self.upper))
