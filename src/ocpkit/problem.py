"""Single-phase optimal control problems.

    minimise    phi(x(t0), x(tf), t0, tf) + integral_{t0}^{tf} L(x, u, t) dt
    subject to  dx/dt = f(x, u, t)
                x_lo <= x(t) <= x_hi,  u_lo <= u(t) <= u_hi
                x(t0), x(tf) fixed or bounded component by component
                t0 fixed; tf fixed or free within bounds.

This is the problem of Desai & Conway, Eqs. (1)-(5), without general path
constraints. The definition is independent of any transcription: dynamics and
costs are Python callables on CasADi symbols, turned here into CasADi
Functions once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence, Union

import casadi as ca
import numpy as np

Bound = Union[None, float, tuple[float, float]]
"""A boundary condition: ``None`` (free), a value (fixed) or ``(lower, upper)``."""

GuessSpec = Union[None, float, tuple[float, float]]
"""A guess: ``None`` (derived from bounds), a constant, or ``(start, end)`` linear in time."""


def _as_interval(spec: Bound, what: str) -> tuple[float, float]:
    if spec is None:
        return (-math.inf, math.inf)
    if isinstance(spec, (tuple, list)):
        if len(spec) != 2:
            raise ValueError(f"{what}: expected a value or a (lower, upper) pair, got {spec!r}")
        lo, hi = float(spec[0]), float(spec[1])
    else:
        lo = hi = float(spec)
    if math.isnan(lo) or math.isnan(hi):
        raise ValueError(f"{what}: NaN in {spec!r}")
    if lo > hi:
        raise ValueError(f"{what}: impossible bounds, lower {lo} > upper {hi}")
    return lo, hi


@dataclass(frozen=True)
class AffineScaling:
    """NLP variables ``(value - shift) / scale``, component by component."""

    shift: np.ndarray
    scale: np.ndarray

    def subset(self, index) -> "AffineScaling":
        return AffineScaling(self.shift[index], self.scale[index])

    def to_nlp(self, values):
        """Physical values (last axis = components) to NLP values."""
        return (np.asarray(values, dtype=float) - self.shift) / self.scale

    def from_nlp(self, z):
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

    def guess_at(self, s: np.ndarray) -> np.ndarray:
        """The guess at normalised times ``s`` in [0, 1]."""
        g = self.guess
        if g is None:
            g = _midpoint(self.lower, self.upper)
        if isinstance(g, (tuple, list)):
            if len(g) != 2:
                raise ValueError(f"guess of {self.name!r}: expected a value or (start, end), got {g!r}")
            return float(g[0]) + (float(g[1]) - float(g[0])) * np.asarray(s, dtype=float)
        return np.full(np.shape(s), float(g))


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

    def guess_at(self, s: np.ndarray) -> np.ndarray:
        if self.guess is not None:
            return super().guess_at(s)
        a = _fixed_value(self.initial)
        b = _fixed_value(self.final)
        if a is None and b is None:
            return super().guess_at(s)
        a = b if a is None else a
        b = a if b is None else b
        return a + (b - a) * np.asarray(s, dtype=float)


def _fixed_value(spec: Bound) -> float | None:
    if spec is None or isinstance(spec, (tuple, list)):
        return None
    return float(spec)


@dataclass(frozen=True)
class Control(Variable):
    """A control with box bounds."""


@dataclass(frozen=True)
class FreeFinalTime:
    """A free final time ``tf`` in ``[lower, upper]``."""

    lower: float
    upper: float
    guess: float
    scale: float = 1.0

    def __post_init__(self) -> None:
        lo, hi = _as_interval((self.lower, self.upper), "final time bounds")
        if not lo <= self.guess <= hi:
            raise ValueError(f"final time guess {self.guess} lies outside [{lo}, {hi}]")
        if not (self.scale > 0 and math.isfinite(self.scale)):
            raise ValueError(f"final time scale must be positive and finite, got {self.scale}")


class OptimalControlProblem:
    """A single-phase optimal control problem (see the module docstring).

    Parameters
    ----------
    name : str
    states, controls : sequences of :class:`State` and :class:`Control`.
    dynamics : callable ``f(x, u, t)`` on CasADi column vectors returning dx/dt
        (a CasADi expression or a list of ``len(states)`` expressions).
    t0 : float
        Initial time (fixed).
    tf : float or :class:`FreeFinalTime`
    mayer : callable ``phi(x0, xf, t0, tf)`` returning a scalar, optional.
    lagrange : callable ``L(x, u, t)`` returning a scalar, optional.
    objective_scale : float
        The NLP minimises ``J / objective_scale``.
    parameters : mapping name -> value, optional
        Named constants that may change between solves without rebuilding the
        problem's symbolic form (a homotopy parameter, a thrust level). When given,
        ``dynamics``, ``lagrange`` and ``mayer`` receive one more argument: a dict
        of CasADi symbols by name. ``dynamics``, ``lagrange`` and ``mayer`` below
        have the values substituted; ``*_p`` versions take the parameter vector
        as their last input.
    """

    def __init__(
        self,
        name: str,
        states: Sequence[State],
        controls: Sequence[Control],
        dynamics: Callable,
        *,
        t0: float = 0.0,
        tf: float | FreeFinalTime,
        mayer: Callable | None = None,
        lagrange: Callable | None = None,
        objective_scale: float = 1.0,
        description: str = "",
        parameters: Mapping[str, float] | None = None,
    ) -> None:
        self._spec = dict(
            name=name, states=states, controls=controls, dynamics=dynamics, t0=t0, tf=tf, mayer=mayer,
            lagrange=lagrange, objective_scale=objective_scale, description=description, parameters=parameters,
        )
        self.name = name
        self.description = description
        self.states = tuple(states)
        self.controls = tuple(controls)
        if not self.states:
            raise ValueError("a problem needs at least one state")
        for v, kind in [(s, State) for s in self.states] + [(c, Control) for c in self.controls]:
            if not isinstance(v, kind):
                raise TypeError(f"expected {kind.__name__}, got {v!r}")
        names = [v.name for v in self.states + self.controls]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"duplicate variable names: {dup}")
        if mayer is None and lagrange is None:
            raise ValueError("give a Mayer term, a Lagrange term, or both")
        if not (objective_scale > 0 and math.isfinite(objective_scale)):
            raise ValueError(f"objective_scale must be positive and finite, got {objective_scale}")
        self.objective_scale = float(objective_scale)
        self.t0 = float(t0)
        if isinstance(tf, FreeFinalTime):
            if tf.lower <= self.t0:
                raise ValueError(f"final time lower bound {tf.lower} must exceed t0 = {self.t0}")
            self.tf: float | FreeFinalTime = tf
        else:
            if float(tf) <= self.t0:
                raise ValueError(f"final time {tf} must exceed t0 = {self.t0}")
            self.tf = float(tf)

        self.parameters = {} if parameters is None else {str(k): float(v) for k, v in parameters.items()}
        for k in self.parameters:
            if not k.isidentifier():
                raise ValueError(f"parameter name must be an identifier, got {k!r}")
        P = ca.SX.sym("P", len(self.parameters))
        pdict = {k: P[i] for i, k in enumerate(self.parameters)}
        extra = (pdict,) if parameters is not None else ()
        pval = ca.DM(list(self.parameters.values())) if self.parameters else ca.DM(0, 1)

        nx, nu = self.nx, self.nu
        x = ca.SX.sym("x", nx)
        u = ca.SX.sym("u", nu)
        t = ca.SX.sym("t")
        xdot = _column(dynamics(x, u, t, *extra), "dynamics")
        if xdot.shape != (nx, 1):
            raise ValueError(
                f"dynamics returned shape {xdot.shape}, expected ({nx}, 1) for states {self.state_names}"
            )
        self.dynamics_p = ca.Function("f_p", [x, u, t, P], [xdot], ["x", "u", "t", "P"], ["xdot"])
        self.dynamics = ca.Function("f", [x, u, t], [self.dynamics_p(x, u, t, pval)], ["x", "u", "t"], ["xdot"])
        self.lagrange = self.lagrange_p = None
        if lagrange is not None:
            L = _column(lagrange(x, u, t, *extra), "lagrange")
            if L.shape != (1, 1):
                raise ValueError(f"lagrange must return a scalar, got shape {L.shape}")
            self.lagrange_p = ca.Function("L_p", [x, u, t, P], [L], ["x", "u", "t", "P"], ["L"])
            self.lagrange = ca.Function("L", [x, u, t], [self.lagrange_p(x, u, t, pval)], ["x", "u", "t"], ["L"])
        self.mayer = self.mayer_p = None
        if mayer is not None:
            x0, xf, s0, sf = ca.SX.sym("x0", nx), ca.SX.sym("xf", nx), ca.SX.sym("t0"), ca.SX.sym("tf")
            phi = _column(mayer(x0, xf, s0, sf, *extra), "mayer")
            if phi.shape != (1, 1):
                raise ValueError(f"mayer must return a scalar, got shape {phi.shape}")
            self.mayer_p = ca.Function("phi_p", [x0, xf, s0, sf, P], [phi], ["x0", "xf", "t0", "tf", "P"], ["phi"])
            self.mayer = ca.Function(
                "phi", [x0, xf, s0, sf], [self.mayer_p(x0, xf, s0, sf, pval)], ["x0", "xf", "t0", "tf"], ["phi"]
            )

    def replace(self, **changes) -> "OptimalControlProblem":
        """A copy with some constructor arguments changed, e.g. ``parameters={"lam": 0.5}``.

        Parameter values given are merged into the current ones; an unknown
        parameter name is an error.
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
        return OptimalControlProblem(**spec)

    @property
    def parameter_values(self) -> np.ndarray:
        return np.array(list(self.parameters.values()), dtype=float)

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
        return self.tf.guess if isinstance(self.tf, FreeFinalTime) else self.tf

    @property
    def state_scale(self) -> np.ndarray:
        return np.array([s.scale for s in self.states])

    @property
    def control_scale(self) -> np.ndarray:
        return np.array([c.scale for c in self.controls])

    @property
    def state_scaling(self) -> AffineScaling:
        return AffineScaling(np.array([s.shift for s in self.states]), self.state_scale)

    @property
    def control_scaling(self) -> AffineScaling:
        return AffineScaling(np.array([c.shift for c in self.controls]), self.control_scale)

    def state_index(self, name: str) -> int:
        try:
            return self.state_names.index(name)
        except ValueError:
            raise KeyError(f"unknown state {name!r}; states are {self.state_names}") from None

    def __repr__(self) -> str:
        tf = "free" if self.free_final_time else self.tf
        return (
            f"OptimalControlProblem({self.name!r}, states={self.state_names}, "
            f"controls={self.control_names}, tf={tf})"
        )

    # -- numerical helpers -----------------------------------------------------------
    def rhs(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Evaluate f(x, u, t) numerically (for re-integration and checks)."""
        return np.asarray(self.dynamics(x, u, t)).ravel()

    def guess_functions(self, tf: float):
        """Default guess as functions of time over [t0, tf] (from each variable's ``guess``)."""
        t0 = self.t0

        def states(t):
            s = (np.asarray(t, dtype=float) - t0) / (tf - t0)
            return np.stack([v.guess_at(s) for v in self.states], axis=-1)

        def controls(t):
            s = (np.asarray(t, dtype=float) - t0) / (tf - t0)
            if not self.controls:
                return np.zeros(np.shape(s) + (0,))
            return np.stack([v.guess_at(s) for v in self.controls], axis=-1)

        return states, controls


def _column(expr, what: str) -> ca.SX:
    if isinstance(expr, (list, tuple)):
        expr = ca.vertcat(*expr)
    if isinstance(expr, (int, float, np.ndarray, ca.DM)):
        expr = ca.SX(ca.DM(expr))
    if not isinstance(expr, ca.SX):
        raise TypeError(f"{what} must return CasADi SX expressions, got {type(expr).__name__}")
    return expr


@dataclass
class Guess:
    """An initial guess for a transcription.

    ``states`` and ``controls`` map names to a callable of time, a constant, or a
    ``(start, end)`` pair (linear in time); names left out use the problem's
    default guess. ``tf`` defaults to the problem's guess.
    """

    tf: float | None = None
    states: Mapping[str, object] = field(default_factory=dict)
    controls: Mapping[str, object] = field(default_factory=dict)

    def functions(self, problem: OptimalControlProblem):
        tf = problem.tf_guess if self.tf is None else float(self.tf)
        if tf <= problem.t0:
            raise ValueError(f"guess tf = {tf} must exceed t0 = {problem.t0}")
        for key, names in (("states", problem.state_names), ("controls", problem.control_names)):
            unknown = sorted(set(getattr(self, key)) - set(names))
            if unknown:
                raise KeyError(f"guess names unknown {key} {unknown}; {key} are {names}")
        xs_default, us_default = problem.guess_functions(tf)

        def build(spec_map, variables, default):
            def fun(t):
                t = np.asarray(t, dtype=float)
                out = np.array(default(t), dtype=float)
                s = (t - problem.t0) / (tf - problem.t0)
                for j, v in enumerate(variables):
                    if v.name not in spec_map:
                        continue
                    spec = spec_map[v.name]
                    if callable(spec):
                        val = np.asarray(spec(t), dtype=float)
                        if val.shape != t.shape:
                            raise ValueError(
                                f"guess for {v.name!r} returned shape {val.shape}, expected {t.shape}"
                            )
                    elif isinstance(spec, (tuple, list)):
                        val = float(spec[0]) + (float(spec[1]) - float(spec[0])) * s
                    else:
                        val = np.full(t.shape, float(spec))
                    out[..., j] = val
                return out

            return fun

        return (
            tf,
            build(self.states, problem.states, xs_default),
            build(self.controls, problem.controls, us_default),
        )
