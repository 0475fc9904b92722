"""The switching structure of a solution: per control, its arcs and the junction times between them.

The first step from a direct solution to an extremal of the maximum principle (Martinon & Gergaud's slides set the
direct method's robustness against the indirect one's precision; the hybrid reads the structure and the costates
of the first to start the second). On a dense grid, each bounded control, and each control an active inequality
involves, is

* ``"lower"`` or ``"upper"``: on that bound (within ``band`` of its range);
* ``"zero"``: at zero, strictly inside its bounds, for a control with an L1 cost (``w |u|`` in H: an "off" arc);
* ``"singular"``: elsewhere inside, for a control the Hamiltonian is affine in (:func:`ocpkit.accuracy.linear_controls`),
  or piecewise affine in (an L1 cost without a quadratic term,
  :func:`ocpkit.hamiltonian_form.piecewise_affine_controls`: ``psi = -w`` or ``+w`` on the arc);
* ``"regular"``: elsewhere inside otherwise (``H_u = 0`` gives the control);
* ``"boundary"``: inside its bounds where an inequality of the problem is active (:func:`inequalities`: a state
  on its bound, a pure state constraint, or a mixed state-control path constraint at its bound); the arc names it.
  For a state constraint of order two or more (``q``: its ``q``-th time derivative is the first that contains a
  control), active only where ``c^(q)(x, u)`` also vanishes (within 1e-2 of its range): the control is the
  boundary control there. A stretch where it is active but ``c^(q)`` does not vanish is a *touch point*
  (:class:`Touch`, at the stretch's middle): the constraint reached at an instant, as Bryson-Denham's ``x <= l``
  for ``1/6 <= l <= 1/4``; stretches that reach ``t0`` or ``tf`` are the boundary values', not touch points.

Runs shorter than ``min_share`` of the horizon, a direct solution's singular runs within fewer than three mesh
intervals (the smearing of a switch by the polynomial control), and its runs on a bound within fewer than three
mesh intervals between two singular runs (the chattering of collocation on a singular arc) are not arcs: each is
shared between its neighbours at its middle. A junction is first the midpoint of the two samples either side; where
the solution has costates (Radau) and the Hamiltonian has the form ``H0 + psi u + w |u|`` in the control, it is
refined to the crossing of the switching function that decides it: ``psi = 0`` between the two bounds or at a
singular arc, ``psi = w`` between ``"lower"`` and ``"zero"``, ``psi = -w`` between ``"zero"`` and ``"upper"``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from .hamiltonian_form import decompose, l1_controls, piecewise_affine_controls
from .statement import declared_turn

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from .statement import OptimalControlProblem
    from .trajectory import Trajectory

#: the kinds of arc, in the order of :func:`control_structure`'s classification
ARC_KINDS = ("lower", "upper", "zero", "singular", "regular", "boundary")


@dataclass(frozen=True)
class Inequality:
    """One inequality of a problem as ``c(x, u, t, P) <= 0`` (CasADi Function ``function``), named
    ``"<state>.lower"``/``"<state>.upper"`` for a state's bound or ``"<constraint>.lower"``/``".upper"`` for a path
    constraint's; ``pure`` when ``c`` does not depend on the control (a state constraint)."""

    name: str
    function: ca.Function
    pure: bool
    #: the indices of the controls in ``c`` (mixed), or in its ``order``-th time derivative (a state constraint)
    controls: tuple[int, ...] = ()
    #: 0 for a mixed constraint; for a state constraint, the order of the first time derivative along the dynamics
    #: that contains a control (0 where none of the first three does)
    order: int = 0
    #: ``c^(order)(x, u, t, P)`` for a state constraint whose order is known, else None
    rate: ca.Function | None = None


#: the highest order of a state constraint that :func:`inequalities` looks for
MAX_ORDER = 3


def inequalities(problem: OptimalControlProblem) -> list[Inequality]:
    """Every finite state bound and path-constraint bound of ``problem`` as an :class:`Inequality` ``c <= 0``, a
    state constraint with its order (up to :data:`MAX_ORDER`) and its derivative of that order."""
    ham = problem.functions.hamiltonian
    x, u, t, P = ham.x, ham.u, ham.t, ham.P
    out = []

    def add(name: str, expr: ca.SX) -> None:
        fun = ca.Function("inequality", [x, u, t, P], [expr], ["x", "u", "t", "P"], ["c"])
        pure = not ca.depends_on(expr, u)
        if not pure:
            controls = tuple(i for i in range(problem.nu) if ca.depends_on(expr, u[i]))
            out.append(Inequality(name, fun, pure, controls))
            return
        moved, order = expr, 0
        for q in range(1, MAX_ORDER + 1):
            moved = ca.jtimes(moved, x, ham.f) + ca.jacobian(moved, t)
            if ca.depends_on(moved, u):
                order = q
                break
        controls = tuple(i for i in range(problem.nu) if ca.depends_on(moved, u[i])) if order else ()
        rate = ca.Function("rate", [x, u, t, P], [moved], ["x", "u", "t", "P"], ["c_q"]) if order else None
        out.append(Inequality(name, fun, pure, controls, order, rate))

    for i, s in enumerate(problem.states):
        if np.isfinite(s.lower):
            add(f"{s.name}.lower", s.lower - x[i])
        if np.isfinite(s.upper):
            add(f"{s.name}.upper", x[i] - s.upper)
    path = problem.functions.path
    if path is not None:
        g = path.function(x, u, t, P)
        for k, label in enumerate(path.labels):
            if np.isfinite(path.lower[k]):
                add(f"{label}.lower", path.lower[k] - g[k])
            if np.isfinite(path.upper[k]):
                add(f"{label}.upper", g[k] - path.upper[k])
    return out


@dataclass(frozen=True)
class Arc:
    """One arc of one control: its ``kind`` (:data:`ARC_KINDS`) on ``[start, end]``."""

    control: str
    kind: str
    start: float
    end: float
    #: on a ``"boundary"`` arc, the active inequality (:func:`inequalities`), e.g. ``"v.upper"``
    constraint: str | None = None

    def __str__(self) -> str:
        kind = self.kind if self.constraint is None else f"{self.kind} ({self.constraint})"
        return f"{kind} on [{self.start:.6g}, {self.end:.6g}]"


@dataclass(frozen=True)
class Touch:
    """A touch point: the state constraint ``constraint`` (:func:`inequalities`, of order two or more) active at
    the one instant ``time``."""

    constraint: str
    time: float

    def __str__(self) -> str:
        return f"touch point of {self.constraint} at {self.time:.6g}"


@dataclass(frozen=True)
class Structure:
    """Every control's arcs, in time order, and the state constraints' touch points (:func:`control_structure`)."""

    arcs: tuple[Arc, ...]
    touches: tuple[Touch, ...] = ()

    def of(self, control: str) -> list[Arc]:
        """The arcs of ``control``."""
        out = [a for a in self.arcs if a.control == control]
        if not out:
            raise KeyError(f"unknown control {control!r}; the controls are {sorted({a.control for a in self.arcs})}")
        return out

    def kinds(self, control: str) -> list[str]:
        """The sequence of arc kinds of ``control``, e.g. ``["lower", "zero", "upper"]`` (bang-off-bang)."""
        return [a.kind for a in self.of(control)]

    def junctions(self, control: str) -> np.ndarray:
        """The junction times of ``control`` (the ends of its arcs but the last)."""
        return np.array([a.end for a in self.of(control)[:-1]])

    def describe(self, times: bool = True) -> str:
        """The structure in words, a line per control: ``u: lower on [0, 0.5], zero on [0.5, 2.5], upper on [2.5,
        3]``; without ``times``, the arcs only: ``u: lower, zero, upper``."""
        lines = []
        for name in dict.fromkeys(a.control for a in self.arcs):
            parts = [str(a) if times else str(a).split(" on [")[0] for a in self.of(name)]
            lines.append(f"{name}: " + ", ".join(parts))
        for touch in self.touches:
            lines.append(str(touch) if times else f"touch point of {touch.constraint}")
        return "\n".join(lines)


def control_structure(
    trajectory: Trajectory, samples: int = 4001, band: float = 1e-3, min_share: float = 0.01
) -> Structure:
    """The arcs of every bounded control of ``trajectory`` (and of every control an active inequality involves) and
    their junction times (module docstring).

    ``samples``: grid points over the horizon; ``band``: the distance to a bound, or to zero, that counts as on it,
    as a fraction of the bounds' range; ``min_share``: the shortest arc, as a fraction of the horizon.
    """
    from .accuracy import linear_controls
    from .solution import PhaseSolution, Solution

    if samples < 3:
        raise ValueError(f"samples must be at least 3, got {samples}")
    if not 0 < min_share < 0.5:
        raise ValueError(f"min_share must lie in (0, 0.5), got {min_share}")
    problem = trajectory.problem
    t = np.linspace(trajectory.t0, trajectory.tf, samples)
    U = np.asarray(trajectory.control(t), dtype=float).reshape(samples, problem.nu)
    affine = set(linear_controls(problem))
    # a transcription's control is one polynomial per mesh interval (also as read in a restated problem's controls,
    # which say so); an extremal's (shooting) is exact
    polynomial = isinstance(trajectory, (Solution, PhaseSolution)) or bool(getattr(trajectory, "polynomial", False))
    breaks = np.asarray(trajectory.breakpoints, dtype=float)
    switching = _switching_functions(trajectory)
    active, touches = _active(trajectory, t, U, band, min_share)
    l1 = l1_controls(problem)
    piecewise = piecewise_affine_controls(problem) if l1 else set()
    arcs = []
    for i, c in enumerate(problem.controls):
        # a periodic control's bounds a period apart or more hold no angle back (Control.period): not on them
        bounded = np.isfinite(c.lower) and np.isfinite(c.upper) and c.upper > c.lower and declared_turn(c) is None
        mine = {name: on for name, (on, controls) in active.items() if i in controls}
        if not bounded and not mine:
            continue  # an unbounded control without an active inequality: regular throughout, no arcs
        u = U[:, i]
        # H is affine in a control, or piecewise affine in one with an L1 cost (H0 + psi u + w |u|): inside its
        # bounds and off zero, such a control is singular (psi = -w or +w)
        interior = "singular" if c.name in affine or i in piecewise else "regular"
        labels = np.full(samples, interior, dtype=object)
        if bounded:
            tol = band * (c.upper - c.lower)
            if c.lower < 0 < c.upper and i in l1:
                labels[np.abs(u) <= tol] = "zero"
            labels[u <= c.lower + tol] = "lower"
            labels[u >= c.upper - tol] = "upper"
        for name, on in mine.items():  # an inequality active where the control is inside: a boundary arc
            labels[on & (labels == interior)] = f"boundary:{name}"
        shortest = max(int(np.ceil(min_share * (samples - 1))), 1)

        def short(
            label: str,
            a: int,
            b: int,
            left: str | None,
            right: str | None,
            interior: str = interior,
            shortest: int = shortest,
        ) -> bool | np.bool_:
            # an interior run within fewer than three mesh intervals is a switch the polynomial smears (a
            # transcription's control is one polynomial per interval), not an arc; a bound run as short between
            # two singular runs is the singular arc's chattering
            spans = np.count_nonzero((breaks > t[a]) & (breaks < t[b])) + 1
            chatter = label in ("lower", "upper", "zero") and left == right == "singular"
            smear = label == interior == "singular"  # a regular control is continuous: nothing to smear
            return b - a + 1 < shortest or (polynomial and (smear or chatter) and spans < 3)

        runs = _runs(labels, short)
        for k, (kind, a, b) in enumerate(runs):
            start = t[0] if k == 0 else _junction(t, runs[k - 1], (kind, a, b), switching, i)
            end = t[-1] if k == len(runs) - 1 else _junction(t, (kind, a, b), runs[k + 1], switching, i)
            kind, _, constraint = kind.partition(":")
            arcs.append(Arc(c.name, kind, float(start), float(end), constraint or None))
    return Structure(tuple(arcs), tuple(touches))


#: how close to zero, relative to its range along the trajectory, ``c^(q)`` must be on a boundary arc of a state
#: constraint of order ``q >= 2`` (elsewhere in a stretch where ``c`` is active, the stretch is a touch point)
RATE_BAND = 1e-2


def _active(
    trajectory: Trajectory, t: np.ndarray, U: np.ndarray, band: float, min_share: float
) -> tuple[dict[str, tuple[np.ndarray, tuple[int, ...]]], list[Touch]]:
    """Per inequality (:func:`inequalities`) active somewhere on the grid ``t`` (within ``band`` of zero, relative
    to the range of its values along the trajectory): where, and the controls it involves; and the touch points
    of the state constraints of order two or more (module docstring)."""
    problem = trajectory.problem
    X = np.asarray(trajectory.state(t), dtype=float).reshape(t.size, problem.nx)
    P = np.repeat(np.asarray(problem.full_parameters, dtype=float).reshape(-1, 1), t.size, axis=1)
    out = {}
    touches = []
    shortest = max(int(np.ceil(min_share * (t.size - 1))), 1)
    for ineq in inequalities(problem):
        c = np.asarray(ineq.function.map(t.size)(X.T, U.T, t[None, :], P)).ravel()
        on = c >= -band * max(float(np.ptp(c)), 1e-12)
        if ineq.pure and ineq.order >= 2 and ineq.rate is not None and on.any():
            rate = np.asarray(ineq.rate.map(t.size)(X.T, U.T, t[None, :], P)).ravel()
            flat = np.abs(rate) <= RATE_BAND * max(float(np.ptp(rate)), 1e-12)
            edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(int), [0]])))
            for a, b in zip(edges[::2], edges[1::2] - 1):  # each stretch where c is active
                if a == 0 or b == t.size - 1:
                    continue  # the boundary values', not a touch point
                if np.count_nonzero(flat[a : b + 1]) < shortest:
                    touches.append(Touch(ineq.name, float(0.5 * (t[a] + t[b]))))
            on = on & flat
        if on.any():
            out[ineq.name] = (on, ineq.controls)
    return out, sorted(touches, key=lambda touch: touch.time)


def _runs(
    labels: np.ndarray, short: Callable[[str, int, int, str | None, str | None], bool | np.bool_]
) -> list[tuple[str, int, int]]:
    """Runs ``(label, first, last)`` of equal labels; a run that ``short(label, first, last, left, right)`` (the
    neighbours' labels, None at an end) calls too short to be an arc (the shortest first) is shared between its
    neighbours at its middle, or given to its only one."""
    runs: list[list[Any]] = []
    for k, label in enumerate(labels):
        if runs and runs[-1][0] == label:
            runs[-1][2] = k
        else:
            runs.append([label, k, k])
    while len(runs) > 1:
        candidates = [
            k
            for k, (label, a, b) in enumerate(runs)
            if short(label, a, b, runs[k - 1][0] if k else None, runs[k + 1][0] if k + 1 < len(runs) else None)
        ]
        if not candidates:
            break
        k = min(candidates, key=lambda j: runs[j][2] - runs[j][1])
        _, a, b = runs[k]
        if 0 < k < len(runs) - 1:
            middle = (a + b) // 2
            runs[k - 1][2], runs[k + 1][1] = middle, middle + 1
        elif k == 0:
            runs[1][1] = a
        else:
            runs[k - 1][2] = b
        del runs[k]
        merged: list[list[Any]] = []  # neighbours that now carry the same label become one run
        for run in runs:
            if merged and merged[-1][0] == run[0]:
                merged[-1][2] = run[2]
            else:
                merged.append(run)
        runs = merged
    return [tuple(r) for r in runs]


def _switching_functions(
    trajectory: Trajectory,
) -> Callable[[ArrayLike], tuple[np.ndarray, np.ndarray]] | None:
    """``(psi, w)`` as functions of time for each control, where the solution has costates and ``H`` has the form
    ``H0 + psi u + w |u|`` in each control; else None."""
    if not trajectory.has_costates:
        return None
    problem = trajectory.problem
    ham = problem.functions.hamiltonian
    H0, psi_i, w_i, _ = decompose(ham.H, ham.u, problem.nu)
    psi, w = ca.vertcat(*psi_i), ca.vertcat(*w_i)
    # the form holds where H - (H0 + psi u + w |u|) vanishes: checked at random points (a quadratic or nonlinear
    # control term leaves a residual, and then no switching function decides the junctions)
    residual = ca.Function(
        "residual", [ham.x, ham.p, ham.u, ham.t, ham.P], [ham.H - H0 - ca.dot(psi, ham.u) - ca.dot(w, ca.fabs(ham.u))]
    )
    rng = np.random.default_rng(0)
    P = problem.parameter_vector()
    for _ in range(5):
        args: list[Any] = [
            rng.normal(size=problem.nx),
            rng.normal(size=problem.nx),
            rng.uniform(-1, 1, problem.nu),
            0.3,
            P,
        ]
        if not abs(float(residual(*args))) <= 1e-9:
            return None
    fun = ca.Function("switching", [ham.x, ham.p, ham.t, ham.P], [psi, w])

    def at(times: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        times = np.atleast_1d(np.asarray(times, dtype=float))
        X = trajectory.state(times).reshape(times.size, -1).T
        L = trajectory.costate(times).reshape(times.size, -1).T
        out = fun.map(times.size)(X, L, times[None, :], np.repeat(P[:, None], times.size, axis=1))
        return np.asarray(out[0]).T, np.asarray(out[1]).T

    return at


def _junction(
    t: np.ndarray,
    before: tuple[str, int, int],
    after: tuple[str, int, int],
    switching: Callable[[ArrayLike], tuple[np.ndarray, np.ndarray]] | None,
    i: int,
) -> float:
    """The junction between two runs: the midpoint of the samples either side, refined to the crossing of the
    switching function that decides it (module docstring) within a few samples of it, where there is one."""
    (kind_a, _, last), (kind_b, first, _) = before, after
    guess = 0.5 * (t[last] + t[first])
    if switching is None:
        return guess
    pair = {kind_a, kind_b}
    if any(k.startswith("boundary") for k in pair):
        return guess  # an inequality becomes active or inactive: no switching function decides it
    if pair == {"lower", "upper"}:
        sign = 0.0
    elif "singular" in pair:  # psi = 0 (H affine), psi = -w after or before "upper", +w by "lower" (an L1 cost)
        rest = pair - {"singular"}
        side = {"upper": -1.0, "lower": 1.0}.get(next(iter(rest)), None) if rest else 0.0
        if side is None:
            return guess  # an L1 control between zero and singular: psi = -w or +w, which the branch decides
        sign = side
    elif pair == {"lower", "zero"}:
        sign = 1.0
    elif pair == {"zero", "upper"}:
        sign = -1.0
    else:
        return guess  # a regular arc meets the bound continuously: no switching function decides it
    h = t[1] - t[0]
    grid = np.linspace(max(t[0], guess - 8 * h), min(t[-1], guess + 8 * h), 161)
    psi, w = switching(grid)
    g = psi[:, i] - sign * w[:, i]
    change = np.flatnonzero(np.sign(g[:-1]) * np.sign(g[1:]) < 0)
    roots = [grid[k] - g[k] * (grid[k + 1] - grid[k]) / (g[k + 1] - g[k]) for k in change]
    roots += list(grid[g == 0])  # a crossing that falls on a grid point
    if not roots:
        return guess
    return float(min(roots, key=lambda r: abs(r - guess)))


__all__ = ["ARC_KINDS", "MAX_ORDER", "Arc", "Inequality", "Structure", "Touch", "control_structure", "inequalities"]
