"""Single-phase optimal control problems::

    minimise    phi(x(t0), x(tf), t0, tf) + integral_{t0}^{tf} L(x, u, t) dt
    subject to  dx/dt = f(x, u, t)
                x_lo <= x(t) <= x_hi,  u_lo <= u(t) <= u_hi
                g_lo <= g(x(t), u(t), t) <= g_hi                  (path constraints)
                psi_lo <= psi(x(t0), x(tf), t0, tf) <= psi_hi     (boundary constraints)
                x(t0), x(tf) fixed or bounded component by component
                t0 and tf fixed or free within bounds; static parameters fixed or free.

This is the problem of Desai & Conway, Eqs. (1)-(5): their path constraints
``g(x, u, t) <= 0`` are :class:`Constraint` s of ``path_constraints`` (mixed
state-control allowed), and general event conditions those of
``boundary_constraints``. The definition is independent of any transcription: dynamics,
costs and constraints are Python callables on CasADi symbols, turned into CasADi
Functions once (:class:`ProblemFunctions`, with the parameter vector ``P`` as their
last input) and shared by every transcription and by the shooting engine. A problem is
immutable; :meth:`OptimalControlProblem.replace` makes changed copies, and a
change of parameter values alone reuses the functions.

One argument order throughout: ``f(x, u, t)``, ``L(x, u, t)``,
``phi(x0, xf, t0, tf)``, each with ``P`` last in the functions.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, cast, overload

import casadi as ca
import numpy as np

from .names import Named, NamedParameters, call

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

Bound = None | float | tuple[float, float]
"""A boundary condition, one of ``None`` (free), a value (fixed) or a ``(lower, upper)`` tuple."""

GuessSpec = None | float | tuple[float, float] | Callable
"""A guess, one of ``None`` (derived from bounds), a constant, ``(start, end)`` linear in time, or a function of
time."""


def _as_interval(spec: Bound, what: str) -> tuple[float, float]:
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
    lo, hi = _as_interval(spec, "boundary condition")
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
        _as_interval((self.lower, self.upper), f"bounds of {self.name!r}")
        if not (self.scale > 0 and math.isfinite(self.scale)):
            raise ValueError(f"scale of {self.name!r} must be positive and finite, got {self.scale}")
        if not math.isfinite(self.shift):
            raise ValueError(f"shift of {self.name!r} must be finite, got {self.shift}")
        guess_function(self.guess, f"guess of {self.name!r}")  # validates

    def _default_guess(self) -> Callable[[Any, Any], np.ndarray]:
        """Midpoint of the bounds (or the finite bound, or 0), as a guess function."""
        return guess_function(_midpoint(self.lower, self.upper), self.name)

    def guess_function(self) -> Callable[[Any, Any], np.ndarray]:
        """This variable's guess as a function ``(s, t) -> values``."""
        return guess_function(self.guess, f"guess of {self.name!r}") or self._default_guess()

    def guess_at(self, s: ArrayLike) -> np.ndarray:
        """The guess at normalised times ``s`` in [0, 1] (not for callable guesses, which need physical times)."""
        return self.guess_function()(np.asarray(s, dtype=float), None)


def _midpoint(lo: float, hi: float) -> float:
    if math.isfinite(lo) and math.isfinite(hi):
        return 0.5 * (lo + hi)
    if math.isfinite(lo):
        return max(lo, 0.0)
    if math.isfinite(hi):
        return min(hi, 0.0)
    return 0.0


@dataclass(frozen=True)
class State(Variable):
    """A state with optional initial and final conditions (see :data:`Bound`)."""

    initial: Bound = None
    final: Bound = None

    def __post_init__(self) -> None:
        super().__post_init__()
        for which in ("initial", "final"):
            lo, hi = _as_interval(getattr(self, which), f"{which} condition of {self.name!r}")
            if lo > self.upper or hi < self.lower:
                raise ValueError(
                    f"{which} condition of {self.name!r} ({getattr(self, which)!r}) lies outside "
                    f"its bounds [{self.lower}, {self.upper}]"
                )

    def boundary_interval(self, which: str) -> tuple[float, float]:
        """Bounds at t0 (``which='initial'``) or tf (``'final'``), intersected with the path bounds."""
        lo, hi = _as_interval(getattr(self, which), which)
        return max(lo, self.lower), min(hi, self.upper)

    @property
    def fixed_initial(self) -> float | None:
        """The initial value when it is fixed, else None."""
        return fixed_value(self.initial)

    @property
    def fixed_final(self) -> float | None:
        """The final value when it is fixed, else None."""
        return fixed_value(self.final)

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
class Control(Variable):
    """A control with box bounds.

    Attributes
    ----------
    period : float or None
        Set for an angle, or any control the problem's functions see only through periodic functions of this
        period (``Control("beta", period=2 * math.pi)``). The NLP may then move a node's value by whole periods at
        no cost (orbit raising on Radau 4 x 20: node values 233.7, -109.7 and -417 degrees in one interval), and a
        polynomial through such values sweeps whole turns between the nodes. A solution's control interpolant
        unwraps each interval's node values first (:func:`unwrap_periodic`): between nodes it takes the short way
        round, which is the control the dynamics saw. Give such a control no bounds, or bounds at least a period
        apart.
    """

    period: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.period is not None and not (math.isfinite(self.period) and self.period > 0):
            raise ValueError(f"period of {self.name!r} must be positive and finite, got {self.period!r}")


def unwrap_periodic(values: ArrayLike, controls: Sequence[Control], axis: int = 0) -> np.ndarray:
    """``values`` (controls on the last axis) with every periodic control (:attr:`Control.period`) unwrapped along
    ``axis``: consecutive values differ by at most half a period (``numpy.unwrap``)."""
    values = np.array(values, dtype=float, copy=True)
    for j, c in enumerate(controls):
        if c.period is not None and values.shape[axis] > 1:
            values[..., j] = np.unwrap(values[..., j], period=c.period, axis=axis if axis >= 0 else axis + 1)
    return values


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


@dataclass(frozen=True)
class FreeFinalTime:
    """A free final time ``tf`` in ``[lower, upper]``; the NLP holds ``tf / scale``."""

    lower: float
    upper: float
    guess: float
    scale: float = 1.0

    _what = "final time"

    def __post_init__(self) -> None:
        lo, hi = _as_interval((self.lower, self.upper), f"{self._what} bounds")
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
        return float(cast(float, self.guess)) if self.guess is not None else float(_midpoint(self.lower, self.upper))


@dataclass(frozen=True)
class ProblemFunctions:
    """A problem's CasADi functions, built once; the parameter vector ``P`` is the last input of each.

    ``f(x, u, t, P)`` the dynamics, ``L(x, u, t, P)`` the running cost (None without
    one), ``phi(x0, xf, t0, tf, P)`` the Mayer term (None without one), ``path``
    (``g(x, u, t, P)``) and ``boundary`` (``psi(x0, xf, t0, tf, P)``) the constraints
    (None without); and, for the indirect side, the Hamiltonian ``H = L + p' f``
    (:attr:`hamiltonian`).
    """

    f: ca.Function
    L: ca.Function | None
    phi: ca.Function | None
    path: ConstraintSet | None = None
    boundary: ConstraintSet | None = None

    @cached_property
    def hamiltonian(self) -> Hamiltonian:
        """The Hamiltonian ``H = L + p' f`` of these functions (:class:`Hamiltonian`, on its own symbols), built
        once."""
        return Hamiltonian.of(self)

    @cached_property
    def derived(self) -> dict[Any, Any]:
        """Functions built from these once and kept for every copy of the problem that shares them (e.g. the
        integrator of :func:`ocpkit.flight.fly`), keyed by what else they depend on."""
        return {}


@dataclass(frozen=True)
class Hamiltonian:
    """``H(x, p, u, t, P) = L + p' f`` as symbols and expressions (Pontryagin's principle).

    ``x, p, u, t, P`` are the SX symbols, ``f`` and ``L`` the dynamics and running
    cost in them (``L`` is 0 without a running cost), ``H`` the Hamiltonian; the
    costate equations are ``dp/dt = -dH/dx``.
    """

    x: ca.SX
    p: ca.SX
    u: ca.SX
    t: ca.SX
    P: ca.SX
    f: ca.SX
    L: ca.SX
    H: ca.SX

    @classmethod
    def of(
        cls, functions: ProblemFunctions, x: ca.SX | None = None, p: ca.SX | None = None, P: ca.SX | None = None
    ) -> Hamiltonian:
        """The Hamiltonian of ``functions``, on new symbols or on given ``x, p, P`` (with new ``u, t``).

        On given symbols it is a second expression graph of the same definition: the
        shooting engine's flows use one beside the control law's, as they always have,
        so that derivatives through the law's control keep their association order
        (and the compendium's published numbers their last bits).
        """
        f_fun = functions.f
        nx, nu, nP = f_fun.size1_in(0), f_fun.size1_in(1), f_fun.size1_in(3)
        x = ca.SX.sym("x", nx) if x is None else x
        p = ca.SX.sym("p", nx) if p is None else p
        u = ca.SX.sym("u", nu)
        P = ca.SX.sym("P", nP) if P is None else P
        t = ca.SX.sym("t")
        f = f_fun(x, u, t, P)
        L = functions.L(x, u, t, P) if functions.L is not None else ca.SX(0)
        return cls(x, p, u, t, P, f, L, L + ca.dot(p, f))


class OptimalControlProblem:
    """A single-phase optimal control problem (see the module docstring). Immutable.

    Parameters
    ----------
    name : str
    states : Sequence[State]
    controls : Sequence[Control]
    dynamics : callable
        ``f(x, u, t)`` on CasADi column vectors returning dx/dt
        (a CasADi expression or a list of ``len(states)`` expressions; use CasADi's
        functions, ``ca.cos``, ``ca.vertcat``: ``math`` functions and numpy arrays are rejected).
        ``x`` and ``u`` answer to the declared names, ``x["h"]`` (:mod:`ocpkit.names`); so do
        ``x0`` and ``xf`` of ``mayer`` and of the constraints.
    t0 : float or FreeInitialTime
        Initial time, fixed (a number) or free (:class:`FreeInitialTime`). A free initial time must lie below
        every admissible final time.
    tf : float, FreeFinalTime or Duration
        Final time, fixed (a number), free (:class:`FreeFinalTime`) or given by the phase's duration
        (:class:`Duration`, ``tf = t0 + d``).
    mayer : callable, optional
        ``phi(x0, xf, t0, tf)`` returning a scalar.
    lagrange : callable, optional
        ``L(x, u, t)`` returning a scalar. Without either the cost is 0: a
        feasibility problem, or a phase of a :class:`~ocpkit.MultiPhase` whose cost lies in other phases.
    objective_scale : float
        The NLP minimises ``J / objective_scale``.
    parameters : Mapping[str, float], optional
        Named constants, name -> value, that may change between solves without rebuilding the
        problem's functions (a homotopy parameter, a thrust level). A callable that
        takes one argument more than its inputs, ``f(x, u, t, p)``, receives them by
        name, ``p["thrust"]``; one that does not use them need not take them.
    free_parameters : Sequence[FreeParameter], optional
        Static parameters the transcriptions optimise; in the same ``p``.
    path_constraints, boundary_constraints : Sequence[Constraint], optional
        The path and the boundary constraints.

    Notes
    -----
    The functions are :attr:`functions` (``f``, ``L``, ``phi`` with ``P`` last);
    :meth:`dynamics`, :meth:`lagrange` and :meth:`mayer` evaluate them with this
    problem's parameter values, on numbers or CasADi symbols.
    """

    # what the constructor sets (the object is immutable: object.__setattr__ in __init__)
    #: the problem's name
    name: str
    #: a description of the problem (``description=``)
    description: str
    #: the states, in the order of ``x``
    states: tuple[State, ...]
    #: the controls, in the order of ``u``
    controls: tuple[Control, ...]
    #: the NLP minimises ``J / objective_scale``
    objective_scale: float
    #: the free initial time (:class:`FreeInitialTime`), or None where ``t0`` is fixed
    initial_time: FreeInitialTime | None
    #: the initial time (a free one's guess)
    t0: float
    #: the final time, or the :class:`FreeFinalTime` (or :class:`Duration`) where it is free
    tf: float | FreeFinalTime
    #: the fixed parameters' values by name, first in the parameter vector ``P`` (:meth:`parameter_vector`); a copy
    #: with other values is ``replace(parameters={...})`` (:meth:`replace`)
    parameters: dict[str, float]
    #: the free parameters (:class:`FreeParameter`), after the fixed ones in ``P``
    free_parameters: tuple[FreeParameter, ...]
    #: the path constraints (``path_constraints=``), names distinct
    path_constraints: tuple[Constraint, ...]
    #: the boundary constraints (``boundary_constraints=``), names distinct
    boundary_constraints: tuple[Constraint, ...]
    #: the problem's CasADi functions (:class:`ProblemFunctions`, ``P`` the last input of each), built once; a copy
    #: whose parameter values alone change shares them
    functions: ProblemFunctions
    _spec: dict[str, Any]

    def __init__(
        self,
        name: str,
        states: Sequence[State],
        controls: Sequence[Control],
        dynamics: Callable[..., Any],
        *,
        t0: float | FreeInitialTime = 0.0,
        tf: float | FreeFinalTime,
        mayer: Callable[..., Any] | None = None,
        lagrange: Callable[..., Any] | None = None,
        objective_scale: float = 1.0,
        description: str = "",
        parameters: Mapping[str, float] | None = None,
        free_parameters: Sequence[FreeParameter] = (),
        path_constraints: Sequence[Constraint] = (),
        boundary_constraints: Sequence[Constraint] = (),
        _functions: ProblemFunctions | None = None,
    ) -> None:
        spec = dict(
            name=name,
            states=states,
            controls=controls,
            dynamics=dynamics,
            t0=t0,
            tf=tf,
            mayer=mayer,
            lagrange=lagrange,
            objective_scale=objective_scale,
            description=description,
            parameters=parameters,
            free_parameters=free_parameters,
            path_constraints=path_constraints,
            boundary_constraints=boundary_constraints,
        )
        set_ = object.__setattr__
        set_(self, "_spec", spec)
        set_(self, "name", name)
        set_(self, "description", description)
        set_(self, "states", tuple(states))
        set_(self, "controls", tuple(controls))
        if not self.states:
            raise ValueError("a problem needs at least one state")
        expected: list[tuple[Variable, type[Variable]]] = [(s, State) for s in self.states]
        for variable, kind in expected + [(c, Control) for c in self.controls]:
            if not isinstance(variable, kind):
                raise TypeError(f"expected {kind.__name__}, got {variable!r}")
        names = [v.name for v in self.states + self.controls]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"duplicate variable names: {dup}")
        if not (objective_scale > 0 and math.isfinite(objective_scale)):
            raise ValueError(f"objective_scale must be positive and finite, got {objective_scale}")
        set_(self, "objective_scale", float(objective_scale))
        if isinstance(t0, FreeInitialTime):
            set_(self, "initial_time", t0)
            set_(self, "t0", float(t0.guess))
            t0_upper = t0.upper
        else:
            if isinstance(t0, FreeFinalTime) or not (isinstance(t0, (int, float, np.floating)) and math.isfinite(t0)):
                raise ValueError(f"t0 must be a finite number or a FreeInitialTime, got {t0!r}")
            set_(self, "initial_time", None)
            set_(self, "t0", float(t0))
            t0_upper = self.t0
        if isinstance(tf, FreeInitialTime):
            raise TypeError("tf is a FreeInitialTime: give a FreeFinalTime")
        if isinstance(tf, FreeFinalTime):
            if not isinstance(tf, Duration) and tf.lower <= t0_upper:
                raise ValueError(
                    f"final time lower bound {tf.lower} must exceed t0 (at most {t0_upper}); to let the windows of "
                    "a free t0 and tf overlap, give the duration, tf=Duration(lower, upper, guess)"
                )
            set_(self, "tf", tf)
        else:
            if not (isinstance(tf, (int, float, np.floating)) and math.isfinite(tf)):
                raise ValueError(f"tf must be a finite number or a FreeFinalTime, got {tf!r}")
            if float(tf) <= t0_upper:
                raise ValueError(f"final time {tf} must exceed t0 (at most {t0_upper})")
            set_(self, "tf", float(tf))

        values = {} if parameters is None else {str(k): float(v) for k, v in parameters.items()}
        for k, value in values.items():
            if not k.isidentifier():
                raise ValueError(f"parameter name must be an identifier, got {k!r}")
            if not math.isfinite(value):
                raise ValueError(f"parameter {k!r} must be finite, got {value}")
        set_(self, "parameters", values)
        free = tuple(free_parameters)
        for parameter in free:
            if not isinstance(parameter, FreeParameter):
                raise TypeError(f"free_parameters must be FreeParameter objects, got {parameter!r}")
        clash = sorted({v.name for v in free} & set(values))
        names = [v.name for v in free]
        clash += sorted({n for n in names if names.count(n) > 1})
        if clash:
            raise ValueError(f"parameter names used twice (fixed and free, or free twice): {clash}")
        set_(self, "free_parameters", free)
        for which, given in (("path_constraints", path_constraints), ("boundary_constraints", boundary_constraints)):
            set_(self, which, checked_constraints(given, which))
        if _functions is None:
            _functions = _build_functions(
                self.nx,
                self.nu,
                values,
                dynamics,
                lagrange,
                mayer,
                with_parameters=self.takes_parameters,
                state_names=self.state_names,
                control_names=self.control_names,
                free_names=[v.name for v in free],
                path_constraints=self.path_constraints,
                boundary_constraints=self.boundary_constraints,
            )
        set_(self, "functions", _functions)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"an OptimalControlProblem is immutable; use replace({name}=...)")

    def replace(self, **changes: Any) -> OptimalControlProblem:
        """A copy with some constructor arguments changed, e.g. ``parameters={"lam": 0.5}``.

        Parameter values given are merged into the current ones (an unknown name is
        an error); when only parameter values, the name or the description change,
        the copy shares this problem's CasADi functions.
        """
        spec = dict(self._spec)
        unknown = sorted(set(changes) - set(spec))
        if unknown:
            raise TypeError(f"unknown problem arguments {unknown}")
        if "parameters" in changes and changes["parameters"] is not None:
            new = dict(changes["parameters"])
            bad = sorted(set(new) - set(self.parameters))
            if bad:
                raise KeyError(f"unknown parameters {bad}; {self.name!r} has {sorted(self.parameters)}")
            changes["parameters"] = {**self.parameters, **new}
        spec.update(changes)
        shared = set(changes) <= {"parameters", "name", "description"} and (
            changes.get("parameters") is not None or "parameters" not in changes
        )
        return OptimalControlProblem(**spec, _functions=self.functions if shared else None)

    # -- the functions, at this problem's parameter values --------------------------------------
    @property
    def f(self) -> ca.Function:
        return self.functions.f

    @property
    def L(self) -> ca.Function | None:
        return self.functions.L

    @property
    def phi(self) -> ca.Function | None:
        return self.functions.phi

    def parameter_vector(self, values: Mapping[str, float] | ArrayLike | None = None) -> np.ndarray:
        """The parameter vector ``P``: this problem's values, or ``values`` checked against them.

        ``values`` may be a vector (in the order of :attr:`parameters`) or a mapping of
        some names to values (the others keep this problem's).
        """
        if values is None:
            return np.array(list(self.parameters.values()), dtype=float)
        if isinstance(values, Mapping):
            bad = sorted(set(values) - set(self.parameters))
            if bad:
                raise KeyError(f"unknown parameters {bad}; {self.name!r} has {sorted(self.parameters)}")
            return np.array([float(values.get(k, v)) for k, v in self.parameters.items()], dtype=float)
        P = np.array(values, dtype=float).ravel()
        if P.shape != (len(self.parameters),):
            raise ValueError(f"expected {len(self.parameters)} parameters {list(self.parameters)}, got {P.shape}")
        return P

    @property
    def takes_parameters(self) -> bool:
        """Whether the user's functions receive the dict of parameter symbols (given ``parameters`` or free ones)."""
        return self._spec["parameters"] is not None or bool(self._spec["free_parameters"])

    @property
    def parameter_names(self) -> list[str]:
        """The names in the parameter vector ``P`` and in a callable's ``p``, the fixed ones, then the free ones."""
        return [*self.parameters, *(v.name for v in self.free_parameters)]

    @property
    def free_initial_time(self) -> bool:
        return self.initial_time is not None

    @property
    def free_parameter_scaling(self) -> AffineScaling:
        return AffineScaling.of(self.free_parameters)

    def parameters_as_states(self) -> OptimalControlProblem:
        """This problem with each free parameter a state of zero dynamics, free at both ends (its bounds, scale and
        guess kept), after the problem's states: the statement of the indirect method, in which the parameter's
        costate obeys ``dlambda_k/dt = -dH/dk`` with ``lambda_k(t0) = 0`` and ``lambda_k(tf) = dphi/dk`` (the
        transversality conditions of a free static parameter). Without free parameters, this problem."""
        if not self.free_parameters:
            return self
        if self.path_constraints or self.boundary_constraints:
            raise ValueError(f"{self.name!r}: free parameters become states only in a problem without constraints")
        nx, nk = self.nx, len(self.free_parameters)
        fns = self.functions

        def P(x: ca.SX, p: NamedParameters) -> ca.SX:
            return ca.vertcat(p.column, x[nx:])

        def dynamics(x: ca.SX, u: ca.SX, t: ca.SX, p: NamedParameters) -> ca.SX:
            return ca.vertcat(fns.f(x[:nx], u, t, P(x, p)), ca.DM.zeros(nk))

        L, phi = fns.L, fns.phi
        lagrange = None if L is None else (lambda x, u, t, p: L(x[:nx], u, t, P(x, p)))
        mayer = None if phi is None else (lambda x0, xf, t0, tf, p: phi(x0[:nx], xf[:nx], t0, tf, P(xf, p)))
        states = [
            *self.states,
            *(
                State(v.name, v.lower, v.upper, v.scale, v.shift, v.guess_value, v.unit, v.description)
                for v in self.free_parameters
            ),
        ]
        return OptimalControlProblem(
            f"{self.name}_parameters_as_states",
            states,
            self.controls,
            dynamics,
            t0=self.initial_time or self.t0,
            tf=self.tf,
            mayer=mayer,
            lagrange=lagrange,
            objective_scale=self.objective_scale,
            description=self.description,
            parameters=self.parameters,
        )

    def fix_parameters(self, values: Mapping[str, float]) -> OptimalControlProblem:
        """This problem with its free parameters fixed at ``values`` (every one named), sharing its functions."""
        names = [v.name for v in self.free_parameters]
        if sorted(values) != sorted(names):
            raise KeyError(f"give a value for each free parameter {names}, got {sorted(values)}")
        spec = dict(self._spec)
        spec["parameters"] = {**self.parameters, **{k: float(values[k]) for k in names}}
        spec["free_parameters"] = ()
        return OptimalControlProblem(**spec, _functions=self.functions)

    @property
    def parameter_values(self) -> np.ndarray:
        return self.parameter_vector()

    @cached_property
    def _P(self) -> ca.DM:
        """The parameter vector of the functions: the fixed values, then each free parameter's guess."""
        values = [*self.parameter_vector(), *(v.guess_value for v in self.free_parameters)]
        return ca.DM(values) if values else ca.DM(0, 1)

    def dynamics(self, x: Any, u: Any, t: Any, P: Any = None) -> Any:
        """``f(x, u, t)`` with this problem's parameters, or ``P`` (numbers give a DM, CasADi symbols an expression).

        Here and below, ``P`` (default ``_P``) is the full parameter vector: the fixed
        values, then the free parameters (their guesses by default; a transcription passes
        its NLP symbols).
        """
        return self.functions.f(x, u, t, self._P if P is None else P)

    def lagrange(self, x: Any, u: Any, t: Any, P: Any = None) -> Any:
        """``L(x, u, t)`` with this problem's parameters; 0 without a running cost."""
        return self.functions.L(x, u, t, self._P if P is None else P) if self.functions.L is not None else ca.DM(0)

    def mayer(self, x0: Any, xf: Any, t0: Any, tf: Any, P: Any = None) -> Any:
        """``phi(x0, xf, t0, tf)`` with this problem's parameters; 0 without a Mayer term."""
        if self.functions.phi is None:
            return ca.DM(0)
        return self.functions.phi(x0, xf, t0, tf, self._P if P is None else P)

    def path(self, x: Any, u: Any, t: Any, P: Any = None) -> Any:
        """The stacked path constraints ``g(x, u, t)`` with this problem's parameters (None without)."""
        c = self.functions.path
        return None if c is None else c.function(x, u, t, self._P if P is None else P)

    def boundary(self, x0: Any, xf: Any, t0: Any, tf: Any, P: Any = None) -> Any:
        """The stacked boundary constraints ``psi(x0, xf, t0, tf)`` with this problem's parameters (None without)."""
        c = self.functions.boundary
        return None if c is None else c.function(x0, xf, t0, tf, self._P if P is None else P)

    def expression(
        self,
        fn: Callable[..., Any],
        kind: str = "running",
        what: str = "expression",
        extra_parameters: Sequence[str] = (),
    ) -> ca.Function:
        """A user expression of this problem's variables as a CasADi Function, the statement's callables' way.

        ``kind="running"``: ``fn(x, u, t[, p])``, the Function ``(x, u, t, P) -> column``; ``"boundary"``:
        ``fn(x0, xf, t0, tf[, p])``, the Function ``(x0, xf, t0, tf, P) -> column``. Names as in
        :mod:`ocpkit.names`; ``P`` as in :meth:`dynamics`, then ``extra_parameters`` (names ``p`` has besides the
        problem's: a trajectory's parameters that another phase declares).
        """
        if kind not in ("running", "boundary"):
            raise ValueError(f"kind must be 'running' or 'boundary', got {kind!r}")
        if not callable(fn):
            raise TypeError(f"{what} must be a callable of the problem's variables, got {fn!r}")
        names = [*self.parameter_names, *extra_parameters]
        sym = StatementSymbols.of(self.state_names, self.control_names, names)
        expr = _column(sym.call(fn, kind, what, has_parameters=bool(names)), what)
        try:
            return ca.Function("expression", sym.inputs(kind), [expr])
        except RuntimeError:
            raise ValueError(f"{what} depends on symbols other than the problem's variables and parameters") from None

    # -- descriptors -----------------------------------------------------------------
    @property
    def nx(self) -> int:
        return len(self.states)

    @property
    def nu(self) -> int:
        return len(self.controls)

    @property
    def state_names(self) -> list[str]:
        return [s.name for s in self.states]

    @property
    def control_names(self) -> list[str]:
        return [c.name for c in self.controls]

    @property
    def free_final_time(self) -> bool:
        return isinstance(self.tf, FreeFinalTime)

    @property
    def tf_guess(self) -> float:
        if isinstance(self.tf, Duration):
            return self.t0 + self.tf.guess
        return self.tf.guess if isinstance(self.tf, FreeFinalTime) else self.tf

    @property
    def state_scaling(self) -> AffineScaling:
        return AffineScaling.of(self.states)

    @property
    def control_scaling(self) -> AffineScaling:
        return AffineScaling.of(self.controls)

    @property
    def state_scale(self) -> np.ndarray:
        return self.state_scaling.scale

    @property
    def control_scale(self) -> np.ndarray:
        return self.control_scaling.scale

    def state_index(self, name: str) -> int:
        try:
            return self.state_names.index(name)
        except ValueError:
            raise KeyError(f"unknown state {name!r}; states are {self.state_names}") from None

    def __repr__(self) -> str:
        tf = "free" if self.free_final_time else self.tf
        return (
            f"OptimalControlProblem({self.name!r}, states={self.state_names}, controls={self.control_names}, tf={tf})"
        )


@dataclass(frozen=True)
class StatementSymbols:
    """The symbols a problem statement's callables are called on, with their named views (:mod:`ocpkit.names`).

    ``x, u, t``: a running expression's inputs; ``x0, xf, t0, tf``: a boundary expression's; ``P``: the
    parameters (fixed values, then free ones), ``p`` its view by name.
    """

    x: ca.SX
    u: ca.SX
    t: ca.SX
    x0: ca.SX
    xf: ca.SX
    t0: ca.SX
    tf: ca.SX
    P: ca.SX
    views: dict[str, list[Any]]
    p: NamedParameters

    @classmethod
    def of(
        cls, state_names: Sequence[str], control_names: Sequence[str], parameter_names: Sequence[str]
    ) -> StatementSymbols:
        nx, nu = len(state_names), len(control_names)
        x, u, t = ca.SX.sym("x", nx), ca.SX.sym("u", nu), ca.SX.sym("t")
        x0, xf, t0, tf = ca.SX.sym("x0", nx), ca.SX.sym("xf", nx), ca.SX.sym("t0"), ca.SX.sym("tf")
        P = ca.SX.sym("P", len(parameter_names))
        views = {
            "running": [Named(x, state_names, "state"), Named(u, control_names, "control"), t],
            "boundary": [Named(x0, state_names, "state"), Named(xf, state_names, "state"), t0, tf],
        }
        return cls(x, u, t, x0, xf, t0, tf, P, views, NamedParameters(P, parameter_names))

    def inputs(self, kind: str) -> list[ca.SX]:
        """The plain symbols of ``kind`` (``"running"`` or ``"boundary"``), then ``P``: a Function's inputs."""
        plain = [self.x, self.u, self.t] if kind == "running" else [self.x0, self.xf, self.t0, self.tf]
        return [*plain, self.P]

    def call(self, fn: Callable[..., Any], kind: str, what: str, *, has_parameters: bool) -> Any:
        """``fn`` on the named views of ``kind`` (and ``p`` if it takes it: :func:`ocpkit.names.call`)."""
        return call(fn, self.views[kind], self.p, has_parameters=has_parameters, what=what)


def _build_functions(
    nx: int,
    nu: int,
    values: dict[str, float],
    dynamics: Callable[..., Any],
    lagrange: Callable[..., Any] | None,
    mayer: Callable[..., Any] | None,
    *,
    with_parameters: bool,
    state_names: Sequence[str],
    control_names: Sequence[str] | None = None,
    free_names: Sequence[str] = (),
    path_constraints: Sequence[Constraint] = (),
    boundary_constraints: Sequence[Constraint] = (),
) -> ProblemFunctions:
    """The problem's CasADi functions from the user's callables (called once, on named symbols: :mod:`ocpkit.names`)."""
    control_names = [f"u{k}" for k in range(nu)] if control_names is None else list(control_names)
    sym = StatementSymbols.of(state_names, control_names, [*values, *free_names])
    x, u, t, P = sym.x, sym.u, sym.t, sym.P
    x0, xf, s0, sf = sym.x0, sym.xf, sym.t0, sym.tf

    def user(fn: Callable[..., Any], kind: str, what: str) -> Any:
        return sym.call(fn, kind, what, has_parameters=with_parameters)

    xdot = _column(user(dynamics, "running", "dynamics"), "dynamics")
    if xdot.shape != (nx, 1):
        raise ValueError(f"dynamics returned shape {xdot.shape}, expected ({nx}, 1) for states {list(state_names)}")
    f = ca.Function("f_p", [x, u, t, P], [xdot], ["x", "u", "t", "P"], ["xdot"])
    L: ca.Function | None = None
    phi: ca.Function | None = None
    if lagrange is not None:
        expr = _column(user(lagrange, "running", "lagrange"), "lagrange")
        if expr.shape != (1, 1):
            raise ValueError(f"lagrange must return a scalar, got shape {expr.shape}")
        L = ca.Function("L_p", [x, u, t, P], [expr], ["x", "u", "t", "P"], ["L"])
    if mayer is not None:
        expr = _column(user(mayer, "boundary", "mayer"), "mayer")
        if expr.shape != (1, 1):
            raise ValueError(f"mayer must return a scalar, got shape {expr.shape}")
        phi = ca.Function("phi_p", [x0, xf, s0, sf, P], [expr], ["x0", "xf", "t0", "tf", "P"], ["phi"])
    path = _constraint_set(
        "path", path_constraints, [x, u, t], ["x", "u", "t"], P, lambda fn, what: user(fn, "running", what)
    )
    boundary = _constraint_set(
        "boundary",
        boundary_constraints,
        [x0, xf, s0, sf],
        ["x0", "xf", "t0", "tf"],
        P,
        lambda fn, what: user(fn, "boundary", what),
    )
    return ProblemFunctions(f, L, phi, path, boundary)


def _constraint_set(
    kind: str,
    constraints: Sequence[Constraint],
    inputs: list[Any],
    input_names: list[str],
    P: Any,
    user: Callable[[Callable[..., Any], str], Any],
) -> ConstraintSet | None:
    """Compile constraints of one kind into one stacked function ``(inputs..., P) -> g`` and its bounds.

    ``user(fn, what)`` calls a constraint's callable on the named inputs (and the parameters if it takes them).
    """
    if not constraints:
        return None
    exprs: list[ca.SX] = []
    lower: list[np.ndarray] = []
    upper: list[np.ndarray] = []
    scale: list[np.ndarray] = []
    sizes: list[int] = []
    for c in constraints:
        what = f"{kind} constraint {c.name!r}"
        try:
            e = _column(user(c.function, what), what)
        except (TypeError, ValueError, KeyError) as exc:
            if what in str(exc):
                raise
            raise type(exc)(f"{what}: {exc}") from exc
        if e.shape[1] != 1 or e.numel() == 0:
            raise ValueError(f"{kind} constraint {c.name!r} must return one or more scalar expressions, got {e.shape}")
        lo, hi = c.bounds(e.shape[0])
        exprs.append(e)
        lower.append(lo)
        upper.append(hi)
        scale.append(np.full(e.shape[0], c.scale))
        sizes.append(e.shape[0])
    fun = ca.Function(f"{kind}_constraints", [*inputs, P], [ca.vertcat(*exprs)], [*input_names, "P"], ["g"])
    return ConstraintSet(
        fun,
        np.concatenate(lower),
        np.concatenate(upper),
        np.concatenate(scale),
        tuple(c.name for c in constraints),
        tuple(sizes),
    )


def _column(expr: Any, what: str) -> ca.SX:
    if isinstance(expr, np.ndarray):
        raise TypeError(
            f"{what} returned a numpy array: return CasADi expressions (ca.vertcat(...)) or a list of them; "
            "numpy turns CasADi symbols into NaN"
        )
    if isinstance(expr, (list, tuple)):
        expr = ca.vertcat(*expr)
    if isinstance(expr, (int, float, ca.DM)):
        expr = ca.SX(ca.DM(expr))
    if not isinstance(expr, ca.SX):
        raise TypeError(f"{what} must return CasADi SX expressions, got {type(expr).__name__}")
    for k in range(expr.numel()):
        e = expr[k]
        if e.is_constant() and math.isnan(float(e)):
            raise ValueError(
                f"{what} returned NaN in entry {k}: a math or numpy function (math.cos, np.sqrt) applied to a CasADi "
                "symbol gives NaN; use CasADi's (ca.cos, ca.sqrt)"
            )
    return expr


@dataclass
class Guess:
    """An initial guess for a transcription.

    ``states`` and ``controls`` map names to a :data:`GuessSpec` (a function of time,
    a constant, or a ``(start, end)`` tuple linear in time); names left out use each
    variable's own guess. ``tf`` defaults to the problem's guess (a free initial time
    starts at its guess), and ``parameters`` (free parameter name -> value) to each free
    parameter's guess.
    """

    tf: float | None = None
    states: Mapping[str, GuessSpec] = field(default_factory=dict)
    controls: Mapping[str, GuessSpec] = field(default_factory=dict)
    parameters: Mapping[str, float] = field(default_factory=dict)

    def parameter_values(self, problem: OptimalControlProblem) -> dict[str, float]:
        """The guess of every free parameter, by name."""
        names = [v.name for v in problem.free_parameters]
        unknown = sorted(set(self.parameters) - set(names))
        if unknown:
            raise KeyError(f"guess names unknown free parameters {unknown}; free parameters are {names}")
        return {v.name: float(self.parameters.get(v.name, v.guess_value)) for v in problem.free_parameters}

    def functions(
        self, problem: OptimalControlProblem
    ) -> tuple[float, Callable[[ArrayLike], np.ndarray], Callable[[ArrayLike], np.ndarray]]:
        """``(tf, states(t), controls(t))``: the guessed final time and the guess as functions of time."""
        tf = problem.tf_guess if self.tf is None else float(self.tf)
        t0 = problem.t0
        if not (math.isfinite(tf) and tf > t0):
            raise ValueError(f"guess tf = {tf} must be finite and exceed t0 = {t0}")
        for key, names in (("states", problem.state_names), ("controls", problem.control_names)):
            unknown = sorted(set(getattr(self, key)) - set(names))
            if unknown:
                raise KeyError(f"guess names unknown {key} {unknown}; {key} are {names}")

        def build(
            spec_map: Mapping[str, GuessSpec], variables: Sequence[Variable]
        ) -> Callable[[ArrayLike], np.ndarray]:
            parts = [
                guess_function(spec_map[v.name], f"guess for {v.name!r}") or v.guess_function()
                if v.name in spec_map
                else v.guess_function()
                for v in variables
            ]

            def fun(t: ArrayLike) -> np.ndarray:
                t = np.asarray(t, dtype=float)
                s = (t - t0) / (tf - t0)
                if not parts:
                    return np.zeros(t.shape + (0,))
                return np.stack([np.broadcast_to(g(s, t), t.shape) for g in parts], axis=-1)

            return fun

        return tf, build(self.states, problem.states), build(self.controls, problem.controls)
