"""How accurate a solution is: the relative discretisation error of its states on each mesh interval.

The estimate of Patterson, Hager & Rao ("A ph mesh refinement method for optimal control",
Optimal Control Applications and Methods 36, 2015, Sec. 3): on each interval ``[t_a, t_b]``
between breakpoints, take ``M`` Legendre-Gauss-Radau points ``tau_1 = -1 < ... < tau_M`` and
``tau_{M+1} = +1``, sample the solution's state ``X`` and control ``U`` there, and integrate the
dynamics along them with the ``M``-point interpolatory quadrature:

    Xhat_j = X(t_a) + (t_b - t_a) / 2 * sum_l A_jl f(X_l, U_l, t_l),     j = 2 .. M + 1,

``A`` the integration matrix of the Lagrange basis (:func:`ocpkit.nodes.integration_matrix`). The
relative error of state ``i`` at point ``j`` is ``|Xhat_ij - X_ij| / (1 + max_l |X_il|)``, and the
interval's error the largest over states and points. With ``M`` at least one more than the
degree of the scheme's state polynomial (Patterson et al. use ``N + 1`` for ``N`` LGR points;
HLGL's states are quintic), an interpolant that satisfies the dynamics exactly on a problem the
quadrature integrates exactly gives an estimate at rounding level. The control is the solution's
admissible one (within the bounds), as :meth:`~ocpkit.Trajectory.reintegrate` flies it.
This is the same estimate for every scheme (HLGL's quintic segments, multi-rate coarse segments,
Radau intervals), so their accuracy compares directly.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, cast

import numpy as np

from ._arrays import unique
from .nodes import lgr_estimate_points

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from .solution import PhaseSolution, Solution
    from .statement import ConstraintSet, OptimalControlProblem
    from .trajectory import Trajectory

#: Estimate points per interval when a scheme does not say (above the degree of HLGL's quintic states)
DEFAULT_ESTIMATE_POINTS = 8


class AccuracyWarning(UserWarning):
    """A solve succeeded but its estimated discretisation error exceeds the threshold asked for."""


def interval_errors(
    trajectory: Trajectory, points: ArrayLike | None = None, breakpoints: ArrayLike | None = None
) -> np.ndarray:
    """The relative state error estimate on each interval between ``breakpoints`` (module docstring).

    ``points``: LGR points per interval (an int, or one per interval); default
    :data:`DEFAULT_ESTIMATE_POINTS`. ``breakpoints``: default ``trajectory.breakpoints``.
    """
    bp = np.asarray(trajectory.breakpoints if breakpoints is None else breakpoints, dtype=float)
    K = bp.size - 1
    M = np.full(K, DEFAULT_ESTIMATE_POINTS if points is None else 0, dtype=np.int64)
    if points is not None:
        M[:] = np.broadcast_to(np.asarray(points, dtype=np.int64), (K,))
    if np.any(M < 2):
        raise ValueError(f"the error estimate needs at least 2 points per interval, got {M.min()}")
    problem = trajectory.problem
    P = problem.parameter_vector() if problem.parameters else np.zeros(0)
    out = np.empty(K)
    for m in unique(M):
        ks = np.flatnonzero(M == m)
        tau, A = lgr_estimate_points(int(m))
        a, b = bp[ks], bp[ks + 1]
        t = a[:, None] + (b - a)[:, None] * (np.append(tau, 1.0)[None, :] + 1.0) / 2.0  # (k, m + 1)
        X = trajectory.state(t)  # (k, m + 1, nx)
        U = trajectory.control(t[:, :m])
        n = ks.size * int(m)
        F = np.asarray(problem.f.map(n)(X[:, :m].reshape(n, -1).T, U.reshape(n, -1).T, t[:, :m].reshape(1, n), P)).T
        F = F.reshape(ks.size, int(m), -1)
        Xhat = X[:, :1] + ((b - a) / 2.0)[:, None, None] * np.einsum("jl,kli->kji", A, F)
        denom = 1.0 + np.abs(X).max(axis=1, keepdims=True)
        out[ks] = (np.abs(Xhat - X) / denom).max(axis=(1, 2))
    return out


#: Samples per interval, and the distance to a bound (a fraction of the bounds' range) that counts as on it
SWITCH_SAMPLES, SWITCH_BAND = 64, 1e-3


def control_switches(
    trajectory: Trajectory,
    breakpoints: ArrayLike | None = None,
    samples: int = SWITCH_SAMPLES,
    band: float = SWITCH_BAND,
) -> list[np.ndarray]:
    """Where a bounded control switches inside each interval: cuts (fractions in (0, 1)) around it, or none.

    A bang-bang switch or the junction of a bound arc with an interior (singular, or
    smooth) arc is a jump or a corner of the control, which no polynomial degree on the
    interval resolves: the refinement cuts there instead (in the spirit of the
    nonsmoothness detection of Liu, Hager & Rao, J. Franklin Inst. 352, 2015). On each
    interval the admissible control is sampled at ``samples`` midpoints; each bounded
    control is on its lower bound, on its upper bound, or between them (within ``band``
    times the range, or of a one-sided bound's scale). Where that status changes, a
    polynomial smears a jump across the interval, with overshoot near its ends, so a jump is
    placed where the control that switches (the one moving most, if several) crosses the
    middle of its range on the interval, at its steepest such crossing. From one bound to the
    other that is all; between a bound and the interior the control may instead meet or
    leave its bound continuously (a corner), which is where its status changes (the change
    nearest the crossing: overshoot near the interval's ends changes it too), so that place
    is bracketed too. Each place is bracketed by two cuts a sample either side (one
    where the other would fall on an end); each mesh iteration narrows a bracket by about
    ``samples / 2``. Controls with equal bounds are ignored.
    """
    bp = np.asarray(trajectory.breakpoints if breakpoints is None else breakpoints, dtype=float)
    controls = trajectory.problem.controls
    K = bp.size - 1
    if not controls or K < 1:
        return [np.zeros(0) for _ in range(K)]
    lo = np.array([c.lower for c in controls], dtype=float)
    hi = np.array([c.upper for c in controls], dtype=float)
    width = np.where(np.isfinite(lo) & np.isfinite(hi), hi - lo, [c.scale for c in controls])
    bounded = (np.isfinite(lo) | np.isfinite(hi)) & (width > 0)
    if not bounded.any():
        return [np.zeros(0) for _ in range(K)]
    width = np.where(width > 0, width, 1.0)
    s = (np.arange(samples) + 0.5) / samples
    t = bp[:-1, None] + np.diff(bp)[:, None] * s[None, :]
    U = trajectory.control(t)  # (K, samples, nu)
    status = np.where(U <= lo + band * width, -1, 0) + np.where(U >= hi - band * width, 1, 0)
    changed = status[:, 1:] != status[:, :-1]  # (K, samples - 1, nu): between samples j and j + 1
    switching = changed.any(axis=1) & bounded  # (K, nu): controls that switch
    # the switching control that moves most; where it crosses the middle of its range on the interval
    spread = np.where(switching, (U.max(axis=1) - U.min(axis=1)) / width, -1.0)  # (K, nu)
    i = np.argmax(spread, axis=1)
    V = np.take_along_axis(U, i[:, None, None], axis=2)[:, :, 0]  # (K, samples)
    step = np.abs(np.diff(V, axis=1))
    side = V > (V.max(axis=1, keepdims=True) + V.min(axis=1, keepdims=True)) / 2
    crossing = side[:, 1:] != side[:, :-1]
    j_cross = np.argmax(np.where(crossing, step, -1.0), axis=1)
    # the status change nearest the crossing (overshoot near the interval's ends changes the status too)
    Vc = np.take_along_axis(changed, i[:, None, None], axis=2)[:, :, 0]  # (K, samples - 1)
    distance = np.abs(np.arange(samples - 1)[None, :] - j_cross[:, None])
    j_status = np.argmin(np.where(Vc, distance, samples), axis=1)
    Vs = np.take_along_axis(status, i[:, None, None], axis=2)[:, :, 0]  # (K, samples)
    out = []
    for k in range(K):
        if not switching[k].any():
            out.append(np.zeros(0))
            continue
        # from one bound to the other: a jump, at the mid-range crossing; between a bound and the interior: a
        # jump there or a corner where the status changes, so both are bracketed
        centres = [j_cross[k]]
        if not ((Vs[k] == -1).any() and (Vs[k] == 1).any()):
            centres.append(j_status[k])
        cuts = unique(np.concatenate([np.array([j, j + 2]) / samples for j in centres]))
        out.append(cuts[(cuts > 0.0) & (cuts < 1.0)])
    return out


def path_junctions(
    trajectory: Trajectory,
    breakpoints: ArrayLike | None = None,
    samples: int = SWITCH_SAMPLES,
    band: float = SWITCH_BAND,
) -> list[np.ndarray]:
    """Where a path constraint becomes active or inactive inside each interval: cuts (fractions in (0, 1)) around
    it, or none.

    The junction of a constrained arc with a free one is a corner of the control (the shuttle's heating-limited
    arc, Bryson-Denham's boundary arc), which no polynomial degree on the interval resolves: a polynomial control
    through the collocation points on both sides of it overshoots, and violates the constraint between the
    points, most where Radau extrapolates past its last collocation point. Cutting an interval where the
    violation is largest only moves its end, and the junction with it, a little at a time (the shuttle's heating
    limit on Radau 4 x 40: 9 meshes, stalled at 2e-3); cutting at the junction resolves it, as
    :func:`control_switches` does for a bounded control (met in 7 meshes). On each interval the constraints are
    sampled at ``samples`` midpoints; each inequality is on its lower bound, on its upper bound or between them
    (within ``band`` times the range of its bounds, or its scale where one is infinite; equalities are active
    everywhere and have no junction); the first and the last place on the interval where that status changes
    are bracketed, each by two cuts a sample either side.
    """
    bp = np.asarray(trajectory.breakpoints if breakpoints is None else breakpoints, dtype=float)
    K = bp.size - 1
    cs = trajectory.problem.functions.path
    if cs is None or K < 1:
        return [np.zeros(0) for _ in range(K)]
    _, G = _path_samples(trajectory, bp, samples)
    lower, upper = np.asarray(cs.lower, dtype=float), np.asarray(cs.upper, dtype=float)
    span = upper - lower
    two_sided = np.isfinite(span)
    width = band * np.where(two_sided, span, np.asarray(cs.scale, dtype=float))
    inequality = ~(two_sided & (span <= 0))  # an equality is active everywhere: it has no junction
    with np.errstate(invalid="ignore"):
        status = np.where(G <= lower + width, -1, 0) + np.where(G >= upper - width, 1, 0)
    changed = ((status[:, 1:] != status[:, :-1]) & inequality).any(axis=2)  # between samples j and j + 1
    out = []
    for k in range(K):
        j = np.flatnonzero(changed[k])
        if j.size == 0:
            out.append(np.zeros(0))
            continue
        cuts = unique(np.concatenate([np.array([c, c + 2]) / samples for c in {int(j[0]), int(j[-1])}]))
        out.append(cuts[(cuts > 0.0) & (cuts < 1.0)])
    return out


def state_error_message(
    label: str,
    errors: np.ndarray,
    breakpoints: np.ndarray,
    threshold: float | None,
    hint: Callable[[], str] | None = None,
) -> str:
    """What :func:`warn_if_inaccurate` says (the estimate, its interval, the threshold and the remedy), or ``""``
    when the largest of ``errors`` is within ``threshold`` (a NaN estimate is over it)."""
    if threshold is None or errors.size == 0:
        return ""
    k = int(np.argmax(np.where(np.isnan(errors), np.inf, errors)))
    if errors[k] <= threshold:
        return ""
    return (
        f"{label}: estimated relative state error {errors[k]:.1e} on interval {k} "
        f"[{breakpoints[k]:.6g}, {breakpoints[k + 1]:.6g}] exceeds {threshold:g}; refine the mesh "
        "(solve(mesh_tolerance=...)) or check the solution (reintegrate())"
        + (f"; {text}" if hint is not None and (text := hint()) else "")
    )


def warn_if_inaccurate(
    label: str,
    errors: np.ndarray,
    breakpoints: np.ndarray,
    threshold: float | None,
    hint: Callable[[], str] | None = None,
    stacklevel: int = 3,
) -> None:
    """Warn (:class:`AccuracyWarning`) naming the estimate and the interval when it exceeds ``threshold``
    (:func:`state_error_message`; ``hint``: a callable giving a sentence to add, e.g. :func:`periodic_control_hint`
    of the solution; ``stacklevel``: :func:`warnings.warn`'s, counted from here)."""
    if message := state_error_message(label, errors, breakpoints, threshold, hint):
        warnings.warn(message, AccuracyWarning, stacklevel=stacklevel)


# -- the whole solution: objective and path constraints ------------------------------------------------------------

#: Points per interval at which path constraints are checked between the scheme's own points
PATH_SAMPLES = 16


def flown_objective(
    trajectory: Trajectory, tol: float | None = None, *, rtol: float | None = None, atol: float | None = None
) -> float:
    """The cost the trajectory's admissible control achieves: the dynamics and the running cost integrated together
    from ``x(t0)``, ``J = phi(x(t0), x(t_f), t0, t_f) + int L``, restarting at every breakpoint, where the control
    may jump or kink (:func:`ocpkit.flight.fly`: CVODES at ``tol``, default :data:`ocpkit.flight.TOLERANCE`).
    ``rtol`` and ``atol``, DOP853's tolerances before 0.3, are deprecated: the smaller is taken as ``tol``."""
    from .flight import TOLERANCE, fly

    if rtol is not None or atol is not None:
        warnings.warn(
            "flown_objective(rtol=, atol=) is deprecated (the control is flown by CVODES at one tolerance): pass tol=",
            DeprecationWarning,
            stacklevel=2,
        )
        tol = min(v for v in (tol, rtol, atol) if v is not None)
    return float(fly(trajectory, TOLERANCE if tol is None else tol).objective)


def path_violation_table(
    trajectory: Trajectory, breakpoints: ArrayLike | None = None, samples: int = PATH_SAMPLES
) -> tuple[list[str], np.ndarray | None, np.ndarray | None]:
    """The violation of each path constraint expression between the scheme's points, per interval.

    On each interval the state interpolant and the admissible control are sampled at ``samples`` interior
    points; ``max(g - upper, lower - g, 0) / scale`` per expression (NaN counts as infinite). Returns
    ``(labels, V, S)``: the expressions' labels, ``V`` (K, samples, n_expr) the violations in units of each
    expression's scale, and ``S`` (samples,) the positions of the samples in (0, 1) of their interval; None for
    ``V`` and ``S`` without path constraints.
    """
    cs = trajectory.problem.functions.path
    if cs is None:
        return [], None, None
    bp = np.asarray(trajectory.breakpoints if breakpoints is None else breakpoints, dtype=float)
    s, G = _path_samples(trajectory, bp, samples)
    with np.errstate(invalid="ignore"):
        v = np.maximum(np.maximum(G - cs.upper, cs.lower - G), 0.0) / cs.scale
    return list(cs.labels), np.nan_to_num(v, nan=np.inf), s


def _path_samples(trajectory: Trajectory, bp: np.ndarray, samples: int) -> tuple[np.ndarray, np.ndarray]:
    """The path constraints' values ``G`` (K, samples, n_expr) at ``samples`` midpoints ``s`` of every interval
    between ``bp``, on the state interpolant and the admissible control; ``(s, G)``."""
    K = bp.size - 1
    s = (np.arange(samples) + 0.5) / samples
    t = bp[:-1, None] + np.diff(bp)[:, None] * s[None, :]  # (K, samples)
    X = trajectory.state(t).reshape(K * samples, -1)
    U = trajectory.control(t).reshape(K * samples, -1)
    problem = trajectory.problem
    P = problem.parameter_vector() if problem.parameters else np.zeros(0)
    path = cast("ConstraintSet", problem.functions.path)  # the callers' problems have path constraints
    G = np.asarray(path.function.map(K * samples)(X.T, U.T, t.reshape(1, -1), P)).T
    return s, G.reshape(K, samples, -1)


def path_violations(
    trajectory: Trajectory,
    breakpoints: ArrayLike | None = None,
    samples: int = PATH_SAMPLES,
    table: tuple[list[str], np.ndarray | None, np.ndarray | None] | None = None,
) -> tuple[list[str], np.ndarray, np.ndarray]:
    """The largest violation of each path constraint between the scheme's points, in units of its scale
    (:func:`path_violation_table`, or its result ``table``). Returns ``(labels, worst, where)``: the expressions' labels, their largest
    violation (``(n_expr,)``) and, per interval, the position in (0, 1) of its worst violation with its size
    (``(K, 2)``; the position NaN where nothing is violated).
    """
    bp = np.asarray(trajectory.breakpoints if breakpoints is None else breakpoints, dtype=float)
    K = bp.size - 1
    labels, V, s = path_violation_table(trajectory, bp, samples) if table is None else table
    if V is None:
        return [], np.zeros(0), np.full((K, 2), np.nan)
    v = V.max(axis=2)  # (K, samples): the worst expression
    j = np.argmax(v, axis=1)
    where = np.stack([cast(np.ndarray, s)[j], v[np.arange(K), j]], axis=1)  # (s: given with V)
    where[where[:, 1] <= 0, 0] = np.nan
    return labels, V.max(axis=(0, 1)), where


def path_cost_sensitivity(
    solution: PhaseSolution,
    breakpoints: ArrayLike | None = None,
    table: tuple[list[str], np.ndarray | None, np.ndarray | None] | None = None,
) -> float:
    """How much better a cost the NLP can claim through its path constraints' violations between its points:
    ``sum_k sum_e |mu_ke| v_ke scale_e``, the multiplier of expression ``e`` at path point ``k`` (a discrete
    measure, :attr:`~ocpkit.Solution.path_multipliers`, in cost per unit of the constraint) times the largest
    violation on the interval of the point (of the two intervals a point on a breakpoint belongs to), in the
    constraint's units: the first-order change of the optimal cost were the constraint relaxed by that much
    (Bryson-Denham on HLGL 10 and 16: within a factor of 2 of the gap between J and its closed form).
    0 without path constraints or multipliers. ``table``: :func:`path_violation_table`'s result, if at hand."""
    cs = solution.problem.functions.path
    times = getattr(solution, "path_times", None)
    mu = getattr(solution, "path_multipliers", None)
    if cs is None or times is None or mu is None or len(times) == 0:
        return 0.0
    bp = np.asarray(solution.breakpoints if breakpoints is None else breakpoints, dtype=float)
    K = bp.size - 1
    _, V, _ = path_violation_table(solution, bp) if table is None else table
    V = cast(np.ndarray, V)  # a table of a problem with path constraints (cs above)
    worst = V.max(axis=1) * np.asarray(cs.scale, dtype=float)  # (K, n_expr), in the constraints' units
    right = np.clip(np.searchsorted(bp, times, side="right") - 1, 0, K - 1)
    left = np.clip(np.searchsorted(bp, times, side="left") - 1, 0, K - 1)  # the interval ending at a breakpoint
    v = np.maximum(worst[right], worst[left])
    mu = np.abs(np.asarray(mu, dtype=float))
    with np.errstate(invalid="ignore"):
        return float(np.sum(np.where(mu > 0, mu * v, 0.0)))  # an inactive constraint is worth nothing, NaN or not


class Accuracy:
    """The parts of a solution's estimated error, each compared with a tolerance by :meth:`failing`.

    * ``state``: the relative state error (:func:`interval_errors`, the largest over intervals);
    * ``objective``: ``(|J_flown - J| + dJ_path) / max(|J|, objective_scale * 1e-3)``: the cost its admissible
      control achieves (:func:`flown_objective`) against the NLP's (``J_flown > J``: the NLP claims a better value
      than its control gives, as an under-resolved singular arc does), plus ``dJ_path``
      (``objective_path``, :func:`path_cost_sensitivity`), what the path constraints' violations between the
      points are worth in cost (the flown control violates them too, so flying it does not show what they
      gain); infinite when the control cannot be flown (``objective_failure`` says why: on open-loop unstable
      dynamics the flown cost measures the instability as much as the discretisation);
    * ``path``: per path constraint expression, the largest violation between the scheme's points
      (:func:`path_violations`), in units of the constraint's scale.

    ``flight_tolerance``: CVODES' tolerance for the flown cost (default :data:`ocpkit.flight.TOLERANCE`; a verdict
    at a loose tolerance flies at a looser one, :func:`ocpkit.verdict.flight_tolerance`).
    """

    solution: PhaseSolution | Solution
    path: dict[str, float]

    def __init__(self, solution: PhaseSolution, flight_tolerance: float | None = None) -> None:
        self.solution = solution
        self.state = float(solution.interval_errors.max())
        self.objective_nlp = float(solution.objective)
        self.objective_failure = ""
        try:
            self.objective_flown = flown_objective(solution, flight_tolerance)
        except (RuntimeError, ValueError, ArithmeticError) as exc:  # the control cannot be flown: unknown, not small
            self.objective_flown, self.objective_failure = float("nan"), str(exc)
        floor = 1e-3 * float(solution.problem.objective_scale)
        table = path_violation_table(solution, solution.estimate_intervals)
        self.objective_path = path_cost_sensitivity(solution, solution.estimate_intervals, table)
        difference = abs(self.objective_flown - self.objective_nlp) + self.objective_path
        self.objective = difference / max(abs(self.objective_nlp), floor) if np.isfinite(difference) else np.inf
        labels, worst, self.path_where = path_violations(solution, solution.estimate_intervals, table=table)
        self.path = dict(zip(labels, worst.tolist()))

    @property
    def parts(self) -> dict[str, float]:
        """Every part by name, ``state``, ``objective``, ``path <label>``."""
        return {"state": self.state, "objective": self.objective, **{f"path {k}": v for k, v in self.path.items()}}

    def failing(self, tolerance: float) -> list[str]:
        """The names of the parts above ``tolerance``."""
        return [k for k, v in self.parts.items() if not v <= tolerance]

    @property
    def worst(self) -> tuple[str, float]:
        """The largest part and its name."""
        name = max(self.parts, key=lambda k: self.parts[k])
        return name, self.parts[name]

    def describe(self, tolerance: float | None = None) -> str:
        bad = set(self.failing(tolerance)) if tolerance is not None else set()
        items = [f"{k} {v:.1e}" + (" (over)" if k in bad else "") for k, v in self.parts.items()]
        flown = f"; J {self.objective_nlp:.10g}, flown {self.objective_flown:.10g}"
        return ", ".join(items) + flown

    def __repr__(self) -> str:
        return f"Accuracy({self.describe()})"


class MultiPhaseAccuracy(Accuracy):
    """The parts of a multi-phase solution's estimated error (:class:`Accuracy`'s, over the phases).

    ``state``: the largest phase's; ``path``: per constraint label, the largest over the phases that have it;
    ``objective``: the sum over the phases of ``|J_flown - J| + dJ_path`` (each phase flown from its own
    initial state), plus the trajectory-level cost's change on the flown trajectory (the phases flown in turn
    through their links: :meth:`~ocpkit.Solution.flown_trajectory_cost`), relative to
    ``max(|J|, objective_scale * 1e-3)``. ``phases``: each phase's :class:`Accuracy`.
    """

    def __init__(self, solution: Solution) -> None:  # (not Accuracy's: the phases' parts combined)
        self.solution = solution
        self.phases = [p.accuracy for p in solution.phases]
        self.state = float(np.max([a.state for a in self.phases]))  # (NaN in any phase is NaN)
        self.objective_nlp = float(solution.objective)
        self.objective_failure = "; ".join(
            f"phase {name}: {a.objective_failure}"
            for name, a in zip(solution.names, self.phases)
            if a.objective_failure
        )
        self.objective_path = float(sum(a.objective_path for a in self.phases))
        flown_cost = solution.flown_trajectory_cost()
        ends = abs(flown_cost - solution.trajectory_cost)
        self.objective_flown = float(sum(a.objective_flown for a in self.phases)) + flown_cost
        difference = sum(abs(a.objective_flown - a.objective_nlp) for a in self.phases) + self.objective_path + ends
        floor = 1e-3 * float(solution.objective_scale)
        self.objective = difference / max(abs(self.objective_nlp), floor) if np.isfinite(difference) else np.inf
        self.path = {}
        for a in self.phases:
            for label, value in a.path.items():
                self.path[label] = float(np.max([self.path.get(label, 0.0), value]))


def path_violation_message(label: str, worst: Mapping[str, float], threshold: float | None) -> str:
    """What :func:`warn_if_path_violated` says: each path constraint whose largest violation between the scheme's
    points (``worst``, by label, in units of its scale: :func:`path_violations`) exceeds ``threshold``, and the
    remedy; ``""`` where none does."""
    if threshold is None:
        return ""
    bad = [f"{k} by {v:.1e}" for k, v in worst.items() if not v <= threshold]
    if not bad:
        return ""
    return (
        f"{label}: path constraints violated between collocation points ({', '.join(bad)}, in units of each "
        f"constraint's scale) by more than {threshold:g}; refine the mesh (solve(mesh_tolerance=...))"
    )


def warn_if_path_violated(label: str, solution: PhaseSolution, threshold: float | None, stacklevel: int = 3) -> None:
    """Warn (:class:`AccuracyWarning`) naming each path constraint violated between the scheme's points by more
    than ``threshold`` (:func:`path_violation_message`)."""
    if threshold is None or solution.problem.functions.path is None:
        return
    labels, worst, _ = path_violations(solution, solution.estimate_intervals)
    if message := path_violation_message(label, dict(zip(labels, worst.tolist())), threshold):
        warnings.warn(message, AccuracyWarning, stacklevel=stacklevel)


# -- singular arcs --------------------------------------------------------------------------------------------------


def linear_controls(problem: OptimalControlProblem) -> list[str]:
    """The controls that enter the dynamics and the running cost affinely (``df/du`` and ``dL/du`` do not depend on
    ``u``): their Hamiltonian is affine, so on an interior arc they are singular. (An L1 cost ``|u|`` is not
    affine: its derivative ``sign(u)`` depends on ``u``, and its "off" arc is determined, not singular.)"""
    import casadi as ca

    nx, nu = problem.nx, problem.nu
    if nu == 0:
        return []
    x, u, t = ca.SX.sym("x", nx), ca.SX.sym("u", nu), ca.SX.sym("t")
    p = ca.SX.sym("P", problem.f.size1_in(3))
    exprs = [problem.f(x, u, t, p)]
    if problem.L is not None:
        exprs.append(problem.L(x, u, t, p))
    out = []
    for i, name in enumerate(problem.control_names):
        if not any(ca.depends_on(ca.jacobian(e, u[i]), u[i]) for e in exprs):
            out.append(name)
    return out


def singular_arcs(trajectory: Trajectory, samples: int = 2001, share: float = 0.02) -> list[tuple[str, float, float]]:
    """For each control that enters linearly (:func:`linear_controls`), where it is singular: ``(name, t_start,
    t_end)`` from its first to its last sample off its bounds (by more than ``share`` of its range), when that
    stretch is longer than 2 % of the horizon, touches at least 3 mesh intervals, and the control is off its bounds
    on at least 30 % of it (a transcription's control chatters on a singular arc; a bang-bang control leaves its
    bounds only at switches, each smeared over an interval or two)."""
    problem = trajectory.problem
    names = linear_controls(problem)
    if not names:
        return []
    t = np.linspace(trajectory.t0, trajectory.tf, samples)
    U = trajectory.control(t)
    bp = np.asarray(trajectory.breakpoints, dtype=float)
    out = []
    for name in names:
        i = problem.control_names.index(name)
        c = problem.controls[i]
        if not (np.isfinite(c.lower) and np.isfinite(c.upper) and c.upper > c.lower):
            continue
        band = share * (c.upper - c.lower)
        inside = np.flatnonzero((U[:, i] > c.lower + band) & (U[:, i] < c.upper - band))
        if inside.size == 0:
            continue
        first, last = int(inside[0]), int(inside[-1])
        spans = np.count_nonzero((bp > t[first]) & (bp < t[last])) + 1  # mesh intervals the stretch touches
        if last - first > 0.02 * samples and inside.size >= 0.3 * (last - first + 1) and spans >= 3:
            out.append((name, float(t[first]), float(t[last])))
    return out


def singular_arc_hint(trajectory: Trajectory) -> str:
    """A sentence naming the singular arcs of a trajectory (:func:`singular_arcs`) and the regularisation to try,
    or the empty string."""
    try:
        arcs = singular_arcs(trajectory)
    except Exception:  # noqa: BLE001 - a hint never hides the error it accompanies
        return ""
    if not arcs:
        return ""
    where = ", ".join(f"{n!r} on [{a:.6g}, {b:.6g}]" for n, a, b in arcs)
    names = [n for n, _, _ in arcs]
    return (
        f"a singular arc: the Hamiltonian is affine in {where} and the control is interior there, which "
        "collocation resolves poorly (chattering, a cost better than the optimum, IPOPT's acceptable level); "
        f"regularise it, ocpkit.regularisation.penalise_control(problem, 1e-6, {names!r}), and continue the weight towards zero"
    )


# -- angles -----------------------------------------------------------------------------------------------------------

#: The periods tried for a control the problem's functions see only through periodic functions (radians, degrees)
PERIODS = (2 * np.pi, 360.0)


def undeclared_periodic_controls(trajectory: Trajectory) -> list[tuple[str, float]]:
    """The controls that are angles in all but name: not declared periodic (:attr:`~ocpkit.Control.period`), while
    the dynamics and the running cost do not change when the control moves by a whole period (:data:`PERIODS`,
    tried at the trajectory's own node values, to 1e-9), and the control's values move by more than half a period
    between consecutive nodes somewhere: a polynomial through them sweeps whole turns the dynamics never saw
    (orbit raising on Radau 4 x 20: 233.7, -109.7 and -417 degrees in one interval). ``(name, period)`` each."""
    problem = trajectory.problem
    values = getattr(trajectory, "control_values", None)
    times = getattr(trajectory, "control_times", None)
    if problem.nu == 0 or values is None or times is None or len(values) < 2:
        return []
    X, U, t = trajectory.state(np.asarray(times)), np.asarray(values, dtype=float), np.asarray(times, dtype=float)
    P = problem.parameter_vector() if problem.parameters else np.zeros(0)
    n = t.size

    def rates(U: np.ndarray) -> np.ndarray:
        out = [np.asarray(problem.f.map(n)(X.T, U.T, t.reshape(1, -1), P))]
        if problem.L is not None:
            out.append(np.asarray(problem.L.map(n)(X.T, U.T, t.reshape(1, -1), P)))
        return np.vstack(out)

    base = rates(U)
    found = []
    for j, c in enumerate(problem.controls):
        if c.period is not None:
            continue
        for period in PERIODS:
            if c.upper - c.lower < period or np.abs(np.diff(U[:, j])).max(initial=0.0) <= period / 2:
                continue
            moved = U.copy()
            moved[:, j] += period
            if np.all(np.abs(rates(moved) - base) <= 1e-9 * (1.0 + np.abs(base))):
                found.append((c.name, period))
                break
    return found


def periodic_control_hint(trajectory: Trajectory) -> str:
    """A sentence naming the controls of :func:`undeclared_periodic_controls` and how to declare them, or ``""``."""
    try:
        found = undeclared_periodic_controls(trajectory)
    except Exception:  # noqa: BLE001 - a hint never hides the error it accompanies
        return ""
    if not found:
        return ""
    names = ", ".join(f"{n!r} (period {p:g})" for n, p in found)
    declare = ", ".join(f"Control({n!r}, period={'2 * math.pi' if p == PERIODS[0] else f'{p:g}'})" for n, p in found)
    return (
        f"an angle not declared periodic: the dynamics see {names} only through periodic functions, and its node "
        f"values jump by more than half a period, so its polynomial sweeps whole turns between them; declare it, "
        f"{declare}"
    )


def refinement_hint(trajectory: Trajectory) -> str:
    """What to try when a solution cannot be refined to a tolerance: the singular arcs (:func:`singular_arc_hint`)
    and the undeclared angles (:func:`periodic_control_hint`) it shows, or ``""``."""
    return "; ".join(h for h in (singular_arc_hint(trajectory), periodic_control_hint(trajectory)) if h)
