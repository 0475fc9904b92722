"""Compiling a statement: the symbols its callables are called on, and the functions built from them."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, cast

import casadi as ca
import numpy as np

from ..names import Named, NamedParameters, argument_names, call
from .constraints import Constraint, ConstraintSet
from .functions import ProblemFunctions

# the inputs of a running callable (a function of time) and of a boundary one (a function of the ends), before p
SIGNATURES = {"running": ("x", "u", "t"), "boundary": ("x0", "xf", "t0", "tf")}
# argument names that say a callable was written for the other signature (an end or its time along the path, a
# control at the ends); both signatures take four arguments with p, so the count cannot tell them apart
FOREIGN_NAMES = {"running": frozenset(SIGNATURES["boundary"]), "boundary": frozenset({"u"})}
# what a running or a boundary callable is, for the messages
READS = {"running": "a function of time", "boundary": "a function of the ends"}


def check_signature(fn: Callable[..., Any], kind: str, what: str, fix: str = "") -> None:
    """A TypeError naming ``what``, the signature it is read with and ``fix`` where ``fn``'s argument names are those
    of the other signature (``FOREIGN_NAMES``): ``lambda x0, xf, t0, tf: xf[0]`` as a path constraint would be
    read as ``(x, u, t, p)``. Only the arguments a call fills are read: one with a default value
    (``lambda x, u, t, tf=tf: ...``, a loop's value bound) is the user's own."""
    names = argument_names(fn, required=True)
    if not names or not FOREIGN_NAMES[kind] & set(names):
        return
    other = "boundary" if kind == "running" else "running"
    fix = fix or f"write it as ({', '.join(SIGNATURES[kind])})"
    raise TypeError(
        f"{what} takes ({', '.join(names)}), {READS[other]}, but is called as {READS[kind]}, "
        f"({', '.join(SIGNATURES[kind])}) and p last where it takes one: {fix}"
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
            "running": [Named(x, state_names, "state", "x"), Named(u, control_names, "control", "u"), t],
            "boundary": [Named(x0, state_names, "state", "x0"), Named(xf, state_names, "state", "xf"), t0, tf],
        }
        return cls(x, u, t, x0, xf, t0, tf, P, views, NamedParameters(P, parameter_names))

    def inputs(self, kind: str) -> list[ca.SX]:
        """The plain symbols of ``kind`` (``"running"`` or ``"boundary"``), then ``P``: a Function's inputs."""
        plain = [self.x, self.u, self.t] if kind == "running" else [self.x0, self.xf, self.t0, self.tf]
        return [*plain, self.P]

    def call(self, fn: Callable[..., Any], kind: str, what: str, *, has_parameters: bool, fix: str = "") -> Any:
        """``fn`` on the named views of ``kind`` (and ``p`` if it takes it: :func:`ocpkit.names.call`); one written
        for the other signature (``check_signature``) or with too few or too many arguments is a TypeError
        naming ``what``, the signature and ``fix``."""
        check_signature(fn, kind, what, fix)
        views = self.views[kind]
        return call(fn, views, self.p, has_parameters=has_parameters, what=what, signature=SIGNATURES[kind], hint=fix)


def build_functions(
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

    def user(fn: Callable[..., Any], kind: str, what: str, fix: str = "") -> Any:
        return sym.call(fn, kind, what, has_parameters=with_parameters, fix=fix)

    xdot = column(user(dynamics, "running", "dynamics", "write the dynamics as f(x, u, t)"), "dynamics")
    if xdot.shape != (nx, 1):
        raise ValueError(f"dynamics returned shape {xdot.shape}, expected ({nx}, 1) for states {list(state_names)}")
    f = ca.Function("f_p", [x, u, t, P], [xdot], ["x", "u", "t", "P"], ["xdot"])
    L: ca.Function | None = None
    phi: ca.Function | None = None
    if lagrange is not None:
        fix = "the running cost is lagrange=L(x, u, t); a cost of the ends is mayer=phi(x0, xf, t0, tf)"
        expr = column(user(lagrange, "running", "lagrange", fix), "lagrange")
        if expr.shape != (1, 1):
            raise ValueError(f"lagrange must return a scalar, got shape {expr.shape}")
        L = ca.Function("L_p", [x, u, t, P], [expr], ["x", "u", "t", "P"], ["L"])
    if mayer is not None:
        fix = "the cost of the ends is mayer=phi(x0, xf, t0, tf); a running cost is lagrange=L(x, u, t)"
        expr = column(user(mayer, "boundary", "mayer", fix), "mayer")
        if expr.shape != (1, 1):
            raise ValueError(f"mayer must return a scalar, got shape {expr.shape}")
        phi = ca.Function("phi_p", [x0, xf, s0, sf, P], [expr], ["x0", "xf", "t0", "tf", "P"], ["phi"])
    on_path = "write it as (x, u, t) for a constraint along the path, or move it to boundary_constraints="
    on_ends = "write it as (x0, xf, t0, tf) for a constraint on the ends, or move it to path_constraints="
    path = constraint_set(
        "path", path_constraints, [x, u, t], ["x", "u", "t"], P, lambda fn, what: user(fn, "running", what, on_path)
    )
    boundary = constraint_set(
        "boundary",
        boundary_constraints,
        [x0, xf, s0, sf],
        ["x0", "xf", "t0", "tf"],
        P,
        lambda fn, what: user(fn, "boundary", what, on_ends),
    )
    return ProblemFunctions(f, L, phi, path, boundary)


@dataclass(frozen=True)
class Readers:
    """What a problem's functions read (:func:`readers`), by index: ``controls`` and ``parameters`` (of ``P``) that any
    function depends on; ``states_along``, the states that another state's dynamics, the running cost or a path
    constraint depends on (a state's own rate is not counted: an output integral reads only itself), and
    ``states_own``, those whose own rate does; ``states_mayer`` and ``states_boundary``, the states whose value at
    either end the Mayer term or the boundary constraints depend on."""

    controls: frozenset[int]
    parameters: frozenset[int]
    states_along: frozenset[int]
    states_own: frozenset[int]
    states_mayer: frozenset[int]
    states_boundary: frozenset[int]


def readers(functions: ProblemFunctions) -> Readers:
    """What the functions of a problem read (:class:`Readers`): one walk of its dynamics, costs and constraints, the
    one definition that the statement's checks (an unread control or parameter), a verdict's notes (an unread
    state) and the indirect chain (an output integral) share; walked once per problem's functions."""
    cached = functions.derived.get("readers")
    if cached is None:
        cached = functions.derived["readers"] = _walk_readers(functions)
    return cast(Readers, cached)


def _walk_readers(functions: ProblemFunctions) -> Readers:
    f = functions.f
    x, u, t, P = (ca.SX.sym(name, f.size1_in(i)) for i, name in enumerate(("x", "u", "t", "P")))
    nx = x.numel()
    x0, xf, t0, tf = ca.SX.sym("x0", nx), ca.SX.sym("xf", nx), ca.SX.sym("t0"), ca.SX.sym("tf")
    rates = f(x, u, t, P)
    running = [functions.L(x, u, t, P)] if functions.L is not None else []
    if functions.path is not None:
        running.append(functions.path.function(x, u, t, P))
    mayer = functions.phi(x0, xf, t0, tf, P) if functions.phi is not None else ca.SX(0, 1)
    boundary = functions.boundary.function(x0, xf, t0, tf, P) if functions.boundary is not None else ca.SX(0, 1)
    along, ends = ca.vertcat(rates, *running), ca.vertcat(mayer, boundary)
    others = ca.vertcat(*running) if running else ca.SX(0, 1)

    def read_along(i: int) -> bool:
        return any(ca.depends_on(rates[j], x[i]) for j in range(nx) if j != i) or ca.depends_on(others, x[i])

    return Readers(
        controls=frozenset(j for j in range(u.numel()) if ca.depends_on(along, u[j])),
        parameters=frozenset(j for j in range(P.numel()) if ca.depends_on(along, P[j]) or ca.depends_on(ends, P[j])),
        states_along=frozenset(i for i in range(nx) if read_along(i)),
        states_own=frozenset(i for i in range(nx) if ca.depends_on(rates[i], x[i])),
        states_mayer=frozenset(i for i in range(nx) if ca.depends_on(mayer, ca.vertcat(x0[i], xf[i]))),
        states_boundary=frozenset(i for i in range(nx) if ca.depends_on(boundary, ca.vertcat(x0[i], xf[i]))),
    )


def read_inputs(functions: ProblemFunctions) -> tuple[set[int], set[int]]:
    """``(controls, parameters)``: the indices of the controls and of the parameter vector ``P`` that some function of
    ``functions`` depends on (the dynamics, the costs, the path and the boundary constraints; :func:`readers`)."""
    read = readers(functions)
    return set(read.controls), set(read.parameters)


def constraint_set(
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
            e = column(user(c.function, what), what)
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


def column(expr: Any, what: str) -> ca.SX:
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
