"""Multiple shooting over a known sequence of arcs, the junction times unknowns (Maurer, "Numerical solution of
singular control problems using multiple shooting techniques", JOTA 18, 1976; the arc-wise shooting of the
control-toolbox tutorials, here with every flow and condition derived from the problem).

Each arc gives each control a *kind* (:data:`ocpkit.structure.ARC_KINDS`) and its flow follows from the
Hamiltonian ``H = L + p'f`` of the problem, written with the time derivative along the Hamiltonian flow
``D F = F_x f - F_p H_x + F_t`` (a Poisson bracket with H, CasADi-symbolic):

* **bang** (``lower``, ``upper``, ``zero``): the control at that value;
* **regular**: the control from ``H_u = 0``, explicit where H is quadratic in it; otherwise the control becomes a
  state of the arc with ``du/dt = -H_uu^-1 (H_ux f - H_up H_x + H_ut)`` (the derivative of ``H_u = 0`` along the
  flow), its value at the arc's start an unknown and ``H_u = 0`` there a condition;
* **singular**: ``phi = H_u`` does not depend on ``u``; its derivatives ``D^k phi`` are taken until ``u`` appears,
  in ``D^(2q) phi`` (order ``q``), which gives the feedback ``u = -D^(2q) phi|_(u=0) / d_u D^(2q) phi``; at the
  arc's entry ``phi, D phi, ..., D^(2q-1) phi`` vanish. For a control with an L1 cost (``H = H0 + psi u + w |u|``)
  ``phi = psi + s w`` on the branch ``s`` (the sign of the bang arc beside it, :attr:`ArcType.signs`);
* **boundary** of an inequality ``c <= 0`` (:func:`ocpkit.structure.inequalities`): for a mixed constraint
  (``c_u != 0``) the control from ``c = 0``, the multiplier ``mu = -H_u / c_u`` and ``dp/dt = -H_x - mu c_x``; at
  each junction (not at t0 or tf) the control is continuous: ``mu = 0`` where H is regular in it, ``c = 0`` with
  the neighbouring arc's control where H is affine in it. For a pure state constraint of order ``q`` (one or two:
  ``D^q c`` is the first derivative that contains the control), direct adjoining (Hartl, Sethi & Vickson, SIAM Rev.
  37, 1995): the control from ``D^q c = 0``; the multiplier ``mu`` in ``dp/dt = -H_x - mu c_x`` that keeps
  ``phi = H_u`` (at the boundary control) zero on the arc, ``mu = D^q phi / ((D^(q-1) phi)_p . c_x)`` (``mu`` does
  not enter ``phi, ..., D^(q-1) phi``). At the arc's entry the tangency ``c = ... = D^(q-1) c = 0`` and the
  minimum condition ``phi = ... = D^(q-1) phi = 0`` hold. Of order one the costate is continuous at the junctions
  (Jacobson, Lele & Speyer, JMAA 35, 1971; Maurer 1977 where the control jumps), so ``phi = 0`` at the entry is the
  switching function's zero (from a bang arc) or the control's continuity (a regular control); from a singular arc
  it holds already, and ``c = 0`` alone is posed (a singular arc after it keeps its own entry conditions: the
  system is then over-determined and consistent, Gauss-Newton). Of order two the costate jumps at the entry, at the
  exit and at a touch point, ``p(t+) = p(t-) - nu c_x`` with ``nu`` an unknown (``nu >= 0`` is certified): the
  entry's four conditions determine its time and jump; the exit's time and jump are determined by what follows;
  a touch point's by ``c = D c = 0``. A constraint of order two on a control H is affine in (chattering junctions,
  Robbins 1980), one of order three, and one that leaves several controls inside their bounds are refused by name.

Junctions between two bang arcs satisfy ``H(u_left) = H(u_right)``, the row divided by the control's jump (the
switching function crosses its threshold: the row is its value there); between a regular arc and a bound the control is continuous. Unknowns: the free initial states, the
initial costates, at each junction its time and ``(x, p)`` there (multiple shooting: each arc integrated from its
own node, matched at its end), a free final time, one multiplier per boundary equality, and the starting controls
of implicit regular arcs, and the costate's jump at each junction of order two. Conditions: the matching, the junctions', and the transversality conditions of
``Phi = phi + nu' psi`` (``p(t0) = -Phi_x0`` for a free initial state, ``p(tf) = Phi_xf`` for a free final one,
``H(tf) + Phi_tf = 0`` for a free final time). The arcs are integrated by CVODES on a normalised time, with exact
derivatives of the shooting function through its forward sensitivities.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, cast

import casadi as ca
import numpy as np

from .._arrays import unique
from ..errors import SolverError
from ..hamiltonian_form import decompose, l1_controls, sample_value
from ..nodes import cubic_hermite
from ..outcome import Outcome
from ..statement import FreeFinalTime
from ..structure import MAX_ORDER, Structure, inequalities
from ..trajectory import Trajectory
from .result import IndirectResult, noise_floor, settled, stall_advice

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..statement import ConstraintSet, OptimalControlProblem

BANG = ("lower", "upper", "zero")


@dataclass(frozen=True)
class ArcType:
    """The kind of each control on one arc (in the problem's control order) and its active inequality, if any;
    ``touch`` names the state constraint whose touch point the arc starts at (the costate jumps there)."""

    kinds: tuple[str, ...]
    constraint: str | None = None
    touch: str | None = None
    #: per control, the branch of an L1 control's singular arc (``+1``: ``u > 0``, where ``H_u = psi + w``;
    #: ``-1``: ``u < 0``), read from the bang arc next to it; 0 elsewhere (empty where there is none)
    signs: tuple[int, ...] = ()


def arc_sequence(
    structure: Structure, problem: OptimalControlProblem, t0: float, tf: float
) -> list[tuple[ArcType, float, float]]:
    """The arcs of the whole control vector on ``[t0, tf]`` from each control's arcs: the common refinement of
    their partitions, as ``(ArcType, start, end)``, cut at the structure's touch points (the arc after each names
    it). A control without bounds is ``regular`` throughout."""
    touches = {float(touch.time): touch.constraint for touch in structure.touches}
    cuts = sorted(
        {float(t0), float(tf)} | {a.start for a in structure.arcs} | {a.end for a in structure.arcs} | set(touches)
    )
    out: list[tuple[ArcType, float, float]] = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        mid = 0.5 * (a + b)
        kinds: list[str] = []
        constraint: str | None = None
        for c in problem.controls:
            arcs = [x for x in structure.arcs if x.control == c.name and x.start <= mid <= x.end]
            if not arcs:
                kinds.append("regular")
                continue
            kinds.append(arcs[0].kind)
            if arcs[0].constraint is not None:
                constraint = arcs[0].constraint
        kind = ArcType(tuple(kinds), constraint, touches.get(a))
        if out and out[-1][0] == kind and kind.touch is None:
            out[-1] = (kind, out[-1][1], b)
        else:
            out.append((kind, a, b))
    return _l1_branches(out, problem)


def _l1_branches(
    arcs: list[tuple[ArcType, float, float]], problem: OptimalControlProblem
) -> list[tuple[ArcType, float, float]]:
    """Each singular arc of a control with an L1 cost given its branch (:attr:`ArcType.signs`): the sign of the
    control on the arc of it just before or just after, where that one is at a bound (``"upper"`` or ``"lower"``;
    none where neither is, or where they disagree)."""
    l1 = l1_controls(problem)
    if not l1 or not any("singular" in kind.kinds for kind, _, _ in arcs):
        return arcs
    out = []
    for k, (kind, a, b) in enumerate(arcs):
        signs = [0] * len(kind.kinds)
        for i in l1:
            if kind.kinds[i] != "singular":
                continue
            before = next(
                (arcs[j][0].kinds[i] for j in range(k - 1, -1, -1) if arcs[j][0].kinds[i] != "singular"), None
            )
            after = next(
                (arcs[j][0].kinds[i] for j in range(k + 1, len(arcs)) if arcs[j][0].kinds[i] != "singular"), None
            )
            bounds = {w for w in (before, after) if w in ("upper", "lower")}
            signs[i] = {"upper": 1, "lower": -1}[bounds.pop()] if len(bounds) == 1 else 0
        out.append((replace(kind, signs=tuple(signs)) if any(signs) else kind, a, b))
    return out


@dataclass
class _Flow:
    """One arc's derived flow: the control, the extra (implicit control) states, the costate multiplier term."""

    kind: ArcType
    control: ca.SX  # in x, p, t, P (and w, the implicit controls)
    w: ca.SX  # the implicit regular controls carried as states (0 x 1 if none)
    wdot: ca.SX
    mu: ca.SX  # the boundary multiplier (0 without)
    entry: list[ca.SX]  # the arc type's conditions at its start (a singular arc's, a boundary arc's), in x, p, t, P, w
    boundary_control: int | None = None  # the control a boundary arc's constraint determines
    implicit: list[ca.SX] = field(default_factory=list)  # H_u = 0 at the start of an implicit regular arc
    #: (control index, order q, d_u D^(2q) phi) for Legendre-Clebsch
    singular: list[tuple[int, int, ca.SX]] = field(default_factory=list)
    #: on a boundary arc of a state constraint of order ``q``: ``q``, the tangency conditions ``c, Dc, ...,
    #: D^(q-1) c`` and the minimum conditions ``phi, D phi, ..., D^(q-1) phi`` (``phi = H_u`` at the boundary control)
    order: int = 0
    tangency: list[ca.SX] = field(default_factory=list)
    minimum: list[ca.SX] = field(default_factory=list)


class ArcFlows:
    """The symbolic flows and conditions of a problem's arcs (module docstring)."""

    def __init__(self, problem: OptimalControlProblem) -> None:
        self.problem = problem
        ham = problem.functions.hamiltonian
        self.ham = ham
        self.x, self.p, self.u, self.t, self.P = ham.x, ham.p, ham.u, ham.t, ham.P
        self.H, self.f = ham.H, ham.f
        self.Hx = ca.gradient(ham.H, ham.x)
        self.ineq = {q.name: q for q in inequalities(problem)}
        self.l1 = l1_controls(problem)
        self._cache: dict[ArcType, _Flow] = {}

    def depends(self, expr: ca.SX, ui: ca.SX) -> bool:
        """Whether ``expr`` depends on the control ``ui``: structurally, and then at random points (a bracket such
        as ``D H_u`` contains ``u`` in terms that cancel, which CasADi does not simplify)."""
        if not ca.depends_on(expr, ui):
            return False
        d = ca.Function("d", [self.x, self.p, self.u, self.t, self.P], [ca.jacobian(expr, ui), expr])
        rng = np.random.default_rng(7)
        P = np.asarray(self.problem.full_parameters, dtype=float).ravel()
        x = np.array([sample_value(s) for s in self.problem.states])
        for _ in range(6):
            lo = np.array([c.lower if np.isfinite(c.lower) else -1.0 for c in self.problem.controls])
            hi = np.array([c.upper if np.isfinite(c.upper) else 1.0 for c in self.problem.controls])
            args = (x * (1 + 0.1 * rng.normal(size=x.size)), rng.normal(size=x.size), rng.uniform(lo, hi), 0.1, P)
            dv, v = (np.asarray(a, dtype=float) for a in d(*args))
            if np.any(np.abs(dv) > 1e-9 * (1 + np.abs(v).max())):
                return True
        return False

    def _constant(self, expr: ca.SX) -> float | None:
        """The value of ``expr`` (in x, p, t, P) where it is the same at random points (a weight that CasADi does not
        simplify to a number), else None."""
        f = ca.Function("value", [self.x, self.p, self.t, self.P], [expr])
        rng = np.random.default_rng(11)
        P = np.asarray(self.problem.full_parameters, dtype=float).ravel()
        values = [
            float(f(rng.normal(size=self.x.numel()), rng.normal(size=self.x.numel()), rng.uniform(), P))
            for _ in range(4)
        ]
        return values[0] if max(values) - min(values) <= 1e-12 * (1 + abs(values[0])) else None

    def D(self, F: ca.SX) -> ca.SX:
        """``dF/dt = F_x f - F_p H_x + F_t`` along the Hamiltonian flow, the control symbolic."""
        x, p, t = self.x, self.p, self.t
        return ca.jtimes(F, x, self.f) + ca.jtimes(F, p, -self.Hx) + ca.jacobian(F, t)

    def flow(self, kind: ArcType) -> _Flow:
        if kind not in self._cache:
            self._cache[kind] = self._derive(kind)
        return self._cache[kind]

    def _derive(self, kind: ArcType) -> _Flow:
        problem, u, H = self.problem, self.u, self.H
        nu = problem.nu
        names = problem.control_names
        value: list[Any] = [None] * nu
        for i, which in enumerate(kind.kinds):
            c = problem.controls[i]
            if which in BANG:
                value[i] = ca.SX({"lower": c.lower, "upper": c.upper, "zero": 0.0}[which])
        free = [i for i in range(nu) if value[i] is None]
        mu: ca.SX = ca.SX(0)
        entry: list[ca.SX] = []
        singular: list[tuple[int, int, ca.SX]] = []
        w, wdot = ca.SX(0, 1), ca.SX(0, 1)

        bang = [i for i in range(nu) if value[i] is not None]

        def fixed(expr: ca.SX) -> ca.SX:  # the bang controls at their values
            if not bang:
                return expr
            return ca.substitute(expr, ca.vertcat(*[u[i] for i in bang]), ca.vertcat(*[value[i] for i in bang]))

        boundary_control = None
        state_arc: dict[str, Any] = {}
        if kind.constraint is not None:
            value, mu, entry, boundary_control, state_arc = self._boundary(kind, value, free, fixed)
        sing = [i for i in free if kind.kinds[i] == "singular"]
        if kind.constraint is None and sing:
            if len(sing) > 1:
                raise ValueError(
                    f"controls {[names[i] for i in sing]} are singular on the same arc: a joint singular feedback is "
                    "not derived; keep the direct solution"
                )
            i = sing[0]
            other = [j for j in free if j != i]
            if other:
                raise ValueError(
                    f"control {names[i]!r} is singular while {[names[j] for j in other]} are not at a bound: this "
                    "combination is not derived; keep the direct solution"
                )
            if i in self.l1:  # H = H0 + psi u + w |u|: on the branch u = s |u|, H_u = psi + s w
                sign = kind.signs[i] if kind.signs else 0
                if sign == 0:
                    raise ValueError(
                        f"control {names[i]!r} has an L1 cost and a singular arc with no bang arc of it at a bound "
                        "on either side: the branch of |u| (psi = -w or +w) is not determined; keep the direct solution"
                    )
                weight = self._constant(decompose(H, u, problem.nu)[2][i])
                if weight is None:
                    raise ValueError(
                        f"control {names[i]!r}: the weight of its L1 cost depends on the state or time: its singular "
                        "arc is not derived; keep the direct solution"
                    )
                H = H - weight * ca.fabs(u[i]) + sign * weight * u[i]
            phi = fixed(ca.jacobian(H, u[i]))
            if self.depends(phi, u[i]):
                raise ValueError(f"control {names[i]!r}: H is not affine in it, so it has no singular arc")
            phi = ca.substitute(phi, u[i], 0)
            derivs = [phi]
            while len(derivs) < 5:
                d = fixed(self.D(derivs[-1]))
                if self.depends(d, u[i]):
                    derivs.append(d)
                    break
                derivs.append(ca.substitute(d, u[i], 0))  # the control's terms cancel
            k = len(derivs) - 1
            if not self.depends(derivs[-1], u[i]) or k % 2:
                raise ValueError(
                    f"control {names[i]!r}: the singular arc's control does not appear in an even derivative of the "
                    f"switching function up to the fourth (found order {k / 2:g}): its feedback is not derived"
                )
            a = ca.jacobian(derivs[-1], u[i])
            if ca.depends_on(a, u[i]):
                raise ValueError(f"control {names[i]!r}: its singular feedback is not affine in it")
            value[i] = -ca.substitute(derivs[-1], u[i], 0) / a
            entry = derivs[:k]
            singular.append((i, k // 2, a))
        reg = [i for i in free if value[i] is None]
        implicit: list[ca.SX] = []
        if reg:
            l1 = [names[i] for i in reg if i in self.l1]
            if l1:
                raise ValueError(
                    f"control(s) {l1} have an L1 cost (|u| in H) and are regular on an arc: the law from H_u = 0 with "
                    "|u| is not derived here; use method='switching' (its saturated laws) or keep the direct solution"
                )
            value, w, wdot, implicit = self._regular(reg, value, fixed)
        control = ca.vertcat(*value)
        if ca.depends_on(ca.vertcat(control, mu), u):
            raise ValueError(
                f"on the arc {ArcShooting.arc_name(kind)} a control depends on another that no condition determines "
                "(several controls inside their bounds, coupled): this combination is not derived; keep the direct "
                "solution"
            )
        entry = [ca.substitute(e, u, control) for e in entry]
        for key in ("tangency", "minimum"):
            if key in state_arc:
                state_arc[key] = [ca.substitute(e, u, control) for e in state_arc[key]]
        return _Flow(kind, control, w, wdot, mu, entry, boundary_control, implicit, singular, **state_arc)

    def _regular(
        self, reg: list[int], value: list[Any], fixed: Callable[[ca.SX], ca.SX]
    ) -> tuple[list[Any], ca.SX, ca.SX, list[ca.SX]]:
        """The regular controls from ``H_u = 0``: explicit when H is quadratic in them, else carried as states."""
        u, H = self.u, self.H
        ur = ca.vertcat(*[u[i] for i in reg])
        Hu = fixed(ca.jacobian(H, ur).T)
        Huu = ca.jacobian(Hu, ur)
        names = [self.problem.control_names[i] for i in reg]
        if Huu.is_zero():
            if Hu.is_zero():
                raise ValueError(
                    f"H does not depend on {names} on this arc (a thrust angle while the thrust is off): the control "
                    "is undetermined there; keep the direct solution"
                )
            raise ValueError(
                f"H is affine in {names} on a regular arc: H_u = 0 does not give the control (a singular arc does)"
            )
        if not ca.depends_on(Huu, ur):
            sol = -ca.solve(Huu, ca.substitute(Hu, ur, ca.DM.zeros(len(reg))))
            for k, i in enumerate(reg):
                value[i] = sol[k]
            return value, ca.SX(0, 1), ca.SX(0, 1), []
        w = ca.SX.sym("w", len(reg))
        full = list(value)
        for k, i in enumerate(reg):
            full[i] = w[k]
        ufull = ca.vertcat(*full)
        Hu_w = ca.substitute(Hu, ur, w)
        dHu = ca.substitute(self.D(Hu), u, ufull)  # the part of d/dt H_u at fixed u
        wdot = -ca.solve(ca.substitute(Huu, ur, w), ca.substitute(dHu, ur, w))
        return full, w, wdot, [ca.substitute(Hu_w, u, ufull)]

    def _boundary(
        self, kind: ArcType, value: list[Any], free: list[int], fixed: Callable[[ca.SX], ca.SX]
    ) -> tuple[list[Any], ca.SX, list[ca.SX], int, dict[str, Any]]:
        """The control and the multiplier on a boundary arc of ``kind.constraint``, the arc's entry conditions, and
        for a state constraint the fields of :class:`_Flow` that its junctions need (module docstring)."""
        names = self.problem.control_names
        q = self.ineq.get(cast(str, kind.constraint))  # (a boundary arc's)
        if q is None:
            raise ValueError(f"unknown inequality {kind.constraint!r}; the problem's are {sorted(self.ineq)}")
        x, u, t, P = self.x, self.u, self.t, self.P
        c = q.function(x, u, t, P)
        inside = [i for i in free if kind.kinds[i] == "boundary"]
        if len(inside) != 1:
            raise ValueError(
                f"the boundary arc of {kind.constraint!r} has {len(inside)} controls inside their bounds: one "
                "constraint determines one control"
            )
        i = inside[0]
        if not q.pure:
            cu = ca.jacobian(c, u[i])
            if ca.depends_on(cu, u[i]):
                raise ValueError(
                    f"{kind.constraint!r} is not affine in {names[i]!r}: its boundary control is not derived"
                )
            value[i] = fixed(-ca.substitute(c, u[i], 0) / cu)
            Hu = ca.jacobian(self.H, u[i])
            mu = fixed(-Hu / cu)
            mu = ca.substitute(mu, u[i], value[i])
            return value, mu, [mu], i, {}
        order = q.order
        if order == 0 or i not in q.controls:
            raise ValueError(
                f"no time derivative of {kind.constraint!r} up to order {MAX_ORDER} contains {names[i]!r}: its "
                "boundary control is not derived"
            )
        if order > 2:
            raise ValueError(
                f"{kind.constraint!r} is a state constraint of order {order}: boundary arcs of orders one and two "
                "only are derived; keep the direct solution"
            )
        tangency = [c]
        for _ in range(order):
            tangency.append(fixed(self.D(tangency[-1])))
        rate = tangency.pop()
        a = ca.jacobian(rate, u[i])
        if ca.depends_on(a, u[i]):
            raise ValueError(f"the derivative of order {order} of {kind.constraint!r} is not affine in {names[i]!r}")
        value[i] = -ca.substitute(rate, u[i], 0) / a
        phi = fixed(ca.jacobian(self.H, u[i]))
        affine = not self.depends(phi, u[i])
        if affine and order > 1:
            raise ValueError(
                f"H is affine in {names[i]!r} and {kind.constraint!r} is a state constraint of order {order}: a "
                "boundary arc is then met through infinitely many switchings (Robbins 1980), whose junctions are not "
                "derived; keep the direct solution"
            )
        # the minimum condition phi = H_u = 0 at the boundary control is kept on the arc by the multiplier mu of
        # direct adjoining (p' = -H_x - mu c_x): phi, D phi, ..., D^(q-1) phi do not contain mu (phi_p . c_x = f_u . c_x
        # = 0 below the order), D^q phi does, linearly: mu = D^q phi / ((D^(q-1) phi)_p . c_x)
        minimum = [ca.substitute(phi, u[i], 0 if affine else value[i])]
        for _ in range(order - 1):
            minimum.append(ca.substitute(fixed(self.D(minimum[-1])), u[i], value[i]))
        denominator = ca.dot(ca.gradient(minimum[-1], self.p), ca.gradient(c, x))
        mu = ca.substitute(fixed(self.D(minimum[-1])), u[i], value[i]) / denominator
        return value, mu, [c], i, {"order": order, "tangency": tangency, "minimum": minimum}

    def rhs(self, kind: ArcType) -> tuple[ca.SX, ca.SX, _Flow]:
        """``(y, rhs, flow)``: ``y = (x, p, w, J)``, its time derivative on this arc, and the arc's :class:`_Flow`."""
        fl = self.flow(kind)
        x, p, t, P, u = self.x, self.p, self.t, self.P, self.u
        ineq = self.ineq[kind.constraint].function(x, u, t, P) if kind.constraint else ca.SX(0)
        J = ca.SX.sym("J")
        y = ca.vertcat(x, p, fl.w, J)
        L = self.ham.L
        pdot = -self.Hx - fl.mu * ca.gradient(ineq, x) if kind.constraint else -self.Hx
        rhs = ca.vertcat(self.f, pdot, ca.SX.zeros(fl.w.numel()), L)
        rhs = ca.substitute(rhs, u, fl.control)
        if fl.w.numel():
            rhs[2 * self.problem.nx : 2 * self.problem.nx + fl.w.numel()] = fl.wdot
        return y, rhs, fl


@dataclass
class ArcResult(IndirectResult):
    """A multiple-shooting run over arcs: the fields every indirect run has
    (:class:`~ocpkit.shooting.result.IndirectResult`; ``z`` in the layout :attr:`ArcShooting.layout`, ``iterations``
    the Newton iterations, ``evaluations`` the evaluations of S), and its own: ``times`` the arcs' bounds (t0,
    junctions, tf; :attr:`tf` the last), ``multipliers`` of the boundary equalities and ``arcs`` the
    :class:`ArcType` of each arc. Its :attr:`trajectory` is an :class:`ArcTrajectory` (a ValueError where the last
    iterate cannot be integrated)."""

    times: np.ndarray
    multipliers: np.ndarray
    arcs: list[ArcType]
    #: the costate's jumps, ``(time, constraint, nu)`` with ``p(t+) = p(t-) - nu c_x`` (``nu >= 0`` at an
    #: extremal): at the junctions of state constraints of order two and their touch points
    jumps: list[tuple[float, str, float]] = field(default_factory=list)
    #: the extremal as functions of time, None where the last iterate cannot be integrated (read :attr:`trajectory`)
    _trajectory: ArcTrajectory | None = field(default=None, repr=False)

    @property
    def tf(self) -> float:
        """The final time."""
        return float(self.times[-1])

    @property
    def trajectory(self) -> ArcTrajectory:
        """The extremal as functions of time (:class:`ArcTrajectory`)."""
        if self._trajectory is None:
            raise ValueError(f"this run has no trajectory: {self.status}: {self.detail}")
        return self._trajectory


class ArcShooting:
    """Multiple shooting of ``problem`` over the arcs ``arcs`` (``[(ArcType, start, end), ...]`` from
    :func:`arc_sequence`; start and end are estimates); module docstring. ``rtol``/``atol``: CVODES's.

    Attributes
    ----------
    layout : list[tuple[str, int]]
        The unknowns ``z`` block by block, as ``[(name, size), ...]`` in order: ``x0`` the free initial states,
        ``p0`` the initial costates, ``t<k>`` and ``y<k>`` the time and ``(x, p)`` at junction ``k``, ``tf`` where
        free, ``nu`` the boundary multipliers, ``w<k>`` the starting values of arc ``k``'s implicit regular controls
        (of a phase, ``phase=True``: neither ``tf`` nor ``nu``, which are the trajectory's).
    """

    def __init__(
        self,
        problem: OptimalControlProblem,
        arcs: Sequence[tuple[ArcType, float, float]],
        *,
        rtol: float = 1e-12,
        atol: float = 1e-12,
        phase: bool = False,
    ) -> None:
        #: a phase of a multi-phase boundary value problem (:class:`~ocpkit.shooting.phases.PhasedArcShooting`):
        #: its times are inputs and its ends' conditions the trajectory's; ``interior`` (a CasADi function of
        #: ``(z, P, t0, tf)``) gives the arcs' conditions, the phase's ends and H there, its cost and its times
        self.phase = phase
        if problem.free_initial_time and not phase:
            raise ValueError(f"{problem.name!r}: arc shooting integrates from a fixed t0")
        if problem.free_parameters:
            raise ValueError(
                f"{problem.name!r} has free parameters: arc shooting does not take them yet (it would hold them at "
                "their guesses); the switching method takes them as states where the structure has no singular or "
                "boundary arc"
            )
        self.problem = problem
        self.kinds = [a[0] for a in arcs]
        self.estimates = np.array([a[1] for a in arcs] + [arcs[-1][2]], dtype=float)
        self.flows = ArcFlows(problem)
        nx = problem.nx
        self.nx = nx
        self.free_tf = isinstance(problem.tf, FreeFinalTime)
        for s in problem.states:
            for which in ("initial", "final"):
                if getattr(s, which) is not None and getattr(s, f"fixed_{which}") is None:
                    raise ValueError(
                        f"arc shooting supports fixed or free {which} states, not the interval of {s.name!r}"
                    )
        bc = problem.functions.boundary
        if bc is not None and np.any(bc.lower != bc.upper):
            raise ValueError(f"{problem.name!r}: arc shooting takes boundary equalities only, not inequalities")
        self.n_nu = 0 if bc is None else bc.size
        self.free_initial = [s.initial is None for s in problem.states]
        self.x0 = np.array([0.0 if s.initial is None else s.fixed_initial for s in problem.states])
        self.integrators: list[ca.Function] = []
        self.rhs: list[tuple[ca.SX, ca.SX, _Flow]] = []
        self.rtol, self.atol = rtol, atol
        for k, kind in enumerate(self.kinds):
            y, rhs, fl = self.flows.rhs(kind)
            self.integrators.append(self.integrator(f"arc{k}", y, rhs, [1.0]))
            self.rhs.append((y, rhs, fl))
        self._build()

    def integrator(self, name: str, y: ca.SX, rhs: ca.SX, grid: Sequence[float] | np.ndarray) -> ca.Function:
        """CVODES over an arc on the normalised time ``tau`` in [0, 1] (``t = ta + tau dt``, parameters
        ``(ta, dt, P)``), its outputs at ``grid``; at most 20000 steps, so that a hopeless iterate fails quickly."""
        tau, ta, dt = ca.SX.sym("tau"), ca.SX.sym("ta"), ca.SX.sym("dt")
        ode = ca.substitute(dt * rhs, self.flows.t, ta + tau * dt)
        dae = {"x": y, "p": ca.vertcat(ta, dt, self.flows.P), "t": tau, "ode": ode}
        opts = {"abstol": self.atol, "reltol": self.rtol, "max_num_steps": 20000}
        return ca.integrator(name, "cvodes", dae, 0.0, list(grid), opts)

    # -- the shooting function, symbolic -----------------------------------------------------------------
    def _build(self) -> None:
        problem, nx, fl = self.problem, self.nx, self.flows
        K = len(self.kinds)
        nw = [self.rhs[k][2].w.numel() for k in range(K)]
        nfree = int(np.sum(self.free_initial))
        sizes = [("x0", nfree), ("p0", nx)]
        self.jumps = self._jump_junctions()
        for k in range(1, K):
            sizes += [(f"t{k}", 1), (f"y{k}", 2 * nx)]
            if k in self.jumps:
                sizes.append((f"jump{k}", 1))
        if self.free_tf and not self.phase:
            sizes.append(("tf", 1))
        if not self.phase:
            sizes.append(("nu", self.n_nu))
        for k in range(K):
            sizes.append((f"w{k}", nw[k]))
        self.layout = sizes
        nz = sum(n for _, n in sizes)
        z = ca.MX.sym("z", nz)
        parts: dict[str, ca.MX] = {}
        offset = 0
        for name, n in sizes:
            parts[name] = z[offset : offset + n] if n else ca.MX(0, 1)
            offset += n
        P = ca.MX.sym("P", fl.P.numel())
        if self.phase:
            t0: Any = ca.MX.sym("t0")
            tf: Any = ca.MX.sym("tf")
        else:
            t0 = float(problem.t0)
            tf = parts["tf"] if self.free_tf else ca.MX(float(cast(float, problem.tf)))
        times = [ca.MX(t0) if isinstance(t0, float) else t0] + [parts[f"t{k}"] for k in range(1, K)] + [tf]
        xs: list[ca.MX] = []
        it = iter(range(nx))
        free_iter = iter(range(nfree))
        for i in it:
            xs.append(parts["x0"][next(free_iter)] if self.free_initial[i] else ca.MX(self.x0[i]))
        x0 = ca.vertcat(*xs)
        starts = [ca.vertcat(x0, parts["p0"])] + [parts[f"y{k}"] for k in range(1, K)]
        rows: list[ca.MX] = []
        ends: list[ca.MX] = []
        costs: list[ca.MX] = []
        # the functions of the conditions, in the SX symbols of ArcFlows
        sym_in = [fl.x, fl.p, fl.t, fl.P]
        for k in range(K):
            y, rhs, flow = self.rhs[k]
            w = parts[f"w{k}"]
            y0 = ca.vertcat(starts[k], w, 0)
            out = self.integrators[k](x0=y0, p=ca.vertcat(times[k], times[k + 1] - times[k], P))["xf"]
            ends.append(out)
            costs.append(out[-1])
            if k + 1 < K:
                arrival = out[: 2 * nx]
                if k + 1 in self.jumps:  # p(t+) = p(t-) - nu c_x at a state constraint's junction of order two
                    Cx = ca.Function("cx", [fl.x, fl.t, fl.P], [self._cx(self.jumps[k + 1])])
                    step = parts[f"jump{k + 1}"] * Cx(out[:nx], times[k + 1], P)
                    arrival = ca.vertcat(out[:nx], out[nx : 2 * nx] - step)
                rows.append(starts[k + 1] - arrival)
            # the arc's entry conditions at its start: an implicit regular arc's H_u = 0; a singular arc's (from its
            # start, t0 included); a boundary arc's at a junction (c = 0 for a state constraint, mu = 0 for a mixed)
            entry = list(flow.implicit)
            if flow.entry and (k > 0 or self.kinds[k].constraint is None):
                entry += self._entry(k)
            if k > 0 and self.kinds[k].touch is not None:  # a touch point: tangency, the jump its unknown
                entry += self._touch(k)
            if entry:
                E = ca.Function("entry", [*sym_in, flow.w], [ca.vertcat(*entry)])
                rows.append(E(starts[k][:nx], starts[k][nx:], times[k], P, w))
            if k > 0:
                rows += self._junction(k, ends[k - 1], starts[k], w, times[k], P)
        yf = ends[-1]
        xf, pf = yf[:nx], yf[nx : 2 * nx]
        self.nz = nz
        if self.phase:  # the trajectory's conditions at the ends are PhasedArcShooting's
            ends_H = [
                ca.Function("H", [*sym_in, flow.w], [ca.substitute(fl.H, fl.u, flow.control)])
                for flow in (self.rhs[0][2], self.rhs[-1][2])
            ]
            H_start = ends_H[0](x0, parts["p0"], times[0], P, parts["w0"])
            H_end = ends_H[1](xf, pf, tf, P, yf[2 * nx : 2 * nx + nw[-1]])
            self.interior = ca.Function(
                "interior",
                [z, P, times[0], tf],
                [ca.vertcat(*rows), x0, parts["p0"], xf, pf, H_start, H_end, sum(costs), ca.vertcat(*times)],
                ["z", "P", "t0", "tf"],
                ["rows", "x0", "p0", "xf", "pf", "H0", "Hf", "cost", "times"],
            )
            return
        # the end: fixed final states, transversality, boundary equalities, free tf
        X0, XF, T0, TF, Pm = ca.SX.sym("x0", nx), ca.SX.sym("xf", nx), ca.SX.sym("t0"), ca.SX.sym("tf"), fl.P
        nu = ca.SX.sym("nu", self.n_nu)
        Phi = problem.phi(X0, XF, T0, TF, Pm) if problem.phi is not None else ca.SX(0)
        psi = ca.SX(0, 1)
        bc = problem.functions.boundary
        if bc is not None:
            psi = bc.function(X0, XF, T0, TF, Pm) - ca.DM(bc.lower)
            Phi = Phi + ca.dot(nu, psi)
        grads = ca.Function(
            "transversality",
            [X0, XF, T0, TF, Pm, nu],
            [ca.gradient(Phi, X0), ca.gradient(Phi, XF), ca.gradient(Phi, TF), psi],
        )
        g0, gf, gt, psi_v = grads(x0, xf, t0, tf, P, parts["nu"])
        for i, s in enumerate(problem.states):
            rows.append(xf[i] - cast(float, s.fixed_final) if s.final is not None else pf[i] - gf[i])
            if self.free_initial[i]:
                rows.append(parts["p0"][i] + g0[i])
        rows.append(psi_v)
        if self.free_tf:
            y, rhs, flow = self.rhs[-1]
            Hf = ca.Function("H", [*sym_in, flow.w], [ca.substitute(fl.H, fl.u, flow.control)])
            rows.append(Hf(xf, pf, tf, P, yf[2 * nx : 2 * nx + flow.w.numel()]) + gt)
        S = ca.vertcat(*rows)
        if S.numel() < nz:
            raise ValueError(
                f"the arcs {[self.arc_name(k) for k in self.kinds]} give {S.numel()} conditions for {nz} unknowns: "
                "this structure is not one the derived junction conditions close (a junction the theory treats "
                "otherwise); keep the direct solution"
            )
        Phi_val = ca.Function(
            "Phi", [X0, XF, T0, TF, Pm], [problem.phi(X0, XF, T0, TF, Pm) if problem.phi is not None else ca.SX(0)]
        )
        objective = Phi_val(x0, xf, t0, tf, P) + sum(costs)
        self.S = ca.Function("S", [z, P], [S])
        self.SJ = ca.Function("SJ", [z, P], [S, ca.jacobian(S, z)])
        self.times = ca.Function("times", [z, P], [ca.vertcat(*times)])
        self.objective = ca.Function("objective", [z, P], [objective])

    def _jump_junctions(self) -> dict[int, str]:
        """The junctions where the costate jumps, ``{k: constraint}`` (the junction at the start of arc ``k``): the
        entry into and the exit from a boundary arc of a state constraint of order two, and its touch points. At
        the junctions of order one the costate is continuous (module docstring)."""
        out: dict[int, str] = {}
        for k in range(1, len(self.kinds)):
            a, b = self.kinds[k - 1], self.kinds[k]
            if b.touch is not None:
                q = self.flows.ineq.get(b.touch)
                if q is None or not q.pure or q.order < 2:
                    raise ValueError(
                        f"a touch point of {b.touch!r}: touch points of state constraints of order two or more only"
                    )
                out[k] = b.touch
            elif b.constraint != a.constraint and self._second_order(b.constraint):
                out[k] = cast(str, b.constraint)
            elif a.constraint != b.constraint and self._second_order(a.constraint):
                out[k] = cast(str, a.constraint)
        return out

    def _second_order(self, constraint: str | None) -> bool:
        """Whether ``constraint`` is a state constraint of order two or more."""
        q = self.flows.ineq.get(constraint) if constraint is not None else None
        return q is not None and q.pure and q.order >= 2

    def _cx(self, constraint: str) -> ca.SX:
        """The gradient ``c_x`` of a state constraint, in ``(x, t, P)``: the direction of the costate's jumps."""
        fl = self.flows
        return ca.gradient(fl.ineq[constraint].function(fl.x, fl.u, fl.t, fl.P), fl.x)

    def _entry(self, k: int) -> list[ca.SX]:
        """The conditions at the start of arc ``k`` (a singular or boundary arc; in arc ``k``'s symbols): a singular
        arc's; a mixed constraint's (module docstring); for a state constraint of order ``q`` entered here, the
        tangency ``c = ... = D^(q-1) c = 0`` and the minimum condition ``phi = ... = D^(q-1) phi = 0`` after the
        jump (of order one: the costate continuous, ``phi = 0`` the continuity of a regular control and the
        switching function's zero for an affine one), except from a singular arc, where ``phi = 0`` holds already
        (``c = 0`` only)."""
        flow, kind = self.flows.flow(self.kinds[k]), self.kinds[k]
        continuous = self._continuous_control(k, k - 1) if k > 0 else None
        if continuous is not None:
            return [continuous]
        q = self.flows.ineq.get(kind.constraint) if kind.constraint is not None else None
        if q is None or not q.pure or k == 0:
            return list(flow.entry)
        if self.kinds[k - 1].constraint == kind.constraint:
            return []  # the same boundary arc, another control switching: entered before
        i = cast(int, flow.boundary_control)  # (a boundary arc's)
        if flow.order == 1 and self.kinds[k - 1].kinds[i] == "singular":
            return list(flow.entry)
        return [*flow.tangency, *flow.minimum]

    def _touch(self, k: int) -> list[ca.SX]:
        """The conditions ``c = D c = 0`` at the touch point at the start of arc ``k`` (the constraint reaches its
        bound there and turns back; of any order): they determine the junction's time and the costate's jump."""
        fl = self.flows
        c = fl.ineq[cast(str, self.kinds[k].touch)].function(fl.x, fl.u, fl.t, fl.P)
        return [ca.substitute(r, fl.u, fl.flow(self.kinds[k]).control) for r in (c, fl.D(c))]

    def _continuous_control(self, k: int, neighbour: int) -> ca.SX | None:
        """For the boundary arc ``k`` of a mixed constraint on a control H is affine in, the condition at its junction
        with arc ``neighbour`` (the control continuous there): ``c(x, u of the neighbour) = 0``, in arc ``k``'s
        symbols; None where the multiplier's vanishing is the condition (H regular in the control)."""
        fl, kind = self.flows, self.kinds[k]
        if kind.constraint is None or fl.ineq[kind.constraint].pure:
            return None
        i = cast(int, fl.flow(kind).boundary_control)  # (a boundary arc's)
        if fl.depends(ca.jacobian(fl.H, fl.u[i]), fl.u[i]):
            return None
        other = fl.flow(self.kinds[neighbour])
        if other.w.numel():
            raise ValueError(
                f"the boundary arc of {kind.constraint!r} meets an arc whose control is implicit: not derived"
            )
        c = fl.ineq[kind.constraint].function(fl.x, fl.u, fl.t, fl.P)
        return ca.substitute(c, fl.u, other.control)

    def _leaves_continuously(self, k: int) -> bool:
        """Whether boundary arc ``k``'s multiplier vanishes at its exit: a mixed constraint's (the control is
        continuous there)."""
        return not self.flows.ineq[cast(str, self.kinds[k].constraint)].pure

    @staticmethod
    def arc_name(kind: ArcType) -> str:
        """An arc's name in messages: its controls' kinds, and its active constraint (``"bang/singular (x_max)"``)."""
        k = "/".join(kind.kinds)
        return k if kind.constraint is None else f"{k} ({kind.constraint})"

    def _junction(
        self, k: int, left_end: ca.MX, right_start: ca.MX, w_right: ca.MX, tj: ca.MX, P: ca.MX
    ) -> list[ca.MX]:
        """The conditions at the junction between arcs ``k - 1`` and ``k`` (module docstring)."""
        fl, nx = self.flows, self.nx
        a, b = self.kinds[k - 1], self.kinds[k]
        la, ra = self.rhs[k - 1][2], self.rhs[k][2]
        sym_in = [fl.x, fl.p, fl.t, fl.P]
        xl, pl, wl = left_end[:nx], left_end[nx : 2 * nx], left_end[2 * nx : 2 * nx + la.w.numel()]
        xr, pr = right_start[:nx], right_start[nx:]
        rows = []
        if a.constraint and a.constraint != b.constraint and self._leaves_continuously(k - 1):
            # the multiplier of a mixed constraint vanishes at the arc's exit (the control is continuous there); for
            # a control H is affine in, the constraint holds with the next arc's control
            continuous = self._continuous_control(k - 1, k)
            M = ca.Function("exit", [*sym_in, la.w], [la.mu if continuous is None else continuous])
            rows.append(M(xl, pl, tj, P, wl))
        for i, (ka, kb) in enumerate(zip(a.kinds, b.kinds)):
            if ka == kb or "boundary" in (ka, kb) or (kb == "singular" and ka in BANG):
                continue  # entries of singular and boundary arcs are the arcs' own conditions
            if ka in BANG and kb in BANG:
                # this control's own switching condition, the others held at their values on the arc before (one
                # row per control that switches here, also where several switch together)
                swapped = ca.vertcat(*[ra.control[j] if j == i else la.control[j] for j in range(self.problem.nu)])
                Ha = ca.substitute(fl.H, fl.u, la.control)
                Hb = ca.substitute(fl.H, fl.u, swapped)
                # per unit of the control's jump: the switching function there (H affine in the control), not H's
                # jump, which scales with the bounds (the tumour's dose of 75 made the row 75 times its noise)
                jump = la.control[i] - ra.control[i]
                span = abs(float(ca.evalf(jump))) if jump.is_constant() else 0.0
                F = ca.Function("switch", [*sym_in, la.w], [(Ha - Hb) / span if span > 0 else Ha - Hb])
                rows.append(F(xl, pl, tj, P, wl))
            elif ka == "regular" and kb in BANG:
                F = ca.Function("continuity", [*sym_in, la.w], [la.control[i] - ra.control[i]])
                rows.append(F(xl, pl, tj, P, wl))
            elif ka in BANG and kb == "regular":
                F = ca.Function("continuity", [*sym_in, ra.w], [ra.control[i] - la.control[i]])
                rows.append(F(xr, pr, tj, P, w_right))
            elif ka == "singular" and kb in BANG:
                continue  # leaving a singular arc: no condition
            else:
                raise ValueError(
                    f"a junction from {ka!r} to {kb!r} of control {self.problem.control_names[i]!r} is not derived; "
                    "keep the direct solution"
                )
        return rows

    # -- the initial guess from a trajectory with costates -----------------------------------------------
    def guess(self, trajectory: Trajectory, parameters: Mapping[str, float] | ArrayLike | None = None) -> np.ndarray:
        """The unknowns from a trajectory with costates (a Radau solution): its values at the estimated junctions;
        the boundary multipliers by least squares on the final transversality condition."""
        times = self.estimates.copy()
        if self.free_tf:
            times[-1] = trajectory.tf
        out: list[Any] = []
        X = trajectory.state(times)
        L = trajectory.costate(times)
        # where the costate jumps, the arc starts from its value after the jump, the jump from the two sides
        # (a direct solution's costate smears a jump over a mesh interval or so: read 2% of the horizon away)
        reach = 0.02 * (times[-1] - times[0])
        P = self._P(parameters)
        jumps = {}
        for k, name in self.jumps.items():
            before = trajectory.costate(np.array([max(times[k] - reach, times[k - 1])]))[0]
            after = trajectory.costate(np.array([min(times[k] + reach, times[k + 1])]))[0]
            cx = np.asarray(
                ca.Function("cx", [self.flows.x, self.flows.t, self.flows.P], [self._cx(name)])(X[k], times[k], P)
            ).ravel()
            L[k] = after
            jumps[k] = float(-(after - before) @ cx / max(float(cx @ cx), 1e-300))
        for name, n in self.layout:
            if n == 0:
                continue
            if name == "x0":
                out.append(X[0][np.array(self.free_initial)])
            elif name == "p0":
                out.append(L[0])
            elif name.startswith("t") and name[1:].isdigit():
                out.append([times[int(name[1:])]])
            elif name.startswith("y"):
                k = int(name[1:])
                out.append(np.concatenate([X[k], L[k]]))
            elif name == "tf":
                out.append([times[-1]])
            elif name.startswith("jump"):
                out.append([jumps[int(name[4:])]])
            elif name == "nu":
                out.append(self._multiplier_guess(trajectory, parameters))
            elif name.startswith("w"):
                k = int(name[1:])
                reg = [i for i, kind in enumerate(self.kinds[k].kinds) if kind == "regular"]
                inside = times[k] + 1e-3 * (times[k + 1] - times[k])  # off the junction, where U jumps
                out.append(trajectory.control(np.array([inside]))[0][reg])
        return np.concatenate([np.ravel(v) for v in out]).astype(float)

    def _multiplier_guess(
        self, trajectory: Trajectory, parameters: Mapping[str, float] | ArrayLike | None
    ) -> np.ndarray:
        problem, nx = self.problem, self.nx
        X0, XF, T0, TF = ca.SX.sym("x0", nx), ca.SX.sym("xf", nx), ca.SX.sym("t0"), ca.SX.sym("tf")
        P = self.flows.P
        phi = problem.phi(X0, XF, T0, TF, P) if problem.phi is not None else ca.SX(0)
        boundary = cast("ConstraintSet", problem.functions.boundary)  # (the multipliers of its equalities)
        psi = boundary.function(X0, XF, T0, TF, P)
        F = ca.Function("g", [X0, XF, T0, TF, P], [ca.gradient(phi, XF), ca.jacobian(psi, XF)])
        x = trajectory.state(np.array([trajectory.t0, trajectory.tf]))
        pf = trajectory.costate(np.array([trajectory.tf]))[0]
        g, A = (np.asarray(v) for v in F(x[0], x[1], trajectory.t0, trajectory.tf, self._P(parameters)))
        free = [i for i, s in enumerate(problem.states) if s.final is None]
        return np.linalg.lstsq(A.T[free], pf[free] - g.ravel()[free], rcond=None)[0]

    def _P(self, parameters: Mapping[str, float] | ArrayLike | None = None) -> np.ndarray:
        """The parameter vector: the problem's, a full vector, or a mapping of some names to values."""
        if parameters is None:
            return np.asarray(self.problem.full_parameters, dtype=float).ravel()
        if isinstance(parameters, Mapping):
            return np.asarray(self.problem.replace(parameters=dict(parameters)).full_parameters, dtype=float).ravel()
        return np.asarray(parameters, dtype=float).ravel()

    # -- solve --------------------------------------------------------------------------------------------
    def solve(
        self,
        z0: ArrayLike,
        parameters: Mapping[str, float] | ArrayLike | None = None,
        *,
        tol: float = 1e-10,
        max_iterations: int = 50,
        raise_on_failure: bool = True,
    ) -> ArcResult:
        """Newton's method on ``S(z) = 0`` from ``z0`` with the exact Jacobian (least-squares steps, Gauss-Newton
        where the conditions outnumber the unknowns, as when a singular arc reaching tf makes a transversality
        condition hold already; halved until ``|S|`` decreases); stops at ``|S| <= tol`` once a step no longer gains
        a factor ten, or at the integrator's noise. A failure raises a :class:`~ocpkit.SolverError` naming it and its
        :class:`~ocpkit.Outcome`, the last iterate's result attached (``raise_on_failure=False``: returns it, with
        ``converged=False`` and its ``status``)."""
        if self.phase:
            raise ValueError(
                f"{self.problem.name!r} is shot as a phase of a multi-phase problem, whose conditions at its ends are "
                "the trajectory's: solve the PhasedArcShooting of its phases"
            )
        P = self._P(parameters)
        z = np.asarray(z0, dtype=float).copy()
        if z.size != self.nz:
            raise ValueError(f"z0 must have {self.nz} entries (layout {self.layout})")
        start = time.process_time()

        def ordered(z: np.ndarray) -> bool:
            return bool(np.all(np.diff(np.asarray(self.times(z, P)).ravel()) > 0))

        run = newton(lambda z: self.S(z, P), lambda z: self.SJ(z, P), ordered, z, tol, max_iterations)
        z, norm = run.z, run.norm
        times = np.asarray(self.times(z, P)).ravel()
        try:
            objective = np.asarray(self.objective(z, P)).ravel()
        except RuntimeError:  # the arcs cannot be integrated from the last iterate
            objective = np.array([np.nan])
        result = ArcResult(
            **run.fields(tol, time.process_time() - start),
            objective=float(objective[0]),
            times=times,
            multipliers=self._part(z, "nu"),
            arcs=list(self.kinds),
            jumps=[(float(times[k]), name, float(self._part(z, f"jump{k}")[0])) for k, name in self.jumps.items()],
        )
        if np.all(np.diff(times) > 0) and np.isfinite(norm) and np.isfinite(result.objective):
            problem = self.problem
            if parameters is not None:  # the trajectory's problem has the parameter values it was solved at
                problem = problem.replace(parameters=dict(zip(problem.parameters, P[: len(problem.parameters)])))
            result._trajectory = ArcTrajectory(self, z, P, times, result.objective, problem=problem)
        if raise_on_failure:
            run.raise_unless_converged("arc shooting", result, tol)
        return result

    def _part(self, z: np.ndarray, name: str) -> np.ndarray:
        return block(self.layout, z, name)


def block(layout: Sequence[tuple[str, int]], z: np.ndarray, name: str) -> np.ndarray:
    """The block ``name`` of the unknowns ``z`` laid out as ``layout`` (``[(name, size), ...]``, in order)."""
    offset = 0
    for label, n in layout:
        if label == name:
            return np.asarray(z[offset : offset + n])
        offset += n
    raise KeyError(f"no block {name!r} in the layout {[label for label, _ in layout]}")


@dataclass(frozen=True)
class NewtonRun:
    """How :func:`newton` ended: the last iterate ``z``, ``S`` and its ``norm`` there, whether it ``converged``, its
    ``status`` (:func:`~ocpkit.shooting.result.settled`), the solver's words (``detail``), the Jacobian and residual
    evaluations, and where it stalled, the noise floor of S measured there and the advice it gives."""

    z: np.ndarray
    S: np.ndarray
    norm: float
    converged: bool
    status: Outcome
    detail: str
    iterations: int
    evaluations: int
    noise: float | None = None
    advice: str = ""

    def fields(self, tol: float, cpu_s: float) -> dict[str, Any]:
        """The fields of every indirect result (:class:`~ocpkit.shooting.result.IndirectResult`) this run gives, with
        the ``tol`` it was asked for and its process time ``cpu_s`` (the objective is the caller's)."""
        return {
            "z": self.z,
            "residual": self.S,
            "norm": self.norm,
            "tol": tol,
            "converged": self.converged,
            "status": self.status,
            "detail": self.detail,
            "iterations": self.iterations,
            "evaluations": self.evaluations,
            "cpu_s": cpu_s,
            "noise": self.noise,
        }

    def raise_unless_converged(self, engine: str, result: IndirectResult, tol: float) -> None:
        """The :class:`~ocpkit.SolverError` of a run that did not converge, ``result`` attached (``engine`` names
        the shooting in its message)."""
        if not self.converged:
            raise SolverError(
                engine,
                self.detail,
                self.iterations,
                f"|S| = {self.norm:.3e} > {tol:g}" + (f"; {self.advice}" if self.advice else ""),
                unit="Newton iterations",
                result=result,
                outcome=self.status,
            )


def newton(
    evaluate: Callable[[np.ndarray], Any],
    jacobian: Callable[[np.ndarray], tuple[Any, Any]],
    ordered: Callable[[np.ndarray], bool],
    z: np.ndarray,
    tol: float,
    max_iterations: int,
) -> NewtonRun:
    """Newton's method on ``S(z) = 0`` (:meth:`ArcShooting.solve`): least-squares steps with the exact Jacobian
    (``jacobian(z)`` gives ``(S, dS/dz)``), halved until ``|S|`` decreases and the arcs' times stay ``ordered``; an
    iterate ``evaluate`` cannot integrate (CVODES fails) counts as an infinite ``|S|``. Where it stalls, the noise
    floor of S is measured and said (:func:`~ocpkit.shooting.result.noise_floor`)."""
    size = z.size

    def residual(z: np.ndarray) -> np.ndarray:
        try:
            return np.asarray(evaluate(z)).ravel()
        except RuntimeError:  # CVODES failed on this iterate
            return np.full(size, np.inf)

    n_S = n_J = 0
    message, claimed = "maximum number of iterations", Outcome.MAX_ITERATIONS
    S = residual(z)
    n_S += 1
    norms: list[float] = []
    for _ in range(max_iterations):
        norm = float(np.linalg.norm(S))
        norms.append(norm)
        if len(norms) > 6 and norm > 0.5 * norms[-7]:
            message = "stalled: |S| not halved in six Newton iterations (far from a solution, or another structure)"
            claimed = Outcome.STALLED
            break
        if not np.isfinite(norm):
            message, claimed = "the arcs' integration failed at the starting point", Outcome.INTEGRATION_FAILED
            break
        try:
            Sv, J = jacobian(z)
        except RuntimeError:
            message = "the arcs' sensitivities could not be integrated at this iterate"
            claimed = Outcome.INTEGRATION_FAILED
            break
        n_J += 1
        step = np.linalg.lstsq(np.asarray(J), -np.asarray(Sv).ravel(), rcond=None)[0]
        a = 1.0
        while a >= 2.0**-12:
            trial = z + a * step
            if ordered(trial):
                St = residual(trial)
                n_S += 1
                if np.linalg.norm(St) < (1 - 1e-4 * a) * norm or (norm <= tol and np.linalg.norm(St) <= norm):
                    break
            a *= 0.5
        else:
            message = "no step decreases |S| (the integrator's noise, or far from a solution)"
            claimed = Outcome.STALLED
            break
        gain = np.linalg.norm(St) / max(norm, 1e-300)
        z, S = trial, St
        if np.linalg.norm(S) <= tol and gain > 0.1 or np.linalg.norm(S) <= 1e-15:
            message, claimed = "converged", Outcome.CONVERGED
            break
    norm = float(np.linalg.norm(S))
    if norm <= tol:
        message = "converged"
    converged, status = settled(norm, tol, claimed)
    noise, advice = None, ""
    if status is Outcome.STALLED and np.isfinite(norm):  # the integrator's noise, or not: measured, and said
        noise = noise_floor(residual, z)
        advice = stall_advice(norm, tol, noise)
    return NewtonRun(z, S, norm, converged, status, message, n_J, n_S, noise, advice)


class ArcTrajectory(Trajectory):
    """The extremal of an :class:`ArcShooting` run as functions of time: each arc integrated again on a dense grid
    (CVODES, the shooting's tolerances), cubic Hermite between grid points with the arc's flow as derivative; the
    control the arc's derived control (bang value, singular feedback, boundary control, ``H_u = 0``)."""

    def __init__(
        self,
        shooting: ArcShooting,
        z: np.ndarray,
        P: np.ndarray,
        times: np.ndarray,
        objective: float,
        per_arc: int = 1000,
        problem: OptimalControlProblem | None = None,
    ) -> None:
        self.problem = shooting.problem if problem is None else problem
        self.shooting = shooting
        self.objective = float(objective)
        self.t0, self.tf = float(times[0]), float(times[-1])
        self.breakpoints = np.asarray(times, dtype=float)
        nx = shooting.nx
        self._n = nx
        self._pieces: list[tuple[np.ndarray, np.ndarray, np.ndarray, ca.Function]] = []
        K = len(shooting.kinds)
        starts = [np.concatenate([self._x0(shooting, z), shooting._part(z, "p0")])] + [
            shooting._part(z, f"y{k}") for k in range(1, K)
        ]
        fl = shooting.flows
        self.mu: list[Any] = []
        #: the costate's jumps, ``(time, constraint, nu)`` (:attr:`ArcResult.jumps`)
        self.jumps = [
            (float(times[k]), name, float(shooting._part(z, f"jump{k}")[0])) for k, name in shooting.jumps.items()
        ]
        for k in range(K):
            y, rhs, flow = shooting.rhs[k]
            w = shooting._part(z, f"w{k}")
            grid = np.linspace(0.0, 1.0, per_arc + 1)
            F = shooting.integrator("dense", y, rhs, grid[1:])
            a, b = times[k], times[k + 1]
            y0 = np.concatenate([starts[k], w, [0.0]])
            Y = np.vstack([y0, np.asarray(F(x0=y0, p=np.concatenate([[a, b - a], P]))["xf"]).T])
            t = a + grid * (b - a)
            f = ca.Function("f", [y, fl.t, fl.P], [rhs]).map(t.size)
            D = np.asarray(f(Y.T, t[None, :], np.repeat(P[:, None], t.size, axis=1))).T
            u = ca.Function("u", [fl.x, fl.p, fl.t, fl.P, flow.w], [flow.control, flow.mu])
            self._pieces.append((t, Y, D, u))
        self.full_parameters = P

    @staticmethod
    def _x0(shooting: ArcShooting, z: np.ndarray) -> np.ndarray:
        free = iter(shooting._part(z, "x0"))
        return np.array([next(free) if f else shooting.x0[i] for i, f in enumerate(shooting.free_initial)])

    def _eval(self, t: ArrayLike) -> tuple[tuple[int, ...], np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        flat = t.ravel()
        arc = np.clip(np.searchsorted(self.breakpoints, flat, side="right") - 1, 0, len(self._pieces) - 1)
        out = np.empty((flat.size, self._pieces[0][1].shape[1]))
        for k in unique(arc):
            sel = np.flatnonzero(arc == k)
            tk, Y, D, _ = self._pieces[k]
            i = np.clip(np.searchsorted(tk, flat[sel], side="right") - 1, 0, tk.size - 2)
            h = (tk[i + 1] - tk[i])[:, None]
            out[sel] = cubic_hermite(Y[i], D[i], Y[i + 1], D[i + 1], h, (flat[sel] - tk[i])[:, None] / h)
        return t.shape, flat, arc, out

    def _state(self, t: np.ndarray) -> np.ndarray:
        shape, _, _, y = self._eval(t)
        return y[:, : self._n].reshape(shape + (self._n,))

    @property
    def has_costates(self) -> bool:
        return True

    def _costate(self, t: ArrayLike) -> np.ndarray:
        shape, _, _, y = self._eval(t)
        return y[:, self._n : 2 * self._n].reshape(shape + (self._n,))

    def _control_and_mu(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        shape, flat, arc, y = self._eval(t)
        nu = self.problem.nu
        U, M = np.empty((flat.size, nu)), np.empty(flat.size)
        n = self._n
        for k in unique(arc):
            sel = np.flatnonzero(arc == k)
            f = self._pieces[k][3]
            w = y[sel, 2 * n : -1]
            u, mu = f.map(sel.size)(
                y[sel, :n].T,
                y[sel, n : 2 * n].T,
                flat[sel][None, :],
                np.repeat(self.full_parameters[:, None], sel.size, axis=1),
                w.T,
            )
            U[sel] = np.asarray(u).T
            M[sel] = np.asarray(mu).ravel()
        return U.reshape(shape + (nu,)), M.reshape(shape)

    def _control(self, t: np.ndarray) -> np.ndarray:
        return self._control_and_mu(t)[0]

    def multiplier(self, t: ArrayLike) -> np.ndarray:
        """The multiplier ``mu`` of the active inequality at times ``t`` (0 off boundary arcs)."""
        return self._control_and_mu(self._check_times(t))[1]


__all__ = [
    "ArcFlows",
    "ArcResult",
    "ArcShooting",
    "ArcTrajectory",
    "ArcType",
    "NewtonRun",
    "arc_sequence",
    "block",
    "newton",
]
