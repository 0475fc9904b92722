r"""Fifth-degree Gauss-Lobatto collocation (Herman & Conway 1996; Desai & Conway Eqs. 6-7).

On each segment ``[t_i, t_{i+2}]`` of length ``h`` the states are NLP parameters
at ``t_i``, the centre ``t_c`` and ``t_{i+2}``; each state is the quintic Hermite
polynomial through those values and the slopes ``f`` there. The controls are
NLP parameters at ``t_i, t_a, t_c, t_b, t_{i+2}`` with
``t_a, t_b = t_c -/+ (h/2) sqrt(3/7)``. With :math:`s = \sqrt{21}` and :math:`x_e = x_{i+2}`:

.. math::

   x_a &= \tfrac{1}{686} \big[(231 + 39s)\, x_i + 224\, x_c + (231 - 39s)\, x_e
          + h \big((21 + 3s)\, f_i - 16s\, f_c + (3s - 21)\, f_e\big)\big] \\
   x_b &= \tfrac{1}{686} \big[(231 - 39s)\, x_i + 224\, x_c + (231 + 39s)\, x_e
          + h \big((21 - 3s)\, f_i + 16s\, f_c - (21 + 3s)\, f_e\big)\big] \\
   C_1 &= \tfrac{1}{360} \big[(180 + 32s)\, x_i - 64s\, x_c + (32s - 180)\, x_e
          + h \big((9 + s)\, f_i + 98\, f_a + 64\, f_c + (9 - s)\, f_e\big)\big] \\
   C_2 &= \tfrac{1}{360} \big[(180 - 32s)\, x_i + 64s\, x_c - (180 + 32s)\, x_e
          + h \big((9 - s)\, f_i + 98\, f_b + 64\, f_c + (9 + s)\, f_e\big)\big]

and :math:`C_1 = C_2 = 0` are the defect equations. A Lagrange cost uses the five-point Lobatto rule
:math:`h \left[\tfrac{1}{20} L_i + \tfrac{49}{180} L_a + \tfrac{16}{45} L_c + \tfrac{49}{180} L_b
+ \tfrac{1}{20} L_e\right]`.

NLP size for ``nx`` states, ``nu`` controls and ``n`` segments:
``nx (2n+1) + nu (4n+1) (+1 for a free tf)`` parameters and ``2 nx n`` defects.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from .. import nodes
from .._deprecation import renamed, renamed_argument
from ..interpolation import PiecewiseEvaluator, piecewise_polynomial
from ..nlp import Block
from ..program.scheme import PathPoints, PhaseFields, VariableGroup
from ..statement import OptimalControlProblem, unwrap_periodic
from .base import Transcription
from .mesh import Mesh, h_refined

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..program.layout import PhaseLayout


def hlgl_collocation_states(x_i: Any, x_c: Any, x_e: Any, f_i: Any, f_c: Any, f_e: Any, h: Any) -> tuple[Any, Any]:
    """States ``(x_a, x_b)`` at the collocation points: the quintic Hermite interpolant of the nodes."""
    A, B = nodes.HLGL_XA_X, nodes.HLGL_XA_F
    x_a = A[0] * x_i + A[1] * x_c + A[2] * x_e + h * (B[0] * f_i + B[1] * f_c + B[2] * f_e)
    A, B = nodes.HLGL_XB_X, nodes.HLGL_XB_F
    x_b = A[0] * x_i + A[1] * x_c + A[2] * x_e + h * (B[0] * f_i + B[1] * f_c + B[2] * f_e)
    return x_a, x_b


def hlgl_defects(
    x_i: Any, x_c: Any, x_e: Any, f_i: Any, f_a: Any, f_c: Any, f_b: Any, f_e: Any, h: Any
) -> tuple[Any, Any]:
    """Defects ``(C1, C2)`` of Eqs. (6)-(7) from the node states and the slopes at all five points."""
    D, E = nodes.HLGL_C1_X, nodes.HLGL_C1_F
    c1 = D[0] * x_i + D[1] * x_c + D[2] * x_e + h * (E[0] * f_i + E[1] * f_a + E[2] * f_c + E[3] * f_e)
    D, E = nodes.HLGL_C2_X, nodes.HLGL_C2_F
    c2 = D[0] * x_i + D[1] * x_c + D[2] * x_e + h * (E[0] * f_i + E[1] * f_b + E[2] * f_c + E[3] * f_e)
    return c1, c2


def hlgl_segment(
    f: Callable[[Any, Any, Any], Any], x_i: Any, x_c: Any, x_e: Any, u: Sequence[Any], t: Sequence[Any], h: Any
) -> tuple[Any, Any, Any, Any, tuple[Any, Any, Any, Any, Any]]:
    """HLGL defects of one segment (Eqs. 6-7) and the states at the collocation points.

    ``f(x, u, t)`` is the dynamics; ``u`` is a list of the five controls at
    ``t_i, t_a, t_c, t_b, t_e`` and ``t`` the list of those five times.
    Returns ``(C1, C2, x_a, x_b, (f_i, f_a, f_c, f_b, f_e))``. Works on CasADi
    symbols and on numbers.
    """
    f_i, f_c, f_e = f(x_i, u[0], t[0]), f(x_c, u[2], t[2]), f(x_e, u[4], t[4])
    x_a, x_b = hlgl_collocation_states(x_i, x_c, x_e, f_i, f_c, f_e, h)
    f_a, f_b = f(x_a, u[1], t[1]), f(x_b, u[3], t[3])
    c1, c2 = hlgl_defects(x_i, x_c, x_e, f_i, f_a, f_c, f_b, f_e, h)
    return c1, c2, x_a, x_b, (f_i, f_a, f_c, f_b, f_e)


def segment_points(values: np.ndarray, n: int) -> np.ndarray:
    """Values (5, n, d) at the five points of each of ``n`` segments from (4n+1, d) values laid out point by point."""
    return np.stack([values[j : 4 * n : 4] if j < 4 else values[4::4] for j in range(5)])


def hermite_coefficients(x_nodes: np.ndarray, f_nodes: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Monomial coefficients (6, n, nx) of the quintic Hermite interpolant on each segment.

    ``x_nodes`` and ``f_nodes`` have shape (2n+1, nx): values and slopes at the
    state nodes; ``h`` (n,) are the segment lengths.
    """
    n = h.size
    xs = [x_nodes[0 : 2 * n : 2], x_nodes[1 : 2 * n : 2], x_nodes[2::2]]
    fs = [f_nodes[0 : 2 * n : 2], f_nodes[1 : 2 * n : 2], f_nodes[2::2]]
    data = np.stack([xs[0], h[:, None] * fs[0], xs[1], h[:, None] * fs[1], xs[2], h[:, None] * fs[2]])
    return np.einsum("kl,lnd->knd", nodes.hermite_quintic_matrix(), data)


class HLGL(Transcription):
    """Herman-Conway fifth-degree Gauss-Lobatto collocation.

    Parameters
    ----------
    problem : OptimalControlProblem, optional
        The problem this scheme is bound to (then ``HLGL(problem, 20).solve()`` solves it); none for a scheme alone,
        ``HLGL(intervals=20)``, to give a :class:`~ocpkit.program.Program`.
    intervals : int
        Number of equal mesh intervals, Herman & Conway's segments (or give ``mesh``); ``segments`` is its
        deprecated name.
    mesh : ArrayLike, optional
        Segment lengths as positive fractions of ``tf - t0`` (normalised to sum to one).

    Notes
    -----
    NLP variable layout: states node by node (``nx`` per node, ``2n+1`` nodes),
    then controls point by point (``nu`` per point, ``4n+1`` points), then ``tf``
    if it is free. Everything is scaled by the problem's scales.
    """

    def __init__(
        self,
        problem: OptimalControlProblem | int | None = None,
        intervals: int | None = None,
        *,
        mesh: ArrayLike | None = None,
        segments: int | None = None,
    ) -> None:
        if not isinstance(problem, OptimalControlProblem) and problem is not None and intervals is None:
            problem, intervals = None, problem  # HLGL(20): a scheme alone
        super().__init__(problem)  # type: ignore[arg-type]  # (a problem or None, after the shift above)
        intervals = renamed_argument("segments", "intervals", segments, intervals, None, "HLGL")
        self.mesh = Mesh.from_spec(intervals, mesh)
        #: the number of mesh intervals, Herman & Conway's segments (``segments`` is its deprecated name)
        self.intervals = self.mesh.n

    @property
    def segments(self) -> int:
        """Deprecated name of :attr:`intervals`."""
        renamed("HLGL.segments", "HLGL.intervals")
        return self.intervals

    # -- sizes and layout --------------------------------------------------------------
    @property
    def label(self) -> str:
        return f"HLGL(intervals={self.intervals})"

    @property
    def n_state_nodes(self) -> int:
        return 2 * self.intervals + 1

    @property
    def n_control_points(self) -> int:
        return 4 * self.intervals + 1

    def groups(self, problem: OptimalControlProblem) -> tuple[VariableGroup, ...]:
        """States at the ``2n+1`` state nodes, controls at the ``4n+1`` control points."""
        return (
            VariableGroup("states", problem.states, self.state_node_fractions()),
            VariableGroup("controls", problem.controls, self.control_point_fractions()),
        )

    def defect_count(self, problem: OptimalControlProblem) -> int:
        return 2 * problem.nx * self.intervals

    def state_node_fractions(self) -> np.ndarray:
        """Normalised times (0..1) of the 2n+1 state nodes."""
        return self.mesh.points(nodes.HLGL_STATE_NODES[:2])

    def control_point_fractions(self) -> np.ndarray:
        """Normalised times (0..1) of the 4n+1 control points."""
        return self.mesh.points(nodes.HLGL_CONTROL_NODES[:4])

    # -- NLP blocks ----------------------------------------------------------------------
    def _segment_symbols(self, phase: PhaseLayout) -> tuple[ca.SX, ca.SX, list[ca.SX], list[ca.SX], list[Any], Any]:
        """Symbols of one segment: z = [x_i, x_c, x_e, u_0..u_4, problem-wide variables] scaled;
        p = [start, frac, (tf)]."""
        pr = phase.problem
        nx, nu = pr.nx, pr.nu
        z = ca.SX.sym("z", 3 * nx + 5 * nu + phase.times.size)
        p = ca.SX.sym("p", 2 + len(phase.constants))
        xs, us = pr.state_scaling, pr.control_scaling
        x = [xs.from_nlp(z[j * nx : (j + 1) * nx]) for j in range(3)]
        u = [us.from_nlp(z[3 * nx + j * nu : 3 * nx + (j + 1) * nu]) for j in range(5)]
        t_begin, _, h = phase.clock(z, p)
        t = [t_begin + h * s for s in nodes.HLGL_CONTROL_NODES]
        return z, p, x, u, t, h

    def _segment_tables(self, phase: PhaseLayout) -> tuple[np.ndarray, np.ndarray]:
        n = self.intervals
        k = np.arange(n)
        Xi, Ui = phase.table("states"), phase.table("controls")
        rows = [Xi[:, 2 * k], Xi[:, 2 * k + 1], Xi[:, 2 * k + 2]]
        rows += [Ui[:, 4 * k + j] for j in range(5)]
        rows += phase.tail_rows(n)
        return np.vstack(rows), phase.block_constants(self.mesh)

    def blocks(self, phase: PhaseLayout) -> list[Block]:
        """The defects C1, C2 of every segment (Eqs. 6-7) and the five-point Lobatto rule of a running cost."""
        pr = phase.problem
        nx = pr.nx
        n = self.intervals
        variables, params = self._segment_tables(phase)
        z, p, x, u, t, h = self._segment_symbols(phase)
        P = phase.times.P(z)

        def f(x: Any, u: Any, t: Any) -> Any:
            return pr.dynamics(x, u, t, P)

        c1, c2, x_a, x_b, _ = hlgl_segment(f, x[0], x[1], x[2], u, t, h)
        sx = pr.state_scale
        defects = ca.Function("hlgl_defects", [z, p], [ca.vertcat(c1 / sx, c2 / sx)])
        rows = np.arange(2 * nx * n).reshape(n, 2 * nx).T
        blocks = [Block("defects", defects, variables, params, rows)]

        if pr.L is not None:
            xs = [x[0], x_a, x[1], x_b, x[2]]
            quad = h * sum(w * pr.lagrange(xj, uj, tj, P) for w, xj, uj, tj in zip(nodes.HLGL_QUADRATURE, xs, u, t))
            fun = ca.Function("hlgl_lagrange", [z, p], [quad / phase.objective_scale])
            blocks.append(Block("lagrange", fun, variables, params))
        return blocks

    def path_points(self, phase: PhaseLayout) -> list[PathPoints]:
        """Path constraints at the five points of each segment: ``t_i, t_a, t_c, t_b`` of every segment (the
        states at ``t_a, t_b`` from the quintic Hermite interpolant), and the final node once."""
        z, p, x, u, t, h = self._segment_symbols(phase)
        P = phase.times.P(z)
        pr = phase.problem
        _, _, x_a, x_b, _ = hlgl_segment(lambda x, u, t: pr.dynamics(x, u, t, P), x[0], x[1], x[2], u, t, h)
        variables, params = self._segment_tables(phase)
        mesh = self.mesh
        fractions = mesh.starts[:, None] + mesh.fractions[:, None] * nodes.HLGL_CONTROL_NODES[None, :4]
        return [
            PathPoints(z, p, [x[0], x_a, x[1], x_b], u[:4], t[:4], variables, params, fractions),
            PathPoints(z, p, [x[2]], [u[4]], [t[4]], variables[:, -1:], params[:, -1:], np.ones((1, 1))),
        ]

    def control_weights(self, fraction: float) -> tuple[np.ndarray, np.ndarray]:
        """The control at a normalised time: its segment's quartic through the segment's five control points."""
        k = int(np.clip(np.searchsorted(self.mesh.breaks, fraction, side="right") - 1, 0, self.intervals - 1))
        local = (fraction - self.mesh.starts[k]) / self.mesh.fractions[k]
        weights = nodes.lagrange_matrix(nodes.HLGL_CONTROL_NODES, np.array([local]))[0]
        return 4 * k + np.arange(5), weights

    def uniform(self, points: int) -> HLGL:
        """Equal segments, two collocation points each, at least ``points`` in all (rule 10)."""
        return HLGL(self.problem, max(1, -(-int(points) // 2)))

    def refine(self, errors: np.ndarray, tolerance: float, cuts: Sequence[np.ndarray] | None = None) -> HLGL:
        """h-refinement: a segment whose error estimate exceeds ``tolerance`` splits into
        ``ceil((error / tolerance)^(1/6))`` equal segments (2 to 6; HLGL's states converge at about h^6), or,
        where ``cuts`` (per segment, :func:`ocpkit.accuracy.control_switches`) finds the control switching
        inside, at the switches; this scheme where no segment exceeds it."""
        if np.all(np.asarray(errors, dtype=float) <= tolerance):
            return self
        return HLGL(self.problem, mesh=h_refined(self.mesh, errors, tolerance, cuts))

    def defects(self, X: ArrayLike, U: ArrayLike, tf: float | None = None) -> np.ndarray:
        """Defects (2, nx, n) in physical units at given node values, of the problem this scheme is bound to (for
        checks and tests)."""
        program = self.program
        w = program.pack(X, U, tf)
        g = np.asarray(program.nlp.constraint_function(w)).ravel()[: program.n_defects]
        n, nx = self.intervals, program.problem.nx
        return (g.reshape(n, 2, nx) * program.problem.state_scale).transpose(1, 2, 0)

    # -- solution ------------------------------------------------------------------------
    def interpolants(
        self, phase: PhaseLayout, values: Sequence[np.ndarray], problem: OptimalControlProblem, t0: float, tf: float
    ) -> PhaseFields:
        """The quintic Hermite interpolant of the states (values and slopes at the nodes) and each segment's quartic
        through its five controls."""
        X, U = values
        pr = problem
        t_x = t0 + (tf - t0) * self.state_node_fractions()
        t_u = t0 + (tf - t0) * self.control_point_fractions()
        U_nodes = U[0::2] if pr.nu else np.zeros((self.n_state_nodes, 0))
        F = np.asarray(pr.f.map(self.n_state_nodes)(X.T, U_nodes.T, t_x[None, :], pr.parameter_vector())).T
        breaks = t0 + (tf - t0) * self.mesh.breaks
        h = np.diff(breaks)
        states = PiecewiseEvaluator(piecewise_polynomial(breaks, hermite_coefficients(X, F, h)))
        Useg = unwrap_periodic(segment_points(U, self.intervals), pr.controls, axis=0)
        coef = np.einsum("kl,lnd->knd", nodes.monomial_matrix(nodes.HLGL_CONTROL_NODES), Useg)
        controls = PiecewiseEvaluator(piecewise_polynomial(breaks, coef))
        return PhaseFields(t_x, X, t_u, U, breaks, states, controls)

    def costates(
        self, phase: PhaseLayout, multipliers: np.ndarray, t0: float, tf: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Costate estimates from the defect multipliers: ``(times, values)`` at the two collocation points
        ``t_a, t_b`` of every segment, and at t0 and tf by linear extrapolation from the first and the last
        segment's two.

        Each defect of Eqs. (6)-(7) is the collocation defect at an interior Lobatto point weighted by that point's
        quadrature weight, ``C1 = w_a h (f_a - x_H'(t_a))`` (``w_a = 49/180``; ``x_H`` the quintic Hermite
        interpolant; likewise ``C2`` at ``t_b``), so that near ``t_a`` the NLP's Lagrangian reads
        ``w_a h (L_a + nu' f_a) - w_a h nu' x_H'(t_a)``: the multiplier *is* the costate of ``H = L + lambda' f``
        there, the KKT argument of Garg et al. (2010) for Gauss and Radau collocation, whose defects are unweighted
        and whose multipliers are divided by the weight. In the scaled NLP, ``lambda = nu objective_scale /
        state_scale``. The nodes ``t_i, t_c`` collocate nothing and get no estimate (Lobatto nodes' costate
        estimates are the ones reported to oscillate)."""
        pr = phase.problem
        n, nx = self.intervals, pr.nx
        nu = np.asarray(multipliers, dtype=float).ravel()[: 2 * nx * n].reshape(n, 2, nx)
        nu = nu * phase.objective_scale / pr.state_scale
        breaks = t0 + (tf - t0) * self.mesh.breaks
        h = np.diff(breaks)
        ta = breaks[:-1] + h * nodes.HLGL_COLLOCATION[0]
        tb = breaks[:-1] + h * nodes.HLGL_COLLOCATION[1]
        times = np.column_stack([ta, tb]).ravel()
        values = nu.reshape(2 * n, nx)
        first = values[0] + (values[0] - values[1]) * (ta[0] - breaks[0]) / (tb[0] - ta[0])
        last = values[-1] + (values[-1] - values[-2]) * (breaks[-1] - tb[-1]) / (tb[-1] - ta[-1])
        return np.concatenate([[breaks[0]], times, [breaks[-1]]]), np.vstack([first, values, last])
