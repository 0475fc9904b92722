"""Two-timescale (multi-rate) fifth-degree Gauss-Lobatto collocation (Desai & Conway).

The states are split into slow ``x`` and fast ``z``; ``u`` are the controls.

* Each coarse segment ``[t_i, t_{i+2}]`` (length ``h``) carries the usual HLGL
  nodes for ``x``: ``t_i``, the centre and ``t_{i+2}``.
* It is divided into ``M`` fine segments of length ``h/M``; ``z`` has HLGL nodes
  on every fine segment (``2M + 1`` per coarse segment, ends shared).
* The controls are five NLP parameters per coarse segment at ``s = 0, 1/4, 1/2,
  3/4, 1`` (ends shared) defining a quartic; every other control value the
  defects need is that quartic evaluated there ("two-to-one" and "four-to-one"
  architectures: for M = 2 the five points are the fine nodes, for M = 4 every
  other fine node). With ``control_mesh="fine"`` (beyond the paper, for controls
  that drive the fast states at their rate; with the couplings of :data:`WEAK_COUPLINGS` only)
  there is one quartic per fine segment: ``4M + 1`` control parameters per coarse segment.
* Fine defects (Eqs. 6-7 for ``z`` on each fine segment) need ``x`` at the fine
  centres and fine collocation points: the coarse quintic Hermite polynomial of
  ``x`` (values and slopes at the three coarse nodes), as the paper does.
* The slow defects, by ``coupling`` (how they see the fast states; the NLP's size is the same for all four):

  ``"coarse"`` (the paper's reading)
      Eqs. 6-7 for ``x`` on the coarse segment. The full state at the coarse collocation points is the coarse
      quintic Hermite interpolant of ``(x, z)`` (values and slopes at the coarse nodes).
  ``"fine"``
      The same, with the fast part at the coarse collocation points from the fine Hermite of ``z``.
  ``"quadrature"``
      Integral defects ``x(t_c) - x(t_i) = int f_x`` and ``x(t_{i+2}) - x(t_c) = int f_x``, the integrals by
      :func:`fine_quadrature_weights` over every fine node and fine collocation point, so the slow dynamics
      see the fast states wherever the fine defects do. With ``M = 1`` this is HLGL again (the quintic's
      slope is the quartic through ``f`` at the five points).
  ``"galerkin"``
      Weak defects ``int_0^1 P_m(s) (dx/ds - h f_x) ds = 0`` for the Legendre polynomials ``P_0 = 1`` and
      ``P_1 = 2s - 1`` on the coarse segment, ``x`` its quintic Hermite polynomial, the integrals over every
      fine point by the composite rule of :func:`fine_quadrature_weights`. The multipliers of the two defects
      then stand for a slow costate linear on each coarse segment where ``"quadrature"``'s stand for one
      constant on each half: the fast costate equations see it to high order (notebook 02). With ``M = 1``
      this is HLGL again.

* A Lagrange cost is integrated on the fine grid (:func:`fine_quadrature_weights`), whatever the coupling.

NLP size: ``nx (2N+1) + nz (2MN+1) + nu (4N+1) (+1 for a free tf)`` parameters (``nu (4MN+1)`` controls on
the fine mesh) and ``2 nx N + 2 nz M N`` defects for ``N`` coarse segments.
"""

from __future__ import annotations

from collections.abc import Sequence
from types import SimpleNamespace
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
from .hlgl import hermite_coefficients, hlgl_collocation_states, hlgl_defects, segment_points
from .mesh import Mesh, h_refined

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..program.layout import PhaseLayout

COUPLINGS = ("coarse", "fine", "quadrature", "galerkin")
#: the couplings whose slow defects see the fast states at every fine point (the ones fine controls need)
WEAK_COUPLINGS = ("quadrature", "galerkin")
CONTROL_MESHES = ("coarse", "fine")


def state_partition(
    problem: OptimalControlProblem, slow: Sequence[str] | None = None, fast: Sequence[str] | None = None
) -> tuple[list[int], list[int]]:
    """Indices of the slow and fast states from names; either group may be left to be the complement."""
    names = problem.state_names
    groups: dict[str, list[str]] = {}
    for label, group in (("slow", slow), ("fast", fast)):
        if group is None:
            continue
        if isinstance(group, str):
            raise TypeError(f"{label} states must be a sequence of names, got the string {group!r}")
        group = list(group)
        unknown = [g for g in group if g not in names]
        if unknown:
            raise ValueError(f"{label} states {unknown} are not states of {problem.name!r}; states are {names}")
        dup = sorted({g for g in group if group.count(g) > 1})
        if dup:
            raise ValueError(f"{label} states list {dup} more than once")
        groups[label] = group
    if not groups:
        raise ValueError("name the slow states, the fast states, or both")
    if "slow" in groups and "fast" in groups:
        both = sorted(set(groups["slow"]) & set(groups["fast"]))
        if both:
            raise ValueError(f"states {both} are in both the slow and the fast group")
        missing = [n for n in names if n not in groups["slow"] and n not in groups["fast"]]
        if missing:
            raise ValueError(f"states {missing} are in neither the slow nor the fast group")
    elif "slow" in groups:
        groups["fast"] = [n for n in names if n not in groups["slow"]]
    else:
        groups["slow"] = [n for n in names if n not in groups["fast"]]
    return [names.index(n) for n in groups["slow"]], [names.index(n) for n in groups["fast"]]


def fine_quadrature_weights(ratio: int) -> np.ndarray:
    """Weights (2, 4M + 1) of the integrals over the two halves of a coarse segment (``s`` in [0, 1/2] and
    [1/2, 1], times the coarse length ``h``) of the piecewise quartic through a function's values at every fine
    node and fine collocation point, in the order node, ``a``, centre, ``b`` of each fine segment, then the last node.

    For even ``M`` the halves are whole fine segments and the weights are the composite five-point Gauss-Lobatto
    rule (exact to degree 7 on each fine segment).
    """
    M = int(ratio)
    C = nodes.monomial_matrix(nodes.HLGL_CONTROL_NODES)  # values -> monomial coefficients on [0, 1]
    powers = np.arange(5)

    # of each Lagrange basis polynomial over [lo, hi] of the fine segment
    def integral(lo: float, hi: float) -> np.ndarray:
        return ((hi ** (powers + 1) - lo ** (powers + 1)) / (powers + 1)) @ C

    W = np.zeros((2, 4 * M + 1))
    for j in range(M):
        cut = min(max(M / 2 - j, 0.0), 1.0)  # the coarse centre in this fine segment's local time
        W[0, 4 * j : 4 * j + 5] += integral(0.0, cut) / M
        W[1, 4 * j : 4 * j + 5] += integral(cut, 1.0) / M
    return W


def legendre_weights(ratio: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``"galerkin"`` coupling's weights: ``(W, B)`` with ``W`` (2, 4M + 1) the integrals over the coarse
    segment of ``P_m(s) g(s)`` (``P_0 = 1``, ``P_1 = 2s - 1``) from ``g``'s values at the fine points (the order
    of :func:`fine_quadrature_weights`), and ``B`` (6,) the integral of the quintic Hermite polynomial from its
    node values and scaled slopes (the order of :func:`ocpkit.nodes.hermite_quintic_basis`)."""
    M = int(ratio)
    full = fine_quadrature_weights(M).sum(axis=0)
    s = np.concatenate([(j + nodes.HLGL_CONTROL_NODES[:4]) / M for j in range(M)] + [[1.0]])
    W = np.vstack([full, full * (2.0 * s - 1.0)])
    B = (1.0 / np.arange(1, 7)) @ nodes.hermite_quintic_matrix()
    B[np.abs(B) < 1e-14] = 0.0  # the centre slope's weight is zero (rounding leaves 1e-16)
    return W, B


def _hermite(b: np.ndarray, x_i: Any, d_i: Any, x_c: Any, d_c: Any, x_e: Any, d_e: Any) -> Any:
    """Quintic Hermite value from basis weights ``b`` (6,) and node values/slopes (slopes times h)."""
    return b[0] * x_i + b[1] * d_i + b[2] * x_c + b[3] * d_c + b[4] * x_e + b[5] * d_e


class MultiRateHLGL(Transcription):
    """Two-timescale HLGL collocation: slow states on a coarse mesh, fast states ``ratio`` times finer.

    Parameters
    ----------
    problem : OptimalControlProblem, optional
        The problem this scheme is bound to (then ``MultiRateHLGL(problem, 10, ratio=2, fast=["q"]).solve()`` solves
        it); none for a scheme alone, ``MultiRateHLGL(intervals=10, ratio=2, fast=["q"])``, to give a
        :class:`~ocpkit.program.Program` (the partition's names then name each phase's states).
    intervals : int
        Number of coarse mesh intervals, the paper's coarse segments (or give ``mesh``); ``segments`` is its
        deprecated name.
    ratio : int
        Fine segments per coarse segment, ``M >= 1``.
    slow, fast : Sequence[str], optional
        State names, the partition; give either (the other is its complement) or both.
    coupling : str
        ``"coarse"`` (default, the paper's reading), ``"fine"``, ``"quadrature"`` or ``"galerkin"``: how the slow
        defects see the fast states (module docstring). ``fast_interpolation`` is its deprecated
        name (two of its values are not interpolations).
    control_mesh : str
        ``"coarse"`` (default, the paper's: one quartic per coarse segment) or ``"fine"`` (one quartic
        per fine segment; with the couplings of :data:`WEAK_COUPLINGS` only). Path constraints hold at every
        control point.
    mesh : ArrayLike, optional
        The coarse segments' lengths as positive fractions of ``tf - t0`` (normalised to sum to one).

    Notes
    -----
    NLP variable layout: slow states node by node on the coarse nodes, fast
    states node by node on the fine nodes, controls at their points, then tf.
    """

    def __init__(
        self,
        problem: OptimalControlProblem | int | None = None,
        intervals: int | None = None,
        *,
        ratio: int,
        slow: Sequence[str] | None = None,
        fast: Sequence[str] | None = None,
        coupling: str | None = None,
        control_mesh: str = "coarse",
        mesh: ArrayLike | None = None,
        fast_interpolation: str | None = None,
        segments: int | None = None,
    ) -> None:
        if not isinstance(problem, OptimalControlProblem) and problem is not None and intervals is None:
            problem, intervals = None, problem  # MultiRateHLGL(10, ratio=2, ...): a scheme alone
        super().__init__(problem)  # type: ignore[arg-type]  # (a problem or None, after the shift above)
        intervals = renamed_argument("segments", "intervals", segments, intervals, None, "MultiRateHLGL")
        coupling = renamed_argument(
            "fast_interpolation", "coupling", fast_interpolation, coupling, "coarse", "MultiRateHLGL"
        )
        if isinstance(ratio, bool) or not isinstance(ratio, (int, np.integer)):
            raise TypeError(f"ratio must be an integer, got {ratio!r}")
        if ratio < 1:
            raise ValueError(f"ratio must be at least 1, got {ratio}")
        if coupling not in COUPLINGS:
            raise ValueError(f"coupling must be one of {COUPLINGS}, got {coupling!r}")
        if control_mesh not in CONTROL_MESHES:
            raise ValueError(f"control_mesh must be one of {CONTROL_MESHES}, got {control_mesh!r}")
        if control_mesh == "fine" and coupling not in WEAK_COUPLINGS:
            raise ValueError(
                f'control_mesh="fine" needs coupling in {WEAK_COUPLINGS}: the collocation couplings see '
                "the fast states through Hermite slopes at the coarse nodes, where a fine control is free to differ "
                "from the fast trajectory it drives (the NLP then exploits the difference)"
            )
        self.ratio = int(ratio)
        #: how the slow defects see the fast states (``"coarse"``, ``"fine"``, ``"quadrature"`` or ``"galerkin"``;
        #: ``fast_interpolation`` is its deprecated name)
        self.coupling = coupling
        self.control_mesh = control_mesh
        if slow is None and fast is None:
            raise ValueError("name the slow states, the fast states, or both")
        for which, group in (("slow", slow), ("fast", fast)):
            if isinstance(group, str):
                raise TypeError(f"{which} states must be a sequence of names, got the string {group!r}")
        self._partition_names = (None if slow is None else tuple(slow), None if fast is None else tuple(fast))
        #: the slow and fast states' indices in the bound problem's states (empty for a scheme alone)
        bound = self.problem
        self.slow, self.fast = state_partition(bound, slow, fast) if bound is not None else ([], [])
        self.mesh = Mesh.from_spec(intervals, mesh)
        #: the number of coarse mesh intervals, the paper's coarse segments (``segments`` is its deprecated name)
        self.intervals = self.mesh.n

    @property
    def segments(self) -> int:
        """Deprecated name of :attr:`intervals`."""
        renamed("MultiRateHLGL.segments", "MultiRateHLGL.intervals")
        return self.intervals

    @property
    def fast_interpolation(self) -> str:
        """Deprecated name of :attr:`coupling`."""
        renamed("MultiRateHLGL.fast_interpolation", "MultiRateHLGL.coupling")
        return self.coupling

    def partition(self, problem: OptimalControlProblem) -> tuple[list[int], list[int]]:
        """The slow and fast states' indices in ``problem``'s states (:func:`state_partition` of the names given)."""
        slow, fast = self._partition_names
        return state_partition(problem, slow, fast)

    # -- sizes and layout -------------------------------------------------------------
    @property
    def label(self) -> str:
        if self.problem is not None:
            names = self.problem.state_names
            fast = ",".join(names[i] for i in self.fast)
        else:
            given_slow, given_fast = self._partition_names
            fast = ",".join(given_fast) if given_fast is not None else "all but " + ",".join(given_slow or ())
        extra = "" if self.coupling == "coarse" else f", coupling={self.coupling}"
        extra += ", controls on the fine mesh" if self.control_mesh == "fine" else ""
        return f"MultiRateHLGL(intervals={self.intervals}, ratio={self.ratio}, fast=[{fast}]{extra})"

    @property
    def n_coarse_nodes(self) -> int:
        return 2 * self.intervals + 1

    @property
    def n_fine_nodes(self) -> int:
        return 2 * self.ratio * self.intervals + 1

    @property
    def control_quartics(self) -> int:
        """Control quartics per coarse segment (1, or ``M`` with the controls on the fine mesh)."""
        return self.ratio if self.control_mesh == "fine" else 1

    @property
    def n_control_points(self) -> int:
        return 4 * self.control_quartics * self.intervals + 1

    def groups(self, problem: OptimalControlProblem) -> tuple[VariableGroup, ...]:
        """Slow states at the coarse nodes, fast states at the fine nodes, controls at their points."""
        slow, fast = self.partition(problem)
        return (
            VariableGroup("slow states", tuple(problem.states[i] for i in slow), self.coarse_node_fractions()),
            VariableGroup("fast states", tuple(problem.states[i] for i in fast), self.fine_node_fractions()),
            VariableGroup("controls", problem.controls, self.control_point_fractions()),
        )

    def defect_count(self, problem: OptimalControlProblem) -> int:
        slow, fast = self.partition(problem)
        return 2 * self.intervals * (len(slow) + self.ratio * len(fast))

    def coarse_node_fractions(self) -> np.ndarray:
        """Normalised times (0..1) of the 2N+1 coarse (slow-state) nodes."""
        return self.mesh.points(nodes.HLGL_STATE_NODES[:2])

    def fine_node_fractions(self) -> np.ndarray:
        """Normalised times (0..1) of the 2MN+1 fine (fast-state) nodes."""
        return self.mesh.points(np.arange(2 * self.ratio) / (2 * self.ratio))

    def control_point_fractions(self) -> np.ndarray:
        """Normalised times (0..1) of the control points (4N+1, or 4MN+1 on the fine mesh)."""
        q = self.control_quartics
        return self.mesh.points(np.arange(4 * q) / (4 * q))

    # -- NLP blocks -------------------------------------------------------------------
    @staticmethod
    def _full_state(slow: Sequence[int], fast: Sequence[int], x: Sequence[Any], z: Sequence[Any]) -> ca.SX:
        """Assemble the full state vector (problem order) from slow and fast parts."""
        parts: list[Any] = [None] * (len(slow) + len(fast))
        for j, i in enumerate(slow):
            parts[i] = x[j]
        for j, i in enumerate(fast):
            parts[i] = z[j]
        return ca.vertcat(*parts)

    def _segment_symbols(
        self, phase: PhaseLayout
    ) -> tuple[ca.SX, ca.SX, list[ca.SX], list[ca.SX], list[ca.SX], Any, Any]:
        """Symbols of one coarse segment, ``w`` (its NLP variables, the layout of :meth:`_segment_tables`) and
        ``p``, and in them the slow nodes ``X`` (3), fast nodes ``Z`` (2M + 1), controls ``U`` (4q + 1, q quartics),
        start and length."""
        pr = phase.problem
        M = self.ratio
        slow, fast = self.partition(pr)
        nxs, nzf, nu = len(slow), len(fast), pr.nu
        nup = 4 * self.control_quartics + 1
        w = ca.SX.sym("w", 3 * nxs + (2 * M + 1) * nzf + nup * nu + phase.times.size)
        p = ca.SX.sym("p", 2 + len(phase.constants))
        xsc, zsc = pr.state_scaling.subset(slow), pr.state_scaling.subset(fast)
        off = 0
        X = [xsc.from_nlp(w[off + k * nxs : off + (k + 1) * nxs]) for k in range(3)]
        off += 3 * nxs
        Z = [zsc.from_nlp(w[off + k * nzf : off + (k + 1) * nzf]) for k in range(2 * M + 1)]
        off += (2 * M + 1) * nzf
        U = [pr.control_scaling.from_nlp(w[off + k * nu : off + (k + 1) * nu]) for k in range(nup)]
        t_start, _, h = phase.clock(w, p)
        return w, p, X, Z, U, t_start, h

    def path_points(self, phase: PhaseLayout) -> list[PathPoints]:
        """Path constraints at every control point (``4q + 1`` per coarse segment, the last once): the controls are
        NLP values there, the fast states NLP values or their fine Hermite polynomial, the slow states NLP values
        or their coarse Hermite polynomial."""
        q = self.control_quartics
        m = self._segment_model(phase)
        slow, fast = self.partition(phase.problem)
        s = np.arange(4 * q + 1) / (4 * q)
        full = [self._full_state(slow, fast, ca.vertsplit(m.x_at(sk)), ca.vertsplit(m.z_fine_at(sk))) for sk in s]
        t = [m.t_start + m.h * sk for sk in s]
        variables, params = self._segment_tables(phase)
        mesh = self.mesh
        fractions = mesh.starts[:, None] + mesh.fractions[:, None] * s[None, :-1]
        last = (variables[:, -1:], params[:, -1:], np.ones((1, 1)))
        return [
            PathPoints(m.w, m.p, full[:-1], m.U[:-1], t[:-1], variables, params, fractions),
            PathPoints(m.w, m.p, [full[-1]], [m.U[-1]], [t[-1]], *last),
        ]

    def _segment_model(self, phase: PhaseLayout) -> SimpleNamespace:
        """One coarse segment's symbols (:meth:`_segment_symbols`) and the pieces every expression of it uses: the
        control ``u_at(s)``, the dynamics ``f(x, z, s)`` and ``split`` of their value into slow and fast parts, the
        full dynamics at the coarse nodes (``Fc``) and at the fine nodes (``F_nodes``, the fast part ``fz_nodes``),
        the slow states' coarse Hermite ``x_at(s)``, and the fast states' fine Hermite ``z_fine_at(s)`` (the fine
        segment holding ``s``) and coarse Hermite ``z_coarse_at(s)`` (values and slopes at the coarse nodes)."""
        pr = phase.problem
        M = self.ratio
        nu = pr.nu
        slow, fast = self.partition(pr)
        w, p, X, Z, U, t_start, h = self._segment_symbols(phase)
        P = phase.times.P(w)
        q = self.control_quartics

        def u_at(s: float) -> Any:
            if nu == 0:
                return ca.SX(0, 1)
            j = min(int(np.floor(s * q)), q - 1)  # the quartic containing s
            L = nodes.lagrange_matrix(nodes.EQUISPACED_CONTROL_NODES, np.array([s * q - j]))[0]
            return sum(float(L[k]) * U[4 * j + k] for k in range(5) if L[k] != 0.0)

        def f(x: ca.SX, z: ca.SX, s: float) -> Any:
            return pr.dynamics(
                self._full_state(slow, fast, ca.vertsplit(x), ca.vertsplit(z)), u_at(s), t_start + h * s, P
            )

        def split(fv: ca.SX) -> tuple[ca.SX, ca.SX]:
            return fv[slow], fv[fast]

        # coarse nodes: x params, z at fine nodes 0, M, 2M
        zc = [Z[0], Z[M], Z[2 * M]]
        Fc = [f(X[k], zc[k], s) for k, s in enumerate(nodes.HLGL_STATE_NODES)]
        fx_c = [split(F)[0] for F in Fc]
        fz_c = [split(F)[1] for F in Fc]

        def x_at(s: float) -> Any:
            b = nodes.hermite_quintic_basis(np.array([s]))[0]
            return _hermite(b, X[0], h * fx_c[0], X[1], h * fx_c[1], X[2], h * fx_c[2])

        # fine nodes: x from the coarse Hermite where it is not a parameter
        hf = h / M
        fine_s = np.arange(2 * M + 1) / (2 * M)
        F_nodes = [Fc[k // M] if k % M == 0 else f(x_at(s), Z[k], s) for k, s in enumerate(fine_s)]
        fz_nodes = [split(F)[1] for F in F_nodes]

        def z_fine_at(s: float) -> Any:
            j = min(int(np.floor(s * M)), M - 1)  # fine segment containing s
            b = nodes.hermite_quintic_basis(np.array([s * M - j]))[0]
            i = 2 * j
            return _hermite(b, Z[i], hf * fz_nodes[i], Z[i + 1], hf * fz_nodes[i + 1], Z[i + 2], hf * fz_nodes[i + 2])

        def z_coarse_at(s: float) -> Any:
            b = nodes.hermite_quintic_basis(np.array([s]))[0]
            return _hermite(b, zc[0], h * fz_c[0], zc[1], h * fz_c[1], zc[2], h * fz_c[2])

        return SimpleNamespace(
            **dict(w=w, p=p, X=X, Z=Z, U=U, t_start=t_start, h=h, P=P, u_at=u_at, f=f, split=split),
            **dict(zc=zc, Fc=Fc, fx_c=fx_c, fz_c=fz_c, x_at=x_at, F_nodes=F_nodes, fz_nodes=fz_nodes),
            **dict(z_fine_at=z_fine_at, z_coarse_at=z_coarse_at),
        )

    def _segment_expressions(self, phase: PhaseLayout) -> tuple[ca.SX, ca.SX, ca.SX, Any]:
        """Symbols and expressions of one coarse segment (defects and the quadrature of a Lagrange cost)."""
        pr = phase.problem
        M = self.ratio
        slow, fast = self.partition(pr)
        nxs, nzf = len(slow), len(fast)
        m = self._segment_model(phase)
        w, p, X, Z, t_start, h, P = m.w, m.p, m.X, m.Z, m.t_start, m.h, m.P
        u_at, f, split, fx_c, x_at = m.u_at, m.f, m.split, m.fx_c, m.x_at
        F_nodes, fz_nodes = m.F_nodes, m.fz_nodes
        sx = pr.state_scaling.subset(slow).scale
        sz = pr.state_scaling.subset(fast).scale
        hf = h / M

        # fine collocation points: z from each fine segment's Hermite, x from the coarse one
        sa, sb = nodes.HLGL_COLLOCATION
        fine_colloc = []  # per fine segment: (z_a, F_a, z_b, F_b)
        for j in range(M):
            i = 2 * j
            za_f, zb_f = hlgl_collocation_states(
                Z[i], Z[i + 1], Z[i + 2], fz_nodes[i], fz_nodes[i + 1], fz_nodes[i + 2], hf
            )
            s_a, s_b = (j + sa) / M, (j + sb) / M
            fine_colloc.append((za_f, f(x_at(s_a), za_f, s_a), zb_f, f(x_at(s_b), zb_f, s_b)))

        defects = []
        if self.coupling in WEAK_COUPLINGS:
            # slow states: weak defects, the slow dynamics integrated over every fine node and collocation point
            F_all = []
            for j in range(M):
                F_all += [F_nodes[2 * j], fine_colloc[j][1], F_nodes[2 * j + 1], fine_colloc[j][3]]
            F_all.append(F_nodes[2 * M])
            fx_all = [split(F)[0] for F in F_all] if nxs else []

            def integral(weights: np.ndarray) -> Any:
                return sum(float(wk) * fk for wk, fk in zip(weights, fx_all) if wk != 0.0)

            if nxs and self.coupling == "quadrature":
                W = fine_quadrature_weights(M)
                for half in range(2):
                    defects.append((X[half + 1] - X[half] - h * integral(W[half])) / sx)
            elif nxs:
                W, B = legendre_weights(M)
                x_mean = _hermite(B, X[0], h * fx_c[0], X[1], h * fx_c[1], X[2], h * fx_c[2])
                defects.append((X[2] - X[0] - h * integral(W[0])) / sx)  # P_0: int dx/ds = x_e - x_i
                defects.append((X[2] + X[0] - 2.0 * x_mean - h * integral(W[1])) / sx)  # P_1, by parts
        else:
            z_at_coarse_colloc = m.z_coarse_at if self.coupling == "coarse" else m.z_fine_at
            xa, xb = x_at(sa), x_at(sb)
            za, zb = z_at_coarse_colloc(sa), z_at_coarse_colloc(sb)
            Fa, Fb = f(xa, za, sa), f(xb, zb, sb)
            if nxs:
                c1, c2 = hlgl_defects(X[0], X[1], X[2], fx_c[0], split(Fa)[0], fx_c[1], split(Fb)[0], fx_c[2], h)
                defects += [c1 / sx, c2 / sx]
        # fine defects for z
        if nzf:
            for j in range(M):
                i = 2 * j
                _, Fa_j, _, Fb_j = fine_colloc[j]
                c1, c2 = hlgl_defects(
                    Z[i],
                    Z[i + 1],
                    Z[i + 2],
                    fz_nodes[i],
                    split(Fa_j)[1],
                    fz_nodes[i + 1],
                    split(Fb_j)[1],
                    fz_nodes[i + 2],
                    hf,
                )
                defects += [c1 / sz, c2 / sz]

        quad = None
        if pr.L is not None:

            def lagrange(s: float, x: Any, z: Any) -> Any:
                full = self._full_state(slow, fast, ca.vertsplit(x), ca.vertsplit(z))
                return pr.lagrange(full, u_at(s), t_start + h * s, P)

            # on the fine grid, whatever the coupling: the running cost sees the fast states and the controls at
            # every fine node and collocation point (composite five-point Lobatto rule on each fine segment)
            W = fine_quadrature_weights(M).sum(axis=0)
            pts = []
            for j in range(M):
                za_f, _, zb_f, _ = fine_colloc[j]
                s0, sm, s_a, s_b = j / M, (j + 0.5) / M, (j + sa) / M, (j + sb) / M
                pts += [(s0, Z[2 * j]), (s_a, za_f), (sm, Z[2 * j + 1]), (s_b, zb_f)]
            pts.append((1.0, Z[2 * M]))
            quad = h * sum(float(wq) * lagrange(s, x_at(s), z) for wq, (s, z) in zip(W, pts))
        return w, p, ca.vertcat(*defects), quad

    def _segment_tables(self, phase: PhaseLayout) -> tuple[np.ndarray, np.ndarray]:
        N, M = self.intervals, self.ratio
        k = np.arange(N)
        X, Z, U = (phase.table(name) for name in ("slow states", "fast states", "controls"))
        rows = [X[:, 2 * k + j] for j in range(3)]
        rows += [Z[:, 2 * M * k + j] for j in range(2 * M + 1)]
        q = self.control_quartics
        rows += [U[:, 4 * q * k + j] for j in range(4 * q + 1)]
        rows += phase.tail_rows(N)
        return np.vstack(rows), phase.block_constants(self.mesh)

    def blocks(self, phase: PhaseLayout) -> list[Block]:
        """Every coarse segment's slow and fine defects (the module docstring) and its running cost on the fine
        grid."""
        w, p, defects, quad = self._segment_expressions(phase)
        variables, params = self._segment_tables(phase)
        per = defects.shape[0]
        rows = np.arange(per * self.intervals).reshape(self.intervals, per).T
        blocks = [Block("multirate_defects", ca.Function("mr_defects", [w, p], [defects]), variables, params, rows)]
        if quad is not None:
            fun = ca.Function("mr_lagrange", [w, p], [quad / phase.objective_scale])
            blocks.append(Block("lagrange", fun, variables, params))
        return blocks

    def control_weights(self, fraction: float) -> tuple[np.ndarray, np.ndarray]:
        """The control at a normalised time: its quartic through five equally spaced control points."""
        q = self.control_quartics
        k = int(np.clip(np.searchsorted(self.mesh.breaks, fraction, side="right") - 1, 0, self.intervals - 1))
        local = (fraction - self.mesh.starts[k]) / self.mesh.fractions[k]
        j = min(int(np.floor(local * q)), q - 1)
        weights = nodes.lagrange_matrix(nodes.EQUISPACED_CONTROL_NODES, np.array([local * q - j]))[0]
        return 4 * q * k + 4 * j + np.arange(5), weights

    def defects(self, X_slow: ArrayLike, Z_fast: ArrayLike, U: ArrayLike, tf: float | None = None) -> np.ndarray:
        """All defects (physical units), in NLP row order, at given parameter values, of the problem this scheme is
        bound to."""
        program = self.program
        g = np.asarray(program.nlp.constraint_function(program.pack(X_slow, Z_fast, U, tf))).ravel()
        g = g[: program.n_defects]
        per = g.size // self.intervals
        scale = np.concatenate(
            [program.problem.state_scale[self.slow]] * (2 if self.slow else 0)
            + [program.problem.state_scale[self.fast]] * (2 * self.ratio if self.fast else 0)
        )
        return (g.reshape(self.intervals, per) * scale).T

    # -- solution ---------------------------------------------------------------------
    def interpolants(
        self, phase: PhaseLayout, values: Sequence[np.ndarray], problem: OptimalControlProblem, t0: float, tf: float
    ) -> PhaseFields:
        """The slow states' coarse quintic Hermite interpolant, the fast states' fine one (slopes from the full
        state), each quartic of the controls; the error estimate on the fine segments."""
        Xs, Zf, U = values
        pr = problem
        slow, fast = self.partition(pr)
        N, M = self.intervals, self.ratio
        t_c = t0 + (tf - t0) * self.coarse_node_fractions()
        t_f = t0 + (tf - t0) * self.fine_node_fractions()
        t_u = t0 + (tf - t0) * self.control_point_fractions()
        breaks = t0 + (tf - t0) * self.mesh.breaks
        h = np.diff(breaks)

        nq = N * self.control_quartics
        U_seg = unwrap_periodic(segment_points(U, nq), pr.controls, axis=0)
        ucoef = np.einsum("kl,lnd->knd", nodes.monomial_matrix(nodes.EQUISPACED_CONTROL_NODES), U_seg)
        control_breaks = breaks if self.control_quartics == 1 else t_u[::4]
        controls = PiecewiseEvaluator(piecewise_polynomial(control_breaks, ucoef))

        def rhs(times: np.ndarray, full: np.ndarray) -> np.ndarray:
            return np.asarray(pr.f.map(times.size)(full.T, controls(times).T, times[None, :], pr.parameter_vector())).T

        # slow states: coarse Hermite with slopes from the full state at the coarse nodes
        full_c = np.empty((t_c.size, pr.nx))
        full_c[:, slow] = Xs
        full_c[:, fast] = Zf[::M]
        Fc = rhs(t_c, full_c)
        slow_pp = PiecewiseEvaluator(piecewise_polynomial(breaks, hermite_coefficients(Xs, Fc[:, slow], h)))
        # fast states: fine Hermite with slopes from the slow interpolant at the fine nodes
        full_f = np.empty((t_f.size, pr.nx))
        full_f[:, slow] = slow_pp(t_f) if slow else np.zeros((t_f.size, 0))
        full_f[:, fast] = Zf
        fine_breaks = t_f[::2]
        Ff = rhs(t_f, full_f)
        fast_pp = PiecewiseEvaluator(
            piecewise_polynomial(fine_breaks, hermite_coefficients(Zf, Ff[:, fast], np.diff(fine_breaks)))
        )

        slow_idx, fast_idx = list(slow), list(fast)

        def states(t: ArrayLike) -> np.ndarray:
            t = np.asarray(t, dtype=float)
            out = np.empty(t.shape + (pr.nx,))
            if slow_idx:
                out[..., slow_idx] = slow_pp(t)
            if fast_idx:
                out[..., fast_idx] = fast_pp(t)
            return out

        return PhaseFields(t_f, states(t_f), t_u, U, breaks, states, controls, estimate_breakpoints=fine_breaks)

    def uniform(self, points: int) -> MultiRateHLGL:
        """Equal coarse segments, two slow collocation points each, at least ``points`` in all, with this scheme's
        ratio, partition and coupling (rule 10)."""
        slow, fast = self._partition_names
        return MultiRateHLGL(
            self.problem,
            max(1, -(-int(points) // 2)),
            ratio=self.ratio,
            slow=slow,
            fast=fast,
            coupling=self.coupling,
            control_mesh=self.control_mesh,
        )

    def refine(self, errors: np.ndarray, tolerance: float, cuts: Sequence[np.ndarray] | None = None) -> MultiRateHLGL:
        """h-refinement of the coarse mesh: ``errors`` (and ``cuts``) are per fine segment (the solution's
        estimate intervals); a coarse segment whose worst fine segment exceeds ``tolerance`` refines as
        :meth:`HLGL.refine <ocpkit.transcription.hlgl.HLGL.refine>` does; this scheme where none does."""
        coarse = np.asarray(errors, dtype=float).reshape(self.intervals, self.ratio).max(axis=1)
        if np.all(coarse <= tolerance):
            return self
        coarse_switches = None
        if cuts is not None:
            coarse_switches = [
                np.concatenate([(j + np.asarray(cuts[k * self.ratio + j])) / self.ratio for j in range(self.ratio)])
                for k in range(self.intervals)
            ]
        slow, fast = self._partition_names
        return MultiRateHLGL(
            self.problem,
            ratio=self.ratio,
            slow=slow,
            fast=fast,
            coupling=self.coupling,
            control_mesh=self.control_mesh,
            mesh=h_refined(self.mesh, coarse, tolerance, coarse_switches),
        )


def __getattr__(name: str) -> tuple[str, ...]:
    if name == "FAST_INTERPOLATIONS":
        renamed("ocpkit.transcription.multirate.FAST_INTERPOLATIONS", "COUPLINGS")
        return COUPLINGS
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
