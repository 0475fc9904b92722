"""Legendre-Gauss-Radau (LGR) pseudospectral collocation, global or multi-interval.

On each mesh interval, mapped to ``tau`` in [-1, 1], the states are NLP
parameters at the ``N`` LGR points ``tau_1 = -1 < ... < tau_N`` (the roots of
``P_{N-1} + P_N``) and at the non-collocated end ``tau_{N+1} = +1``; the
controls at the ``N`` collocation points. With the ``N x (N+1)``
differentiation matrix ``D`` (:func:`ocpkit.nodes.lgr_differentiation_matrix`)
the defects are

    sum_j D_kj X_j - (T_i / 2) f(X_k, U_k, t_k) = 0,     k = 1..N,

``T_i`` the interval's duration. Consecutive intervals share their boundary
state (continuity). A Lagrange cost uses the LGR quadrature
``(T_i / 2) sum_k w_k L_k``. Costates are estimated from the defect multipliers
``Lambda`` as ``lambda_k = Lambda_k / w_k`` at the collocation points and
``lambda_{N+1} = sum_k D_{k,N+1} Lambda_k`` at the end (Garg et al., Automatica
46 (2010) 1843-1851), with the sign of CasADi's Lagrangian ``f + lam_g' g``
flipped to give the Pontryagin costate of ``H = L + lambda' f``.

Global collocation is ``intervals=1`` with many nodes (the blog post uses
N = 100); multi-interval is ``intervals=K`` with a few nodes each.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import cached_property
from typing import TYPE_CHECKING, Any, cast

import casadi as ca
import numpy as np

from .._arrays import unique
from ..nlp import Block
from ..nodes import barycentric_weights, lagrange_matrix, lgr_differentiation_matrix, lgr_nodes, lgr_weights
from ..program.scheme import PathPoints, PhaseFields, VariableGroup
from ..statement import OptimalControlProblem, unwrap_periodic
from .base import Transcription
from .mesh import Mesh

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..program.layout import PhaseLayout
    from ..program.scheme import IpoptOption


class PiecewiseBarycentric:
    """Callable ``t -> values`` (shape ``t.shape + (dim,)``) interpolating per interval in barycentric form."""

    def __init__(self, breaks: ArrayLike, pieces: Sequence[tuple[ArrayLike, ArrayLike]]) -> None:
        """``pieces[i] = (tau, values)``: support points in [-1, 1] and values (n_i, dim) on interval i.

        Beyond an interval's last support point the polynomial is extrapolated (an
        LGR control beyond the last collocation point, up to the interval's end).
        """
        # pieces on the same support points are evaluated together: one Lagrange matrix (and one set of
        # barycentric weights) per group
        groups: dict[bytes, list[int]] = {}
        supports: dict[bytes, np.ndarray] = {}
        for i, (tau, _) in enumerate(pieces):
            tau = np.asarray(tau, float)
            supports.setdefault(tau.tobytes(), tau)
            groups.setdefault(tau.tobytes(), []).append(i)
        self._set(
            breaks,
            len(pieces),
            [
                (supports[key], np.stack([np.asarray(pieces[i][1], float) for i in members]), np.array(members))
                for key, members in groups.items()
            ],
        )

    @classmethod
    def from_rows(
        cls,
        breaks: ArrayLike,
        counts: ArrayLike,
        supports: dict[int, np.ndarray],
        starts: ArrayLike,
        values: ArrayLike,
        per_piece: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> PiecewiseBarycentric:
        """Interval ``i`` interpolating the rows ``values[starts[i] : starts[i] + counts[i]]`` at the support points
        ``supports[counts[i]]`` (one entry for every count): the constructor's pieces gathered by count,
        without a loop over intervals.
        ``per_piece`` maps the pieces' values, stacked ``(pieces, rows, dim)``, piece by piece along axis 1."""
        counts, starts, values = np.asarray(counts), np.asarray(starts), np.asarray(values, float)
        sizes = unique(counts)
        missing = sorted({int(n) for n in sizes} - set(supports))
        if missing:
            raise ValueError(f"no support points given for the piece sizes {missing}")
        groups = []
        for n in sizes:
            members = np.flatnonzero(counts == n)
            stacked = values[starts[members][:, None] + np.arange(int(n))]
            if per_piece is not None:
                stacked = per_piece(stacked)
            groups.append((np.asarray(supports[int(n)], float), stacked, members))
        return cls.__new__(cls)._set(breaks, counts.size, groups)

    def _set(
        self, breaks: ArrayLike, n_pieces: int, groups: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]]
    ) -> PiecewiseBarycentric:
        """``groups``: per set of support points, the points, the stacked values ``(members, n, dim)`` and the
        members' interval numbers."""
        self.breaks = np.asarray(breaks, dtype=float)
        self.n_pieces = n_pieces
        self.dim = groups[0][1].shape[2]
        self._group = np.empty(n_pieces, dtype=np.int64)
        self._slot = np.empty(n_pieces, dtype=np.int64)
        self._groups: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        for g, (tau, stacked, members) in enumerate(groups):
            self._group[members] = g
            self._slot[members] = np.arange(len(members))
            self._groups.append((tau, barycentric_weights(tau), stacked))
        return self

    def __call__(self, t: ArrayLike) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        flat = np.clip(t.ravel(), self.breaks[0], self.breaks[-1])
        out = np.empty((flat.size, self.dim))
        idx = np.clip(np.searchsorted(self.breaks, flat, side="right") - 1, 0, self.n_pieces - 1)
        a, b = self.breaks[idx], self.breaks[idx + 1]
        s = 2.0 * (flat - a) / (b - a) - 1.0
        group = self._group[idx]
        for g, (tau, w, values) in enumerate(self._groups):
            sel = group == g
            if sel.any():
                P = lagrange_matrix(tau, s[sel], w)  # (points, n)
                out[sel] = np.einsum("pj,pjd->pd", P, values[self._slot[idx[sel]]])
        return out.reshape(t.shape + (self.dim,))


class Radau(Transcription):
    """LGR collocation with ``nodes`` collocation points on each of ``intervals`` mesh intervals.

    Parameters
    ----------
    problem : OptimalControlProblem, optional
        The problem this scheme is bound to (then ``Radau(problem, 4, 20).solve()`` solves it); none for a scheme
        alone, ``Radau(nodes=4, intervals=20)``, to give a :class:`~ocpkit.program.Program`.
    nodes : int or Sequence[int]
        Collocation points per interval (at least 2), the same for all or one per interval.
    intervals : int
        Number of equal mesh intervals (default 1: global collocation), or give ``mesh``.
    mesh : ArrayLike, optional
        The intervals' lengths as positive fractions of ``tf - t0`` (normalised to sum to one).

    Notes
    -----
    NLP variable layout: states point by point (``nx`` per point, ``sum N_i + 1``
    points), controls point by point at the collocation points, then tf if free.
    """

    @property
    def ipopt_defaults(self) -> dict[str, IpoptOption]:  # type: ignore[override]  # read-only here, an attribute above
        """MUMPS's AMF ordering, below :data:`~ocpkit.program.program.SHARED_COLUMN_POINTS` collocation points or
        where no free variable is shared by every point (a program with a free t0, tf or parameter at that size
        factorises with QAMD: AMF's time grows much faster than the mesh there). ``benchmarks/bench_orderings.py``
        measures the rule "AMF for one interval, QAMD for several": it picks the faster ordering on 17 of 19
        comparable cases (five problems; several intervals: QAMD 1.3-2.8 times faster) but it is not adopted,
        because the ordering also changes where IPOPT converges: the GTO-GEO transfer's direct solve (notebook 10,
        Radau 4 x 160) converges in 978 iterations under AMF and stops at 3000 under QAMD, the free-flying robot on
        3 x 1000 the other way round. Give ``ipopt_options={"mumps_pivot_order": 6}`` for QAMD at any size;
        :attr:`~ocpkit.Solution.linear_solver` says which ran."""
        return {"mumps_pivot_order": 2}

    def __init__(
        self,
        problem: OptimalControlProblem | int | Sequence[int] | np.ndarray | None = None,
        nodes: int | Sequence[int] | np.ndarray | None = None,
        intervals: int | None = None,
        *,
        mesh: ArrayLike | None = None,
    ) -> None:
        if not isinstance(problem, OptimalControlProblem) and problem is not None:
            problem, nodes, intervals = None, problem, nodes if intervals is None else intervals  # Radau(4, 20)
            if isinstance(intervals, (list, tuple, np.ndarray)):
                raise TypeError("intervals must be an integer")
        nodes = 20 if nodes is None else nodes
        super().__init__(problem)
        if intervals is None and mesh is None:
            intervals = 1
        self.mesh = Mesh.from_spec(intervals, mesh, what="intervals")
        self.intervals = self.mesh.n
        counts = [cast(int, nodes)] * self.intervals if np.ndim(nodes) == 0 else list(cast("Sequence[int]", nodes))
        if len(counts) != self.intervals:
            raise ValueError(f"{len(counts)} node counts given for {self.intervals} intervals")
        self.tau = [lgr_nodes(n) for n in counts]  # validates each count
        self.counts = np.array(counts, dtype=np.int64)
        self.offsets = np.concatenate([[0], np.cumsum(self.counts)[:-1]])

    # -- sizes and layout ---------------------------------------------------------------
    @property
    def label(self) -> str:
        if np.all(self.counts == self.counts[0]):
            return f"Radau(nodes={int(self.counts[0])}, intervals={self.intervals})"
        if self.intervals <= 8:
            return f"Radau(nodes={self.counts.tolist()}, intervals={self.intervals})"
        return (
            f"Radau(nodes={int(self.counts.min())}..{int(self.counts.max())}, intervals={self.intervals}, "
            f"points={self.n_collocation})"
        )

    @property
    def n_collocation(self) -> int:
        return int(self.counts.sum())

    @property
    def n_state_points(self) -> int:
        return self.n_collocation + 1

    def groups(self, problem: OptimalControlProblem) -> tuple[VariableGroup, ...]:
        """States at every collocation point and at the end, controls at the collocation points."""
        fractions = self.state_point_fractions()
        return (
            VariableGroup("states", problem.states, fractions),
            VariableGroup("controls", problem.controls, fractions[:-1]),
        )

    def defect_count(self, problem: OptimalControlProblem) -> int:
        return problem.nx * self.n_collocation

    def state_point_fractions(self) -> np.ndarray:
        """Normalised times (0..1) of the state points: every collocation point, then the final time."""
        return self._state_points

    def _by_degree(self) -> list[tuple[int, np.ndarray, np.ndarray]]:
        """Per degree ``n``: its intervals and their collocation points' positions ``(intervals, n)`` in layout
        order."""
        out = []
        for n in unique(self.counts):
            which = np.flatnonzero(self.counts == n)
            out.append((int(n), which, self.offsets[which][:, None] + np.arange(int(n))))
        return out

    @cached_property
    def _state_points(self) -> np.ndarray:
        points = np.empty(self.n_state_points)
        starts, fractions = self.mesh.starts, self.mesh.fractions
        for n, which, positions in self._by_degree():
            points[positions] = starts[which][:, None] + fractions[which][:, None] * (lgr_nodes(n) + 1) / 2
        points[-1] = 1.0
        points.flags.writeable = False  # shared by every caller
        return points

    def collocation_fractions(self) -> np.ndarray:
        return self.state_point_fractions()[:-1]

    def _collocation_weights(self) -> np.ndarray:
        """LGR weights on [-1, 1] of every collocation point, in layout order."""
        weights = np.empty(self.n_collocation)
        for n, _, positions in self._by_degree():
            weights[positions] = lgr_weights(lgr_nodes(n))
        return weights

    # -- NLP blocks ---------------------------------------------------------------------
    def blocks(self, phase: PhaseLayout) -> list[Block]:
        """The differentiation ``D X`` per degree, ``-(T_i / 2) f`` at every collocation point, and the LGR quadrature
        of a running cost."""
        pr = phase.problem
        nx = pr.nx
        X, U = phase.table("states"), phase.table("controls")
        rows_all = np.arange(self.defect_count(pr)).reshape(self.n_collocation, nx).T  # (nx, points)
        blocks: list[Block] = []

        # D X on the scaled variables: a shift cancels exactly, whatever the rounding of D's row sums
        for n, which, positions in self._by_degree():
            D = lgr_differentiation_matrix(self.tau[which[0]])
            z = ca.SX.sym("z", nx * (n + 1))
            DX = ca.mtimes(ca.reshape(z, nx, n + 1), ca.DM(D.T))  # (nx, n): column k = point k
            fun = ca.Function(f"lgr_D{n}", [z, ca.SX.sym("p", 0)], [ca.vec(DX)])
            points = np.hstack([positions, positions[:, -1:] + 1])  # with each interval's end: (intervals, n + 1)
            var = X[:, points].transpose(1, 2, 0).reshape(which.size, -1).T  # point-major, one column an interval
            rows = rows_all[:, positions].transpose(1, 2, 0).reshape(which.size, -1).T
            linear = np.kron(D, np.eye(nx))  # point-major z and outputs
            blocks.append(Block(f"lgr_differentiation_{n}", fun, var, np.zeros((0, which.size)), rows, linear))

        # -(T_i / 2) f(x_k, u_k, t_k) / scale at every collocation point
        xs = pr.state_scaling
        z, p, x, (u,), t, h = self._point_symbols(phase)
        P = phase.times.P(z)
        half = h / 2
        dyn = ca.Function("lgr_dynamics", [z, p], [-half * pr.dynamics(x, u, t, P) / ca.DM(xs.scale)])
        var = np.vstack([X[:, :-1], U] + phase.tail_rows(self.n_collocation))
        frac = np.repeat(self.mesh.fractions, self.counts)
        params = phase.block_constants(self.mesh, self.collocation_fractions(), frac)
        blocks.append(Block("lgr_dynamics", dyn, var, params, rows_all))

        if pr.L is not None:
            # parameters [s, fraction, (tf), weight]
            q = ca.SX.sym("q", params.shape[0] + 1)
            tq, Tq, _ = phase.clock(z, q)
            L = q[-1] * Tq * q[1] / 2 * pr.lagrange(x, u, tq, P)
            fun = ca.Function("lgr_lagrange", [z, q], [L / phase.objective_scale])
            blocks.append(Block("lagrange", fun, var, np.vstack([params, self._collocation_weights()])))
        return blocks

    def _point_symbols(
        self, phase: PhaseLayout, n_controls: int = 1
    ) -> tuple[ca.SX, ca.SX, ca.SX, list[ca.SX], Any, Any]:
        """Symbols of one point: ``z = [x, u_1..u_n, problem-wide variables]`` (scaled), ``p = [s, fraction,
        (tf)]``; physical ``x``, the ``n`` controls, ``t`` and its interval's length ``h`` in them."""
        pr = phase.problem
        nx, nu = pr.nx, pr.nu
        z = ca.SX.sym("z", nx + n_controls * nu + phase.times.size)
        p = ca.SX.sym("p", 2 + len(phase.constants))
        us = pr.control_scaling
        u = [us.from_nlp(z[nx + k * nu : nx + (k + 1) * nu]) for k in range(n_controls)]
        t, _, h = phase.clock(z, p)
        return z, p, pr.state_scaling.from_nlp(z[:nx]), u, t, h

    def path_points(self, phase: PhaseLayout) -> list[PathPoints]:
        """Path constraints at every collocation point, and at the final time with the last interval's control
        polynomial extrapolated there (the control the solution reports at tf)."""
        pr = phase.problem
        X, U = phase.table("states"), phase.table("controls")
        z, p, x, u, t, _ = self._point_symbols(phase)
        frac = np.repeat(self.mesh.fractions, self.counts)
        colloc = PathPoints(
            z,
            p,
            [x],
            u,
            [t],
            np.vstack([X[:, :-1], U] + phase.tail_rows(self.n_collocation)),
            phase.block_constants(self.mesh, self.collocation_fractions(), frac),
            self.collocation_fractions()[:, None],
        )
        n, o = int(self.counts[-1]), int(self.offsets[-1])
        z, p, x, u, t, _ = self._point_symbols(phase, n)
        ell = lagrange_matrix(self.tau[-1], np.array([1.0]))[0]
        u_end = cast(ca.SX, sum(float(ell[k]) * u[k] for k in range(n))) if pr.nu else ca.SX(0, 1)
        var = np.concatenate([X[:, -1], U[:, o : o + n].T.ravel(), phase.global_indices])
        params = phase.block_constants(self.mesh, np.array([1.0]), self.mesh.fractions[-1:])
        end = PathPoints(z, p, [x], [u_end], [t], var[:, None], params, np.ones((1, 1)))
        return [colloc, end]

    def control_weights(self, fraction: float) -> tuple[np.ndarray, np.ndarray]:
        """The control at a normalised time: its interval's polynomial through the interval's collocation points
        (extrapolated past the last one: at tf, the control the solution reports there)."""
        k = int(np.clip(np.searchsorted(self.mesh.breaks, fraction, side="right") - 1, 0, self.intervals - 1))
        tau = 2.0 * (fraction - self.mesh.starts[k]) / self.mesh.fractions[k] - 1.0
        weights = lagrange_matrix(self.tau[k], np.array([tau]))[0]
        return int(self.offsets[k]) + np.arange(int(self.counts[k])), weights

    #: per interval, its error before the refinement that made this mesh raised its degree, else None (set by
    #: :meth:`refine` on the mesh it returns)
    _raised: list[float | None]

    #: Degree bounds of the ph refinement (Patterson, Hager & Rao 2015), nodes per interval in [N_MIN, N_MAX]
    N_MIN, N_MAX = 3, 12
    #: An interval of at least STALL_NODES nodes whose degree was raised and whose error fell by less than
    #: STALL_FACTOR is split instead (below, a raise can change the solution nearby more than its own error)
    STALL_FACTOR, STALL_NODES = 0.5, 6

    def uniform(self, points: int) -> Radau:
        """Equal intervals of :attr:`N_MIN` nodes, at least ``points`` collocation points in all (rule 10)."""
        return Radau(self.problem, self.N_MIN, max(1, -(-int(points) // self.N_MIN)))

    def refine(self, errors: np.ndarray, tolerance: float, cuts: Sequence[np.ndarray] | None = None) -> Radau:
        """ph-refinement (Patterson, Hager & Rao, OCAM 36 (2015), Sec. 4), with three safeguards.

        On an interval of ``N`` nodes whose error ``e`` exceeds the tolerance, ``P = ceil(log(e / tol) / log N)``
        more nodes; if ``N + P`` exceeds :attr:`N_MAX`, the interval splits into ``max(ceil((N + P) / N_MIN), 2)``
        intervals of :attr:`N_MIN` nodes instead (the solution is not smooth enough there for a higher degree to
        pay). The safeguards:

        * ``cuts`` (per interval, fractions in (0, 1), from :func:`ocpkit.accuracy.control_switches`): an
          interval over the tolerance with a control switching inside is cut there, since no degree resolves a
          corner or a jump; its nodes are shared among the pieces by length (each at least :attr:`N_MIN`), so a
          cut never coarsens (global collocation at N = 60 cut at a switch keeps 60 points or more, instead of
          becoming 4 intervals of 3 nodes); a piece above :attr:`N_MAX` nodes splits by the ph rule next time;
        * an interval of :attr:`STALL_NODES` nodes or more whose degree this refinement raised last time and
          whose error fell by less than :attr:`STALL_FACTOR` is split in two at the same degree (the error does
          not fall with the degree: a non-smooth or singular solution there);
        * an interval never loses nodes, so no mesh has fewer points than the one before.

        Where no interval exceeds the tolerance, this scheme.
        """
        errors = np.asarray(errors, dtype=float)
        over = ~(errors <= tolerance)  # NaN counts as over
        if not over.any():
            return self
        errors = np.where(np.isfinite(errors), errors, 1e3)
        switches = cuts
        cuts = (
            [np.zeros(0)] * self.intervals
            if switches is None
            else [np.asarray(c) if o else np.zeros(0) for c, o in zip(switches, over)]
        )
        raised_before: Any = getattr(self, "_raised", None)
        fractions, origin = self.mesh.split_at(cuts)
        counts: list[int] = []
        out: list[float] = []
        raised: list[float | None] = []
        for k in range(self.intervals):
            pieces = fractions[origin == k]
            e, n = errors[k], int(self.counts[k])
            if pieces.size > 1:
                share = pieces / pieces.sum()
                for f, q in zip(pieces, share):
                    counts.append(max(self.N_MIN, int(np.ceil(n * q))))
                    out.append(f)
                    raised.append(None)
                continue
            f = pieces[0]
            if e <= tolerance:
                counts.append(n)
                out.append(f)
                raised.append(None)
                continue
            stalled = raised_before is not None and raised_before[k] is not None and n >= self.STALL_NODES
            if stalled and e > self.STALL_FACTOR * raised_before[k]:
                counts += [n, n]
                out += [f / 2, f / 2]
                raised += [None, None]
                continue
            wanted = n + max(1, int(np.ceil(np.log(e / tolerance) / np.log(n))))
            if wanted <= self.N_MAX:
                counts.append(wanted)
                out.append(f)
                raised.append(e)
            else:
                pieces = max(int(np.ceil(wanted / self.N_MIN)), 2)
                counts += [self.N_MIN] * pieces
                out += [f / pieces] * pieces
                raised += [None] * pieces
        refined = Radau(self.problem, counts, mesh=out)
        refined._raised = raised  # per interval: its error before this refinement raised its degree, else None
        return refined

    def defects(self, X: ArrayLike, U: ArrayLike, tf: float | None = None) -> np.ndarray:
        """Defects (collocation points, nx) in physical units, in d/dtau form, at given values, of the problem this
        scheme is bound to."""
        program = self.program
        g = np.asarray(program.nlp.constraint_function(program.pack(X, U, tf))).ravel()[: program.n_defects]
        return g.reshape(self.n_collocation, program.problem.nx) * program.problem.state_scale

    # -- solution -------------------------------------------------------------------------
    def costates(
        self, phase: PhaseLayout, multipliers: np.ndarray, t0: float, tf: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Costate estimates at the state points from the defect multipliers (Garg et al. 2010).

        ``lambda_k = -Lambda_k / w_k`` at the collocation points, ``-D_{N+1}' Lambda``
        at each interval's end; ``Lambda`` converted from the scaled NLP to
        physical units (``objective_scale / state_scale``).
        """
        pr = phase.problem
        n_defects = self.defect_count(pr)
        Lam = -np.asarray(multipliers, dtype=float)[:n_defects].reshape(self.n_collocation, pr.nx)
        Lam *= phase.objective_scale / pr.state_scale
        lam = np.empty((self.n_state_points, pr.nx))
        lam[:-1] = Lam / self._collocation_weights()[:, None]
        last = self.offsets[-1]
        D = lgr_differentiation_matrix(self.tau[-1])
        lam[-1] = D[:, -1] @ Lam[last:]
        return t0 + (tf - t0) * self.state_point_fractions(), lam

    def interpolants(
        self, phase: PhaseLayout, values: Sequence[np.ndarray], problem: OptimalControlProblem, t0: float, tf: float
    ) -> PhaseFields:
        """Each interval's barycentric interpolant of the states (the collocation points and its end) and of the
        controls (the collocation points, extrapolated to the interval's end)."""
        X, U = values
        pr = problem
        breaks = t0 + (tf - t0) * self.mesh.breaks
        counts = [int(n) for n in unique(self.counts)]
        x_supports = {n + 1: np.append(lgr_nodes(n), 1.0) for n in counts}
        states = PiecewiseBarycentric.from_rows(breaks, self.counts + 1, x_supports, self.offsets, X)
        t_x = t0 + (tf - t0) * self.state_point_fractions()
        u_supports = {n: lgr_nodes(n) for n in counts}
        periodic = any(c.period is not None for c in pr.controls)  # each interval's controls unwrapped
        unwrapped = (lambda stacked: unwrap_periodic(stacked, pr.controls, axis=1)) if periodic else None
        controls: Any = (
            PiecewiseBarycentric.from_rows(breaks, self.counts, u_supports, self.offsets, U, unwrapped)
            if pr.nu
            else (lambda t: np.zeros(np.shape(t) + (0,)))
        )
        return PhaseFields(
            t_x,
            X,
            t_x[:-1],
            U,
            breaks,
            states,
            controls,
            estimate_points=self.counts + 1,
        )
