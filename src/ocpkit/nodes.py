"""Collocation nodes, quadrature weights, interpolation and differentiation.

All segment-local quantities use the normalised time ``s = (t - t_i) / h`` in
[0, 1], where ``h = t_{i+2} - t_i`` is the segment length (Desai & Conway's
indexing: a segment runs from node ``i`` through the centre ``i+1`` to
``i+2``).
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

SQRT21 = np.sqrt(21.0)

# -- Fifth-degree Gauss-Lobatto (Herman & Conway 1996; Desai & Conway Eqs. 6-7) ------

HLGL_STATE_NODES = np.array([0.0, 0.5, 1.0])
"""Normalised times of the three state nodes of a segment, t_i, t_c and t_{i+2}."""

HLGL_COLLOCATION = np.array([0.5 - 0.5 * np.sqrt(3.0 / 7.0), 0.5 + 0.5 * np.sqrt(3.0 / 7.0)])
"""Normalised collocation points s_a, s_b = 1/2 -/+ sqrt(3/7)/2 (interior Lobatto points)."""

HLGL_CONTROL_NODES = np.array([0.0, HLGL_COLLOCATION[0], 0.5, HLGL_COLLOCATION[1], 1.0])
"""Normalised times of the five control parameters of a segment, t_i, t_a, t_c, t_b and t_{i+2}."""

HLGL_QUADRATURE = np.array([1 / 20, 49 / 180, 16 / 45, 49 / 180, 1 / 20])
"""Five-point Gauss-Lobatto weights on [0, 1] at :data:`HLGL_CONTROL_NODES` (exact to degree 7)."""

# Interpolated states at the collocation points (the quintic Hermite polynomial
# through x and h*f at the three nodes):  x_a = A_x . (x_i, x_c, x_e) + h A_f . (f_i, f_c, f_e)
HLGL_XA_X = np.array([231 + 39 * SQRT21, 224.0, 231 - 39 * SQRT21]) / 686
HLGL_XA_F = np.array([21 + 3 * SQRT21, -16 * SQRT21, 3 * SQRT21 - 21]) / 686
HLGL_XB_X = np.array([231 - 39 * SQRT21, 224.0, 231 + 39 * SQRT21]) / 686
HLGL_XB_F = np.array([21 - 3 * SQRT21, 16 * SQRT21, -(21 + 3 * SQRT21)]) / 686

# Defects (Eqs. 6-7):  C1 = D_x . (x_i, x_c, x_e) + h D_f . (f_i, f_a, f_c, f_e)
HLGL_C1_X = np.array([180 + 32 * SQRT21, -64 * SQRT21, 32 * SQRT21 - 180]) / 360
HLGL_C1_F = np.array([9 + SQRT21, 98.0, 64.0, 9 - SQRT21]) / 360  # (f_i, f_a, f_c, f_e)
HLGL_C2_X = np.array([180 - 32 * SQRT21, 64 * SQRT21, -(180 + 32 * SQRT21)]) / 360
HLGL_C2_F = np.array([9 - SQRT21, 98.0, 64.0, 9 + SQRT21]) / 360  # (f_i, f_b, f_c, f_e)


def hermite_quintic_matrix() -> np.ndarray:
    """Map ``(x_i, x_i', x_c, x_c', x_e, x_e')`` (derivatives w.r.t. s) to monomial coefficients.

    Returns the 6x6 matrix ``M`` such that ``p(s) = sum_k (M @ data)[k] s^k`` is the
    quintic Hermite interpolant through values and slopes at s = 0, 1/2, 1.
    """
    rows = []
    for s in HLGL_STATE_NODES:
        rows.append([s**k for k in range(6)])
        rows.append([k * s ** (k - 1) if k else 0.0 for k in range(6)])
    return np.linalg.inv(np.array(rows))


def hermite_quintic_basis(s: ArrayLike) -> np.ndarray:
    """Weights ``b(s)`` (shape ``s.shape + (6,)``) with ``p(s) = b(s) . (x_i, x_i', x_c, x_c', x_e, x_e')``.

    ``p`` is the quintic Hermite interpolant of :func:`hermite_quintic_matrix`;
    at the nodes themselves the weights are exactly 0 and 1.
    """
    s = np.asarray(s, dtype=float)
    b = np.stack([s**k for k in range(6)], axis=-1) @ hermite_quintic_matrix()
    for j, node in enumerate(HLGL_STATE_NODES):
        at = s == node
        b[at] = 0.0
        b[at, 2 * j] = 1.0
    return b


EQUISPACED_CONTROL_NODES = np.linspace(0.0, 1.0, 5)
"""Normalised times of the five control parameters per coarse segment of the two-timescale scheme."""


def monomial_matrix(nodes: np.ndarray) -> np.ndarray:
    """Map values at ``nodes`` (in [0, 1]) to the monomial coefficients of their interpolant."""
    nodes = np.asarray(nodes, dtype=float)
    return np.linalg.inv(np.vander(nodes, increasing=True))


# -- Barycentric Lagrange interpolation ---------------------------------------------


def barycentric_weights(nodes: np.ndarray) -> np.ndarray:
    """Barycentric weights ``w_j = 1 / prod_{k != j} (x_j - x_k)`` (Berrut & Trefethen 2004)."""
    x = np.asarray(nodes, dtype=float)
    diff = x[:, None] - x[None, :]
    np.fill_diagonal(diff, 1.0)
    # Scale to avoid overflow for many nodes; the interpolant is invariant to it.
    w = 1.0 / np.prod(diff * (4.0 / (x.max() - x.min() if x.size > 1 else 1.0)), axis=1)
    return w / np.abs(w).max()


def lagrange_matrix(nodes: np.ndarray, points: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Matrix ``P`` with ``P[i, j] = l_j(points[i])``, the Lagrange basis of ``nodes``.

    Evaluated in barycentric form, exact (to rounding) where a point coincides
    with a node. ``weights``: the nodes' :func:`barycentric_weights`, if already at hand.
    """
    x = np.asarray(nodes, dtype=float)
    p = np.atleast_1d(np.asarray(points, dtype=float))
    w = barycentric_weights(x) if weights is None else weights
    diff = p[:, None] - x[None, :]
    exact = diff == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = w[None, :] / diff
        P = terms / terms.sum(axis=1, keepdims=True)
    rows = exact.any(axis=1)
    P[rows] = exact[rows].astype(float)
    return P


def differentiation_matrix(nodes: np.ndarray) -> np.ndarray:
    """Square matrix ``D`` with ``(D v)_i = p'(nodes_i)`` for the interpolant ``p`` of ``v``."""
    x = np.asarray(nodes, dtype=float)
    w = barycentric_weights(x)
    diff = x[:, None] - x[None, :]
    np.fill_diagonal(diff, 1.0)
    D = (w[None, :] / w[:, None]) / diff
    np.fill_diagonal(D, 0.0)
    np.fill_diagonal(D, -D.sum(axis=1))
    return D


# -- Legendre-Gauss-Radau (LGR) ----------------------------------------------------------


def _legendre(n: int, x: np.ndarray) -> np.ndarray:
    """P_n(x) by the three-term recurrence."""
    x = np.asarray(x, dtype=float)
    p0, p1 = np.ones_like(x), x.copy()
    if n == 0:
        return p0
    for k in range(1, n):
        p0, p1 = p1, ((2 * k + 1) * x * p1 - k * p0) / (k + 1)
    return p1


def lgr_nodes(n: int) -> np.ndarray:
    """The ``n`` LGR collocation points on [-1, 1): -1 and the roots of P_{n-1} + P_n, ascending.

    Roots from the Legendre companion matrix, polished by Newton's method on
    ``P_{n-1} + P_n``.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise TypeError(f"the number of LGR nodes must be an integer, got {n!r}")
    if n < 2:
        raise ValueError(f"LGR collocation needs at least 2 nodes per interval, got {n}")
    return _lgr_nodes(int(n))


@functools.lru_cache(maxsize=64)
def _lgr_nodes(n: int) -> np.ndarray:
    """Cached for mesh refinement, which asks for the same few degrees many times; read-only."""
    c = np.zeros(n + 1)
    c[n - 1] = c[n] = 1.0
    r = np.sort(np.polynomial.legendre.legroots(c).real)
    r[0] = -1.0
    dc = np.polynomial.legendre.legder(c)
    for _ in range(3):
        step = np.polynomial.legendre.legval(r[1:], c) / np.polynomial.legendre.legval(r[1:], dc)
        r[1:] -= step
    r.flags.writeable = False
    return r


def lgr_weights(tau: np.ndarray) -> np.ndarray:
    """LGR quadrature weights ``w_k = (1 - tau_k) / (N^2 P_{N-1}(tau_k)^2)`` (so ``w_1 = 2 / N^2``)."""
    n = tau.size
    return (1 - tau) / (n**2 * _legendre(n - 1, tau) ** 2)


def lgr_differentiation_matrix(tau: np.ndarray) -> np.ndarray:
    """The N x (N+1) LGR differentiation matrix, closed form (Garg et al. 2010).

    Support points are the collocation points ``tau_1..tau_N`` and the
    non-collocated end ``tau_{N+1} = +1``; ``D[k, j] = L_j'(tau_k)``:

        D_11 = -(N^2 + 1) / 4
        D_kk = -1 / (2 (1 - tau_k))                                 k >= 2
        D_kj = P_{N-1}(tau_k) / (P_{N-1}(tau_j) (tau_k - tau_j))     j <= N, j != k
        D_k,N+1 = N (P_N(tau_k) - P_{N-1}(tau_k)) / (2 (tau_k - 1))
    """
    tau = np.asarray(tau, dtype=float)
    n = tau.size
    pn1 = _legendre(n - 1, tau)
    pn = _legendre(n, tau)
    diff = tau[:, None] - tau[None, :]
    np.fill_diagonal(diff, 1.0)
    D = np.empty((n, n + 1))
    D[:, :n] = pn1[:, None] / (pn1[None, :] * diff)
    D[np.arange(1, n), np.arange(1, n)] = -1.0 / (2.0 * (1.0 - tau[1:]))
    D[0, 0] = -(n**2 + 1) / 4.0
    D[:, n] = n * (pn - pn1) / (2.0 * (tau - 1.0))
    return D


def integration_matrix(nodes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Matrix ``A`` with ``(A v)_j = int_{-1}^{points_j} p(s) ds`` for the interpolant ``p`` of ``v`` on ``nodes``.

    ``nodes`` and ``points`` lie in [-1, 1]; built in the Legendre basis (well conditioned on
    Gauss-type nodes): the Legendre-Vandermonde matrix of the nodes gives the coefficients, and
    ``int_{-1}^x P_k = (P_{k+1}(x) - P_{k-1}(x)) / (2k + 1)`` their integrals.
    """
    leg = np.polynomial.legendre
    x = np.asarray(nodes, dtype=float)
    p = np.atleast_1d(np.asarray(points, dtype=float))
    n = x.size
    integrals = np.empty((p.size, n))
    for k in range(n):
        c = np.zeros(n)
        c[k] = 1.0
        integrals[:, k] = leg.legval(p, leg.legint(c, lbnd=-1.0))
    return integrals @ np.linalg.inv(leg.legvander(x, n - 1))


@functools.lru_cache(maxsize=64)
def lgr_estimate_points(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``n`` LGR points and the integration matrix from -1 to each of them and to +1 (``n + 1`` rows).

    Cached: the arrays are shared, do not modify them."""
    tau = lgr_nodes(n)
    return tau, integration_matrix(tau, np.append(tau, 1.0))


def cubic_hermite(
    y0: np.ndarray, d0: np.ndarray, y1: np.ndarray, d1: np.ndarray, h: np.ndarray | float, s: np.ndarray | float
) -> np.ndarray:
    """The cubic Hermite interpolant between ``(y0, dy/dt = d0)`` and ``(y1, d1)`` a step ``h`` apart, at the
    fraction ``s`` of the step: ``(1 + 2s)(1 - s)^2 y0 + s(1 - s)^2 h d0 + s^2(3 - 2s) y1 + s^2(s - 1) h d1``
    (fourth-order accurate in ``h``). Arrays broadcast: rows of points, ``h`` and ``s`` as columns."""
    h00, h10 = (1 + 2 * s) * (1 - s) ** 2, s * (1 - s) ** 2
    h01, h11 = s * s * (3 - 2 * s), s * s * (s - 1)
    return h00 * y0 + h10 * h * d0 + h01 * y1 + h11 * h * d1


def quintic_hermite(
    y0: np.ndarray,
    d0: np.ndarray,
    a0: np.ndarray,
    y1: np.ndarray,
    d1: np.ndarray,
    a1: np.ndarray,
    h: np.ndarray | float,
    s: np.ndarray | float,
) -> np.ndarray:
    """The quintic Hermite interpolant between ``(y0, dy/dt = d0, d2y/dt2 = a0)`` and ``(y1, d1, a1)`` a step ``h``
    apart (two points with second derivatives; :func:`hermite_quintic_matrix` is HLGL's, three points with slopes), at the fraction ``s`` of the step (sixth-order accurate in ``h``; exact on polynomials of degree five):
    ``H0 y0 + H1 h d0 + H2 h^2 a0 + H3 h^2 a1 + H4 h d1 + H5 y1`` with ``H0 = 1 - 10s^3 + 15s^4 - 6s^5``,
    ``H1 = s - 6s^3 + 8s^4 - 3s^5``, ``H2 = (s^2 - 3s^3 + 3s^4 - s^5) / 2``, ``H3 = (s^3 - 2s^4 + s^5) / 2``,
    ``H4 = -4s^3 + 7s^4 - 3s^5``, ``H5 = 10s^3 - 15s^4 + 6s^5``. Arrays broadcast as in :func:`cubic_hermite`."""
    s2, s3 = s * s, s * s * s
    s4, s5 = s3 * s, s3 * s2
    h5 = 10 * s3 - 15 * s4 + 6 * s5
    h1 = s - 6 * s3 + 8 * s4 - 3 * s5
    h2 = 0.5 * (s2 - 3 * s3 + 3 * s4 - s5)
    h3 = 0.5 * (s3 - 2 * s4 + s5)
    h4 = -4 * s3 + 7 * s4 - 3 * s5
    return (1 - h5) * y0 + h1 * h * d0 + h2 * h * h * a0 + h3 * h * h * a1 + h4 * h * d1 + h5 * y1
