"""The certificate of an extremal of the maximum principle: :func:`certify` checks it, by name, and gives a
:class:`Certificate` (its :class:`Check` items and its second-order verdict, :mod:`ocpkit.second_order`).

A certificate is what :func:`ocpkit.indirect.to_extremal` attaches to every extremal it returns: the conditions of
the maximum principle checked on the extremal's own trajectory (the shooting residual, H minimal over the admissible
set, feasibility, H constant, the singular and boundary arcs' conditions, the jumps' signs), and, where a direct
solution is given, the comparisons with it (the structure, the objective and the states).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from .second_order import SecondOrder, second_order
from .structure import Structure, control_structure

if TYPE_CHECKING:
    from .shooting.result import IndirectResult
    from .solution import PhaseSolution, Solution
    from .trajectory import Trajectory


@dataclass(frozen=True)
class Check:
    """One check of a certificate: ``value`` against ``tolerance`` (passed when ``value <= tolerance``)."""

    name: str
    value: float
    tolerance: float
    meaning: str

    @property
    def passed(self) -> bool:
        return bool(self.value <= self.tolerance)


@dataclass(frozen=True)
class Certificate:
    """The checks of an extremal (:func:`certify`), by name, and its second-order verdict (``second_order``:
    :class:`~ocpkit.second_order.SecondOrder`; where it applies, it is also the check ``second_order``)."""

    checks: tuple[Check, ...]
    second_order: SecondOrder | None = None

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def failed(self) -> list[str]:
        return [c.name for c in self.checks if not c.passed]

    def __getitem__(self, name: str) -> Check:
        for c in self.checks:
            if c.name == name:
                return c
        raise KeyError(f"no check {name!r}; the checks are {[c.name for c in self.checks]}")

    def describe(self) -> str:
        lines = [
            f"{'ok  ' if c.passed else 'FAIL'} {c.name}: {c.value:.2e} (at most {c.tolerance:.0e}; {c.meaning})"
            for c in self.checks
        ]
        if self.second_order is not None and not self.second_order.applicable:
            lines.append(f"n/a  second_order: {self.second_order.detail}")
        return "\n".join(lines)


def certify(
    trajectory: Trajectory,
    result: IndirectResult,
    direct: Solution | PhaseSolution | None = None,
    structure: Structure | None = None,
    tol: float = 1e-10,
    samples: int = 401,
    first: Solution | None = None,
    terminal: Mapping[str, float] | None = None,
    min_share: float = 0.01,
    second: bool = True,
) -> Certificate:
    """The checks of an extremal (every one named; :class:`Certificate`; ``min_share``: the shortest arc the
    structure is read with, as ``structure`` was):

    * ``shooting_residual``: ``|S|`` at the solution, at most ``tol``;
    * ``hamiltonian_minimum``: on ``samples`` times, how much lower H gets than at the extremal's control over a
      sampled admissible set (41 values per control, the others held at the extremal's, and the box's corners up to
      six controls; a value that violates a mixed state-control constraint is not admissible; for a law over the
      ball ``|u| <= r``, 801 points of the ball instead, and the extremal's control turned by +-1e-3 rad towards
      each axis), relative to ``1 + |L(v) - L(u)| + sum |p_i (f_i(v) - f_i(u))|`` (the magnitude of the terms of H a
      change of the control changes, which the difference's rounding is relative to; H itself may be 0, with a free
      final time, while its terms are 1e4): the maximum principle, checked on the set rather than on the law that
      produced the control;
    * ``feasibility``: the largest violation of a state bound or a path constraint on the samples, relative to the
      range of its values along the extremal (at least 1), of a control's bounds (relative to their span, at least
      1), and for the ball, of ``|u| <= r`` relative to r;
    * ``hamiltonian_constant``: the largest change of H along the extremal relative to 1 + the largest magnitude of
      its terms ``|L| + sum |p_i f_i|``, at most 1e-8 (autonomous problems only);
    * ``legendre_clebsch``: on singular arcs of order q, how negative ``(-1)^q d/du (d/dt)^(2q) H_u`` gets
      (relative to its largest magnitude), the generalised Legendre-Clebsch (Kelley) condition; with
      ``multiplier_sign``: on boundary arcs, how negative the inequality's multiplier gets (relative to its largest
      magnitude); both 0 where there are no such arcs;
    * ``structure``: 0 when the extremal has the direct solution's arcs (kinds in order, for each control), else 1;
    * ``objective_gap``: ``|J_indirect - J_direct| / (1 + |J|)``, at most 1e-2, and ``state_gap``: the largest
      difference of the direct solution's states in percent of each one's magnitude, in normalised time, at most
      5 %: another extremal than the one the direct solution approximates, not its discretisation error (a
      switch inside a mesh interval costs a coarse mesh about 2 %), is what these two catch. A state's magnitude
      counts as at least its ``scale`` (default 1), the unit the direct NLP measures it in and the direct
      solution's accuracy with it: a state near zero, such as a small eccentricity component, is not compared with
      its own tiny values. Without ``structure`` and ``direct`` (a continuation's extremals), those three checks
      are left out;
    * ``first_direct_objective`` (where :func:`~ocpkit.indirect.to_extremal` re-solved the direct problem from the extremal,
      ``first`` the direct solution it started from): how much worse the extremal's objective is than the first
      direct solution's, relative to ``1 + |J|``, at most 1e-2 (an extremal the direct method, started from it,
      confirms, but of a worse local minimum than the one it was asked about, fails here);
    * ``terminal_multiplier_sign`` (where :func:`~ocpkit.indirect.to_extremal` read a state constraint only the final state can
      reach as its terminal condition, :mod:`ocpkit.monotone`; ``terminal`` maps each such equality's name to its
      multiplier): how negative the multiplier of ``c(x(tf)) <= 0`` gets, relative to ``1 + |nu|`` (a negative
      one would gain from spending less than the budget: not an extremal of the inequality);
    * ``second_order`` where it applies (:func:`ocpkit.second_order.second_order`; ``second=False`` leaves it out, for
      a phase of a multi-phase extremal, whose verdict is the whole trajectory's).
    """
    from .structure import inequalities

    problem = trajectory.problem
    ham = problem.functions.hamiltonian
    Hf = ca.Function("H", [ham.x, ham.p, ham.u, ham.t, ham.P], [ham.H])
    t = np.linspace(trajectory.t0, trajectory.tf, samples)
    X, L, U = trajectory.state(t), trajectory.costate(t), trajectory.control(t)
    P = np.asarray(problem.full_parameters, dtype=float).ravel()
    Hmap = Hf.map(samples)
    Ps = np.repeat(P[:, None], samples, axis=1)
    H_star = np.asarray(Hmap(X.T, L.T, U.T, t[None, :], Ps)).ravel()
    # the magnitude of H's terms, |L| + sum |p_i f_i|: what its rounding is relative to (H itself may be 0, as with
    # a free final time, while its terms are 1e4: the tumour's); for the minimum, only the terms a control changes
    terms = ca.Function(
        "terms", [ham.x, ham.p, ham.u, ham.t, ham.P], [ca.fabs(ham.L) + ca.sum1(ca.fabs(ham.p * ham.f))]
    )
    scale = 1.0 + np.asarray(terms.map(samples)(X.T, L.T, U.T, t[None, :], Ps)).ravel()
    v = ca.SX.sym("v", problem.nu)
    at_v = [ca.substitute(e, ham.u, v) for e in (ham.H, ham.L, ham.p * ham.f)]
    changed = 1.0 + ca.fabs(at_v[1] - ham.L) + ca.sum1(ca.fabs(at_v[2] - ham.p * ham.f))
    against = ca.Function("against", [ham.x, ham.p, ham.u, v, ham.t, ham.P], [at_v[0], changed]).map(samples)

    # how much lower H is at the candidate controls V (columns), relative to what they change
    def lower_by(V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        H_v, denominator = (np.asarray(a).ravel() for a in against(X.T, L.T, U.T, V, t[None, :], Ps))
        return H_v, (H_star - H_v) / denominator

    every = [(q, q.function.map(samples)) for q in inequalities(problem)]
    mixed = [c for q, c in every if not q.pure]
    violation = 0.0
    for i, c in enumerate(problem.controls):  # the controls' own bounds
        span = max(1.0, float(c.upper - c.lower)) if np.isfinite(c.upper - c.lower) else 1.0
        over = np.maximum(U[:, i] - c.upper, c.lower - U[:, i])
        violation = max(violation, float(np.max(over)) / span)
    for _, mapped in every:
        values = np.asarray(mapped(X.T, U.T, t[None, :], Ps)).ravel()
        violation = max(violation, float(np.max(values)) / max(1.0, float(np.ptp(values))))
    worst = 0.0
    law = getattr(getattr(trajectory, "system", None), "law", None)
    radius = getattr(law, "radius", None) if getattr(law, "control_set", None) == "ball" else None
    if radius is not None:  # |u| <= radius: the ball sampled, and its feasibility
        norms = np.linalg.norm(U, axis=1)
        violation = max(violation, float(np.max(norms - radius)) / radius)
        candidates = [np.repeat(V[:, None], samples, axis=1) for V in _ball_points(problem.nu, radius)]
        candidates += _rotations(U, radius)  # and the extremal's own control turned slightly: a first-order test
        for V in candidates:
            worst = max(worst, float(np.max(lower_by(V)[1])))
    # the admissible set sampled control by control (41 values each, the others at the extremal's), and its corners
    # for up to 6 controls: H evaluations linear in the controls, not a grid exponential in them
    lows: list[float] = []
    highs: list[float] = []
    for i, c in enumerate(problem.controls):
        lo, hi = c.lower, c.upper
        if not (np.isfinite(lo) and np.isfinite(hi)):
            span = max(1.0, float(np.ptp(U[:, i])))
            lo, hi = float(U[:, i].min()) - span, float(U[:, i].max()) + span
        lows.append(lo)
        highs.append(hi)
    trials: list[Any] = [(i, value) for i in range(problem.nu) for value in np.linspace(lows[i], highs[i], 41)]
    corners: list[Any] = []
    if radius is not None:  # the box around the ball is not admissible
        trials = []
    elif 1 < problem.nu <= 6:
        corners = list(np.array(np.meshgrid(*zip(lows, highs), indexing="ij")).reshape(problem.nu, -1).T)
    for k, trial in enumerate(trials + corners):
        V = U.T.copy()
        if k < len(trials):
            V[trial[0], :] = trial[1]
        else:
            V[:, :] = np.asarray(trial)[:, None]
        _, lower = lower_by(V)
        for g in mixed:
            lower[np.asarray(g(X.T, V, t[None, :], Ps)).ravel() > 1e-9] = -np.inf  # not admissible
        worst = max(worst, float(np.max(lower)))
    ineq = [q.function(ham.x, ham.u, ham.t, ham.P) for q in inequalities(problem)]
    autonomous = not ca.depends_on(ca.vertcat(ham.f, ham.L, *ineq), ham.t)
    drift = float(np.max(np.abs(H_star - H_star[0])) / np.max(scale))
    kelley, sign = _arc_conditions(trajectory, t, X, L, P)
    compared: list[Check] = []
    # an arc-shooting extremal's own arcs are exact (ocpkit.second_order reads them): detected again only to
    # compare with the direct solution's
    exact = isinstance(getattr(getattr(trajectory, "shooting", None), "kinds", None), list)
    found = control_structure(trajectory, min_share=min_share) if structure is not None or not exact else Structure(())
    if structure is not None:

        def arcs(s: Structure, name: str) -> list[tuple[str, str | None]]:
            return [(a.kind, a.constraint) for a in s.arcs if a.control == name]

        same = all(arcs(found, n) == arcs(structure, n) for n in dict.fromkeys(a.control for a in structure.arcs))
        same = same and [p.constraint for p in found.touches] == [p.constraint for p in structure.touches]
        compared.append(
            Check("structure", 0.0 if same else 1.0, 0.0, "the direct solution's arcs and touch points, in order")
        )
    if direct is not None:
        J = float(result.objective)
        s = np.linspace(0.0, 1.0, 2001)
        names = direct.problem.state_names  # the shooting's problem may have more (free parameters as states)
        ours = trajectory.state(trajectory.t0 + s * (trajectory.tf - trajectory.t0))[:, : len(names)]
        theirs = direct.state(direct.t0 + s * (direct.tf - direct.t0))
        # the unit the direct NLP measures a state in (its scale, default 1): the direct solution is no more
        # accurate than that unit allows, so a state's magnitude counts as at least its scale
        scales = np.array([abs(v.scale) for v in direct.problem.states])
        ranges = np.maximum(np.maximum(np.abs(theirs).max(axis=0), scales), 1e-300)
        state_gap = float(100 * np.max(np.abs(ours - theirs).max(axis=0) / ranges))
        gap = abs(J - float(direct.objective)) / (1.0 + abs(J))
        compared.append(Check("objective_gap", gap, 1e-2, "indirect against direct"))
        compared.append(Check("state_gap", state_gap, 5.0, "largest state difference, % of its range"))
    if terminal:
        worst_nu = max(max(0.0, -float(nu)) / (1.0 + abs(float(nu))) for nu in terminal.values())
        compared.append(
            Check("terminal_multiplier_sign", worst_nu, 1e-8, "the budget's terminal multiplier is nonnegative")
        )
    if first is not None:
        worse = (float(result.objective) - float(first.objective)) / (1.0 + abs(float(result.objective)))
        compared.append(
            Check("first_direct_objective", max(worse, 0.0), 1e-2, "no worse than the first direct solution")
        )
    verdict = second_order(trajectory, found, getattr(result, "multipliers", None)) if second else None
    if verdict is not None and verdict.applicable:
        compared.append(Check("second_order", 0.0 if verdict.passed else 1.0, 0.0, str(verdict)))
    checks = (
        Check("shooting_residual", float(result.norm), tol, "|S| at the solution"),
        Check("hamiltonian_minimum", max(worst, 0.0), 1e-8, "H above its minimum over the admissible set"),
        Check("feasibility", max(violation, 0.0), 1e-8, "largest violation of the state bounds and path constraints"),
        *((Check("hamiltonian_constant", drift, 1e-8, "change of H along the extremal"),) if autonomous else ()),
        Check("legendre_clebsch", kelley, 1e-8, "generalised Legendre-Clebsch condition on singular arcs"),
        Check(
            "multiplier_sign", sign, 1e-8, "the inequality's multiplier on boundary arcs and the jumps are nonnegative"
        ),
        *compared,
    )
    return Certificate(checks, verdict)


def _ball_points(n: int, radius: float, directions: int = 200) -> np.ndarray:
    """Points of the ball ``|u| <= radius`` in ``R^n``: the centre, and on each of ``directions`` directions (the
    coordinate axes both ways, then a fixed pseudo-random sample of the sphere) the radii 1/4, 1/2, 3/4, 1."""
    axes = np.vstack([np.eye(n), -np.eye(n)])
    others = np.random.default_rng(0).normal(size=(max(directions - 2 * n, 0), n))
    unit = np.vstack([axes, others / np.linalg.norm(others, axis=1, keepdims=True)])
    return np.vstack([np.zeros((1, n)), *(r * radius * unit for r in (0.25, 0.5, 0.75, 1.0))])


def _rotations(U: np.ndarray, radius: float, angle: float = 1e-3) -> list[np.ndarray]:
    """The controls ``U`` (rows: samples) on the sphere ``|u| = radius`` turned by +-``angle`` towards each axis
    (projected on the sphere's tangent plane), as columns for the H map; zero controls stay. A thrust direction off
    the minimiser by ``theta`` lowers H to first order under one of these turns, which the ball's fixed sample
    points (about 0.3 rad apart) would miss."""
    n = U.shape[1]
    norms = np.linalg.norm(U, axis=1)
    on = norms > 0.5 * radius
    unit = np.where(on[:, None], U / np.maximum(norms, 1e-300)[:, None], 0.0)
    out = []
    for k in range(n):
        e = np.zeros(n)
        e[k] = 1.0
        tangent = e[None, :] - (unit @ e)[:, None] * unit
        size = np.linalg.norm(tangent, axis=1)
        tangent = np.where((size > 1e-8)[:, None], tangent / np.maximum(size, 1e-300)[:, None], 0.0)
        for sign in (1.0, -1.0):
            turned = np.cos(angle) * U + sign * np.sin(angle) * norms[:, None] * tangent
            out.append(np.where(on[:, None], turned, U).T)
    return out


def _arc_conditions(
    trajectory: Trajectory, t: np.ndarray, X: np.ndarray, L: np.ndarray, P: np.ndarray
) -> tuple[float, float]:
    """The Legendre-Clebsch violation on singular arcs and the multiplier's sign violation on boundary arcs of an
    arc-shooting extremal (0 for another trajectory, which has no such arcs)."""
    from .shooting.arcs import ArcTrajectory

    if not isinstance(trajectory, ArcTrajectory):
        return 0.0, 0.0
    flows = trajectory.shooting.flows
    fl_in = [flows.x, flows.p, flows.t, flows.P]
    kelley = sign = 0.0
    for k, kind in enumerate(trajectory.shooting.kinds):
        a, b = trajectory.breakpoints[k], trajectory.breakpoints[k + 1]
        inside = (t > a) & (t < b)
        if not inside.any():
            continue
        flow = flows.flow(kind)
        Ps = np.repeat(P[:, None], inside.sum(), axis=1)
        for _, q, coefficient in flow.singular:
            f = ca.Function("lc", fl_in, [coefficient]).map(int(inside.sum()))
            v = (-1) ** q * np.asarray(f(X[inside].T, L[inside].T, t[inside][None, :], Ps)).ravel()
            kelley = max(kelley, float(np.max(-v) / max(np.abs(v).max(), 1e-300)))
        if kind.constraint is not None:
            mu = trajectory.multiplier(t[inside])
            sign = max(sign, float(np.max(-mu) / max(np.abs(mu).max(), 1e-300)))
    for _, _, nu in trajectory.jumps:  # p(t+) = p(t-) - nu c_x: nu >= 0 at a state constraint's junction
        sign = max(sign, -nu / (1.0 + abs(nu)))
    return max(kelley, 0.0), max(sign, 0.0)


__all__ = ["Certificate", "Check", "certify"]
