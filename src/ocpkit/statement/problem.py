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
from collections.abc import Callable, Mapping, Sequence
from functools import cached_property
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from ..names import NamedParameters
from .constraints import Constraint, checked_constraints
from .functions import ProblemFunctions
from .symbols import StatementSymbols, build_functions, column, read_inputs
from .times import Duration, FreeFinalTime, FreeInitialTime
from .variables import AffineScaling, Control, FreeParameter, State, Variable

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


# what an expression of a solution is, by kind (OptimalControlProblem.expression), for the messages
EXPRESSION_KINDS = {
    "running": "sample takes a function of time, (x, u, t) or (x, u, t, p); "
    "a number of the ends is value(lambda x0, xf, t0, tf: ...)",
    "boundary": "value takes a function of the ends, (x0, xf, t0, tf) or (x0, xf, t0, tf, p); "
    "a function of time is sample(lambda x, u, t: ...)",
}


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
        feasibility problem, or a phase of a :class:`~ocpkit.MultiPhaseProblem` whose cost lies in other phases.
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
            _functions = build_functions(
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
            self._check_controls_read(_functions)
        set_(self, "functions", _functions)

    def _check_controls_read(self, functions: ProblemFunctions) -> None:
        """A ValueError naming each declared control that no function reads: the NLP would return any value for it
        (the phase's own functions are the only ones that see a control, so this is known here)."""
        read, _ = read_inputs(functions)
        unread = [c.name for j, c in enumerate(self.controls) if j not in read]
        if unread:
            names, uses = ", ".join(map(repr, unread)), ", ".join(f"u[{n!r}]" for n in unread)
            raise ValueError(
                f"control {names} of {self.name!r} is read by no function (neither the dynamics, the running cost "
                f"nor a path constraint), so the solver would return an arbitrary value for it: use it ({uses}) in "
                "one of them, or remove it from controls="
            )

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
    def full_parameters(self) -> ca.DM:
        """The parameter vector ``P`` of the functions (:attr:`functions`): the fixed values, then each free
        parameter's guess."""
        values = [*self.parameter_vector(), *(v.guess_value for v in self.free_parameters)]
        return ca.DM(values) if values else ca.DM(0, 1)

    def dynamics(self, x: Any, u: Any, t: Any, P: Any = None) -> Any:
        """``f(x, u, t)`` with this problem's parameters, or ``P`` (numbers give a DM, CasADi symbols an expression).

        Here and below, ``P`` (default :attr:`full_parameters`) is the full parameter vector: the fixed
        values, then the free parameters (their guesses by default; a transcription passes
        its NLP symbols).
        """
        return self.functions.f(x, u, t, self.full_parameters if P is None else P)

    def lagrange(self, x: Any, u: Any, t: Any, P: Any = None) -> Any:
        """``L(x, u, t)`` with this problem's parameters; 0 without a running cost."""
        return (
            self.functions.L(x, u, t, self.full_parameters if P is None else P)
            if self.functions.L is not None
            else ca.DM(0)
        )

    def mayer(self, x0: Any, xf: Any, t0: Any, tf: Any, P: Any = None) -> Any:
        """``phi(x0, xf, t0, tf)`` with this problem's parameters; 0 without a Mayer term."""
        if self.functions.phi is None:
            return ca.DM(0)
        return self.functions.phi(x0, xf, t0, tf, self.full_parameters if P is None else P)

    def path(self, x: Any, u: Any, t: Any, P: Any = None) -> Any:
        """The stacked path constraints ``g(x, u, t)`` with this problem's parameters (None without)."""
        c = self.functions.path
        return None if c is None else c.function(x, u, t, self.full_parameters if P is None else P)

    def boundary(self, x0: Any, xf: Any, t0: Any, tf: Any, P: Any = None) -> Any:
        """The stacked boundary constraints ``psi(x0, xf, t0, tf)`` with this problem's parameters (None without)."""
        c = self.functions.boundary
        return None if c is None else c.function(x0, xf, t0, tf, self.full_parameters if P is None else P)

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
        problem's: a trajectory's parameters that another phase declares). A callable of the other kind's arguments,
        or of too few or too many, is a TypeError naming ``what`` and both kinds (``sample``'s and ``value``'s).
        """
        if kind not in ("running", "boundary"):
            raise ValueError(f"kind must be 'running' or 'boundary', got {kind!r}")
        fix = EXPRESSION_KINDS[kind]
        if not callable(fn):
            raise TypeError(f"{what} must be a callable of the problem's variables, got {fn!r}: {fix}")
        names = [*self.parameter_names, *extra_parameters]
        sym = StatementSymbols.of(self.state_names, self.control_names, names)
        expr = column(sym.call(fn, kind, what, has_parameters=bool(names), fix=fix), what)
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
