"""The second-order check of an extremal: a minimum, not only a point where the first variation vanishes.

The first-order checks of a certificate (:func:`ocpkit.certificate.certify`) say that an extremal satisfies the
maximum principle; a maximum or a saddle of the cost can satisfy it too. :func:`second_order` tries two routes, the
first that applies:

1. **Convexity** (Mangasarian, SIAM J. Control 4, 1966; with state constraints, Seierstad & Sydsaeter, *Optimal
   Control Theory with Economic Applications*, 1987, Ch. 5): where the dynamics are affine in ``(x, u)``, the running
   cost, the Mayer term and every inequality are convex, every boundary equality is affine, the control set is a
   box and ``t0``, ``tf`` are fixed, ``H(., ., p)`` is convex in ``(x, u)`` for every costate, and a normal extremal
   whose multipliers have their signs (the certificate's ``multiplier_sign``) is a *global* minimum. Convexity is
   read from the functions: a Jacobian of ``f`` that does not depend on ``(x, u)``, Hessians that do not depend on
   ``(x, u)`` and are positive semidefinite at 41 times, and the midpoint inequality at 200 random pairs of points
   (which catches a kink such as ``-|u|``, whose Hessian is 0 where it exists).
2. **Jacobi** (the accessory minimum problem; Bryson & Ho, *Applied Optimal Control*, 1975, Ch. 6): where every
   control is regular on the whole extremal (no bang, singular or boundary arc, no touch point), ``t0`` and ``tf``
   fixed, the initial state fixed and the terminal conditions on ``x(tf)`` only: the strengthened Legendre-Clebsch
   condition ``H_uu > 0`` along the extremal, and no conjugate point. The Jacobi fields are the solutions of the
   linearised canonical equations with ``du = -H_uu^-1 (H_ux dx + f_u' dp)``, started at ``tf`` on the terminal
   conditions (``dx(tf)`` in the tangent space of the terminal manifold with ``dp(tf) = Phi~_xx dx(tf)``, ``Phi~``
   the Mayer term with the boundary equalities' multipliers, and ``dx(tf) = 0`` with ``dp(tf)`` along each
   condition's gradient) and integrated backwards (RK4 on 2000 steps, the extremal sampled at each stage); a
   conjugate point is a time in ``[t0, tf)`` where ``det dX`` changes sign (its columns scaled by the fields'
   norms), and then the extremal is not a minimum (a variation vanishing at both ends lowers the cost).

Elsewhere the check is not applicable, and :class:`SecondOrder` says why (the sufficient conditions of bang-bang
extremals, Agrachev, Stefani & Zezza 2002, and of singular and state-constrained arcs, Malanowski, Maurer &
Pickenhain 2004, are not implemented).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from .statement import FreeFinalTime

if TYPE_CHECKING:
    from collections.abc import Sequence

    from .statement import OptimalControlProblem
    from .structure import Structure
    from .trajectory import Trajectory

VERDICTS = ("passed", "failed", "not applicable")


@dataclass(frozen=True)
class SecondOrder:
    """The verdict of :func:`second_order`: ``verdict`` one of :data:`VERDICTS`, the ``route`` that gave it
    (``"convexity"``, ``"jacobi"`` or ``""``), the ``conjugate`` time where a Jacobi test failed on a conjugate
    point (None elsewhere), ``margin`` (the Jacobi test's smallest scaled ``|det dX|`` on ``[t0, tf)``, or where the
    Legendre-Clebsch condition failed the smallest eigenvalue of ``H_uu``; None elsewhere) and ``detail`` (why, in
    words)."""

    verdict: str
    route: str
    detail: str
    conjugate: float | None = None
    margin: float | None = None

    @property
    def applicable(self) -> bool:
        return self.verdict != "not applicable"

    @property
    def passed(self) -> bool:
        """True where it passed or is not applicable (a failure is what fails a certificate)."""
        return self.verdict != "failed"

    def __str__(self) -> str:
        route = f" ({self.route})" if self.route else ""
        return f"{self.verdict}{route}: {self.detail}"


def second_order(
    trajectory: Trajectory,
    structure: Structure,
    multipliers: Sequence[float] | np.ndarray | None = None,
    steps: int = 2000,
) -> SecondOrder:
    """The second-order verdict of the extremal ``trajectory`` (module docstring): ``structure`` its arcs
    (:func:`ocpkit.structure.control_structure` of the extremal), ``multipliers`` those of the problem's boundary
    equalities (an :class:`~ocpkit.shooting.arcs.ArcResult`'s; None where the shooting has none)."""
    problem = trajectory.problem
    if problem.free_initial_time or isinstance(problem.tf, FreeFinalTime):
        return SecondOrder("not applicable", "", "a free initial or final time: its second variation is not derived")
    if problem.nu == 0:
        return SecondOrder("not applicable", "", "no control: the accessory problem has no variation to test")
    reason = not_convex(problem, trajectory)
    if reason is None:
        return SecondOrder(
            "passed",
            "convexity",
            "the dynamics are affine in (x, u) and the costs and constraints convex: a normal extremal with its "
            "multipliers' signs is a global minimum",
        )
    structure = _exact(trajectory, structure)
    other = [a for a in structure.arcs if a.kind != "regular"]
    if other:
        a = other[0]
        return SecondOrder(
            "not applicable",
            "",
            f"not convex ({reason}), and control {a.control!r} has {'an' if a.kind[0] in 'aeiou' else 'a'} {a.kind} "
            f"arc on [{a.start:.6g}, {a.end:.6g}]: "
            "the Jacobi test takes regular arcs only",
        )
    if structure.touches:
        return SecondOrder(
            "not applicable", "", f"not convex ({reason}), and {structure.touches[0]}: the Jacobi test takes none"
        )
    return _jacobi(trajectory, problem, reason, multipliers, steps)


def _exact(trajectory: Trajectory, structure: Structure) -> Structure:
    """An arc-shooting extremal's own arcs and touch points (its shooting's kinds and junction times), which a
    detection's bands could miss; ``structure`` for another trajectory."""
    from .structure import Arc, Touch
    from .structure import Structure as Arcs

    kinds = getattr(getattr(trajectory, "shooting", None), "kinds", None)
    if kinds is None:
        return structure
    times = np.asarray(trajectory.breakpoints, dtype=float)
    names = trajectory.problem.control_names
    arcs = [
        Arc(names[i], which, float(times[k]), float(times[k + 1]), kind.constraint if which == "boundary" else None)
        for k, kind in enumerate(kinds)
        for i, which in enumerate(kind.kinds)
        if which != "regular" or kind.constraint is not None
    ]
    touches = [Touch(kind.touch, float(times[k])) for k, kind in enumerate(kinds) if kind.touch is not None]
    return Arcs(tuple(arcs), tuple(touches))


def not_convex(problem: OptimalControlProblem, trajectory: Trajectory) -> str | None:
    """Why convexity (module docstring, route 1) is not established for ``problem``, or None where it is."""
    ham = problem.functions.hamiltonian
    x, u, t, P = ham.x, ham.u, ham.t, ham.P
    z = ca.vertcat(x, u)
    if ca.depends_on(ca.jacobian(ham.f, z), z):
        return "the dynamics are not affine in (x, u)"
    for c in problem.controls:
        if getattr(c, "period", None) is not None:
            return f"the control {c.name!r} is an angle"
    P0 = np.asarray(problem.full_parameters, dtype=float).ravel()
    times = np.linspace(trajectory.t0, trajectory.tf, 41)
    X = trajectory.state(times)
    U = trajectory.control(times)
    span_x = np.maximum(np.ptp(X, axis=0), 1.0)
    x_lo, x_hi = X.min(axis=0) - span_x, X.max(axis=0) + span_x
    u_lo = np.array([c.lower if np.isfinite(c.lower) else U[:, i].min() - 1 for i, c in enumerate(problem.controls)])
    u_hi = np.array([c.upper if np.isfinite(c.upper) else U[:, i].max() + 1 for i, c in enumerate(problem.controls)])
    rng = np.random.default_rng(3)

    def convex(expr: ca.SX, symbols: ca.SX, lows: np.ndarray, highs: np.ndarray, what: str) -> str | None:
        hessian = ca.hessian(expr, symbols)[0]
        if ca.depends_on(hessian, symbols):
            return f"{what} is not quadratic in {'(x, u)' if symbols.numel() == z.numel() else 'its arguments'}"
        if ca.depends_on(hessian, t):
            return f"{what} has a Hessian that depends on time (its convexity is not established)"
        H = ca.Function("hessian", [t, P], [hessian])
        for tk in times:
            eig = np.linalg.eigvalsh(np.asarray(H(tk, P0), dtype=float))
            if eig.size and eig.min() < -1e-12 * max(1.0, float(np.abs(eig).max())):
                return f"{what} is not convex (its Hessian has the eigenvalue {eig.min():.3g} at t = {tk:.6g})"
        value = ca.Function("value", [symbols, t, P], [expr])
        for _ in range(200):
            a, b = rng.uniform(lows, highs), rng.uniform(lows, highs)
            tk = rng.uniform(trajectory.t0, trajectory.tf)
            fa, fb, fm = (float(value(v, tk, P0)) for v in (a, b, (a + b) / 2))
            if fm > (fa + fb) / 2 + 1e-12 * (1 + abs(fa) + abs(fb)):
                return f"{what} is not convex (the midpoint inequality fails)"
        return None

    lows, highs = np.concatenate([x_lo, u_lo]), np.concatenate([x_hi, u_hi])
    reason = convex(ham.L, z, lows, highs, "the running cost")
    if reason:
        return reason
    path = problem.functions.path
    if path is not None:
        g = path.function(x, u, t, P)
        for k, label in enumerate(path.labels):
            for bound, sign in ((path.upper[k], 1.0), (path.lower[k], -1.0)):
                if np.isfinite(bound):
                    reason = convex(sign * g[k], z, lows, highs, f"the constraint {label!r}")
                    if reason:
                        return reason
    nx = problem.nx
    X0, XF, T0, TF = ca.SX.sym("x0", nx), ca.SX.sym("xf", nx), ca.SX.sym("t0"), ca.SX.sym("tf")
    ends = ca.vertcat(X0, XF)
    fixed = {T0: float(trajectory.t0), TF: float(trajectory.tf)}

    def at_times(e: ca.SX) -> ca.SX:
        return ca.substitute(ca.substitute(e, T0, fixed[T0]), TF, fixed[TF])

    if problem.phi is not None:
        phi = at_times(problem.phi(X0, XF, T0, TF, P))
        reason = convex(phi, ends, np.concatenate([x_lo, x_lo]), np.concatenate([x_hi, x_hi]), "the Mayer term")
        if reason:
            return reason
    bc = problem.functions.boundary
    if bc is not None:
        psi = at_times(bc.function(X0, XF, T0, TF, P))
        if ca.depends_on(ca.jacobian(psi, ends), ends):
            return "a boundary constraint is not affine"
    return None


def _jacobi(
    trajectory: Trajectory,
    problem: OptimalControlProblem,
    reason: str,
    multipliers: Sequence[float] | np.ndarray | None,
    steps: int,
) -> SecondOrder:
    """Route 2 of the module docstring."""
    if any(s.fixed_initial is None for s in problem.states):
        return SecondOrder("not applicable", "", f"not convex ({reason}), and a free initial state: not derived")
    ham = problem.functions.hamiltonian
    x, p, u, t, P = ham.x, ham.p, ham.u, ham.t, ham.P
    nx = problem.nx
    A, B = ca.jacobian(ham.f, x), ca.jacobian(ham.f, u)
    Hxx, _ = ca.hessian(ham.H, x)
    Hxu = ca.jacobian(ca.gradient(ham.H, x), u)
    Huu, _ = ca.hessian(ham.H, u)
    inverse = ca.inv(Huu)
    Ar = A - B @ inverse @ Hxu.T
    M = ca.vertcat(ca.horzcat(Ar, -B @ inverse @ B.T), ca.horzcat(-Hxx + Hxu @ inverse @ Hxu.T, -Ar.T))
    fun = ca.Function("accessory", [x, p, u, t, P], [ca.vec(M), ca.vec(Huu)])
    grid = np.linspace(trajectory.t0, trajectory.tf, 2 * steps + 1)
    X, L, U = trajectory.state(grid), trajectory.costate(grid), trajectory.control(grid)
    P0 = np.asarray(problem.full_parameters, dtype=float).ravel()
    Ms, Huus = fun.map(grid.size)(X.T, L.T, U.T, grid[None, :], np.repeat(P0[:, None], grid.size, axis=1))
    Ms = np.asarray(Ms, dtype=float).T.reshape(grid.size, 2 * nx, 2 * nx).transpose(0, 2, 1)
    nu = problem.nu
    Huus = np.asarray(Huus, dtype=float).T.reshape(grid.size, nu, nu)
    smallest = np.linalg.eigvalsh(Huus).min(axis=1)
    scale = max(1.0, float(np.abs(Huus).max()))
    k = int(np.argmin(smallest))
    if smallest[k] < -1e-12 * scale:
        return SecondOrder(
            "failed",
            "jacobi",
            f"H_uu has the negative eigenvalue {smallest[k]:.3g} at t = {grid[k]:.6g}: the Legendre-Clebsch "
            "condition fails (not a minimum)",
            margin=float(smallest[k]),
        )
    if smallest[k] <= 1e-12 * scale:
        return SecondOrder(
            "not applicable",
            "",
            f"not convex ({reason}), and H_uu is singular at t = {grid[k]:.6g}: the strengthened Legendre-Clebsch "
            "condition does not hold, and the Jacobi test needs it",
        )
    start = _terminal_fields(trajectory, problem, multipliers)
    if isinstance(start, str):
        return SecondOrder("not applicable", "", f"not convex ({reason}), and {start}")
    dets, bounds = _jacobi_determinants(Ms, start, grid, steps, nx)
    times = grid[::2]
    measure = np.divide(dets, bounds, out=np.zeros_like(dets), where=bounds > 0)  # in [-1, 1]
    if np.max(np.abs(measure[:-1])) < 1e-8:
        return SecondOrder(
            "not applicable",
            "",
            f"not convex ({reason}), and the Jacobi fields' dX is singular on the whole horizon (a degenerate "
            "accessory problem): the test does not apply",
        )
    # at tf, dX has a zero column for each terminal condition: the scan runs on [t0, tf)
    scanned = dets[:-1]
    margin = float(np.min(np.abs(measure[: max(int(0.95 * steps), 1)])))
    crossed = np.flatnonzero(np.sign(scanned[:-1]) * np.sign(scanned[1:]) < 0)
    if crossed.size:
        k = int(crossed[-1])
        a, b = scanned[k], scanned[k + 1]
        tc = float(times[k] - a * (times[k + 1] - times[k]) / (b - a))
        return SecondOrder(
            "failed",
            "jacobi",
            f"a conjugate point at t = {tc:.6g}: a Jacobi field started on the terminal conditions at tf vanishes "
            "there, so a variation lowers the cost (not a minimum)",
            conjugate=tc,
            margin=margin,
        )
    return SecondOrder(
        "passed",
        "jacobi",
        f"H_uu > 0 along (smallest eigenvalue {smallest.min():.3g}) and no conjugate point on [t0, tf) (smallest "
        f"scaled |det dX| on the first 95% of the horizon {margin:.2e})",
        margin=margin,
    )


def _jacobi_determinants(
    Ms: np.ndarray, start: np.ndarray, grid: np.ndarray, steps: int, nx: int
) -> tuple[np.ndarray, np.ndarray]:
    """``det dX`` of the Jacobi fields ``Y = (dX, dP)`` at the times ``grid[::2]``, integrated backwards from
    ``Y(tf) = start`` (``Y' = M Y``, RK4, the matrices ``Ms`` on ``grid``'s half-steps). After each step ``Y`` is
    orthonormalised (QR, ``R`` with a positive diagonal: the span and the sign of ``det dX`` are kept, and no column
    collapses onto the fastest mode); ``dX``'s rows are then scaled by their largest magnitude over the horizon, so
    that the determinant is free of the states' units (its sign, and where it vanishes, are those of the unscaled
    one). Returns the determinants and the products of the scaled columns' norms (Hadamard's bound: their ratio, in
    [-1, 1], measures how far from singular ``dX`` is)."""
    Y = np.array(start, dtype=float)
    h = -(grid[1] - grid[0]) * 2
    blocks = np.empty((steps + 1, nx, nx))
    blocks[steps] = Y[:nx]
    for k in range(steps, 0, -1):
        M1, M2, M3 = Ms[2 * k], Ms[2 * k - 1], Ms[2 * k - 2]
        k1 = M1 @ Y
        k2 = M2 @ (Y + 0.5 * h * k1)
        k3 = M2 @ (Y + 0.5 * h * k2)
        k4 = M3 @ (Y + h * k3)
        Q, R = np.linalg.qr(Y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))
        Y = Q * np.where(np.diag(R) < 0, -1.0, 1.0)
        blocks[k - 1] = Y[:nx]
    rows = np.maximum(np.abs(blocks).max(axis=(0, 2)), 1e-300)
    scaled = blocks / rows[None, :, None]
    norms = np.maximum(np.linalg.norm(scaled, axis=1), 1e-300)
    return np.asarray(np.linalg.det(scaled)), np.prod(norms, axis=1)


def _terminal_fields(
    trajectory: Trajectory, problem: OptimalControlProblem, multipliers: Sequence[float] | np.ndarray | None
) -> np.ndarray | str:
    """``Y(tf)``: the Jacobi fields on the terminal conditions (module docstring), or why they are not derived."""
    nx = problem.nx
    P = problem.functions.hamiltonian.P
    X0, XF, T0, TF = ca.SX.sym("x0", nx), ca.SX.sym("xf", nx), ca.SX.sym("t0"), ca.SX.sym("tf")
    phi = problem.phi(X0, XF, T0, TF, P) if problem.phi is not None else ca.SX(0)
    rows: list[ca.SX] = [XF[i] for i, s in enumerate(problem.states) if s.final is not None]
    if any(s.final is not None and s.fixed_final is None for s in problem.states):
        return "a final state within an interval: not derived"
    bc = problem.functions.boundary
    if bc is not None:
        psi = bc.function(X0, XF, T0, TF, P)
        if ca.depends_on(psi, X0):
            return "a boundary constraint on the initial state: not derived"
        if np.any(bc.lower != bc.upper):
            return "a boundary inequality: not derived"
        curved = any(ca.depends_on(ca.jacobian(psi[k], XF), XF) for k in range(psi.numel()))
        if curved:
            if multipliers is None or len(multipliers) != psi.numel():
                return "a curved boundary constraint whose multipliers the shooting does not give"
            phi = phi + ca.dot(ca.DM(np.asarray(multipliers, dtype=float)), psi)
        rows += [psi[k] for k in range(psi.numel())]
    if ca.depends_on(phi, X0):
        return "a Mayer term on the initial state: not derived"
    G = ca.Function("G", [XF, T0, TF, P], [ca.jacobian(ca.vertcat(*rows), XF) if rows else ca.SX(0, nx)])
    Hphi = ca.Function("Hphi", [XF, T0, TF, P], [ca.hessian(phi, XF)[0]])
    xf = trajectory.state(np.array([trajectory.tf]))[0]
    P0 = np.asarray(problem.full_parameters, dtype=float).ravel()
    args = (xf, trajectory.t0, trajectory.tf, P0)
    Gv = np.asarray(G(*args), dtype=float).reshape(len(rows), nx)
    Hv = np.asarray(Hphi(*args), dtype=float)
    if Gv.shape[0]:
        _, s, vt = np.linalg.svd(Gv)
        rank = int(np.sum(s > 1e-10 * max(1.0, s.max())))
        N = vt[rank:].T
        normals = vt[:rank].T
    else:
        N, normals = np.eye(nx), np.zeros((nx, 0))
    top = np.hstack([N, np.zeros((nx, normals.shape[1]))])
    bottom = np.hstack([Hv @ N, normals])
    return np.vstack([top, bottom])


__all__ = ["VERDICTS", "SecondOrder", "not_convex", "second_order"]
