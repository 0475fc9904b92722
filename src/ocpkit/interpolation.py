"""Piecewise-polynomial interpolants of transcribed trajectories.

Evaluated with numpy in the order of ``scipy.interpolate.PPoly`` (a power sum from the lowest
power, on the local variable ``t - t_i``), so that the values are the same to the last bit,
without importing SciPy (``import ocpkit`` stays light: issue "many solves, fast").
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


class PiecewisePolynomial:
    """Vector-valued piecewise polynomial: ``c[m, i, :]`` multiplies ``(t - x[i])^(k - m)`` on ``[x[i], x[i+1]]``.

    The layout of ``scipy.interpolate.PPoly`` (highest power first). Times outside ``[x[0], x[-1]]`` are
    not extrapolated: callers clip them (:class:`PiecewiseEvaluator`).
    """

    def __init__(self, c: ArrayLike, x: ArrayLike) -> None:
        self.c = np.asarray(c, dtype=float)
        self.x = np.asarray(x, dtype=float)
        if self.c.ndim != 3 or self.c.shape[1] != self.x.size - 1:
            raise ValueError(f"coefficients of shape {self.c.shape} do not fit {self.x.size - 1} intervals")

    def __call__(self, t: ArrayLike) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        flat = t.ravel()
        i = np.clip(np.searchsorted(self.x, flat, side="right") - 1, 0, self.x.size - 2)
        s = flat - self.x[i]
        k = self.c.shape[0] - 1
        res = np.zeros((flat.size, self.c.shape[2]))
        z = np.ones(flat.size)
        for p in range(k + 1):
            res = res + self.c[k - p, i] * z[:, None]
            if p < k:
                z = z * s
        return res.reshape(t.shape + (self.c.shape[2],))

    def derivative(self, order: int = 1) -> PiecewisePolynomial:
        if order < 1:
            return PiecewisePolynomial(self.c.copy(), self.x)
        k = self.c.shape[0] - 1
        if order > k:
            return PiecewisePolynomial(np.zeros((1,) + self.c.shape[1:]), self.x)
        c2 = self.c[:-order].copy()
        powers = np.arange(k, order - 1, -1)  # the power of each remaining term before differentiation
        factor = np.array([float(np.prod(np.arange(p - order + 1, p + 1))) for p in powers])
        c2 *= factor[:, None, None]
        return PiecewisePolynomial(c2, self.x)


def piecewise_polynomial(breaks: ArrayLike, monomial: np.ndarray) -> PiecewisePolynomial:
    """A vector-valued :class:`PiecewisePolynomial` from normalised monomial coefficients.

    Parameters
    ----------
    breaks : ArrayLike
        Segment boundaries in time, shape ``(n + 1,)``.
    monomial : numpy.ndarray
        Coefficients ``a_k`` of ``sum_k a_k s^k``, shape ``(degree + 1, n, dim)``, with
        ``s = (t - breaks[i]) / h_i`` on segment ``i``.
    """
    breaks = np.asarray(breaks, dtype=float)
    h = np.diff(breaks)
    deg = monomial.shape[0] - 1
    powers = np.arange(deg + 1)
    # coefficient of (t - t_i)^k is a_k / h^k; highest power first
    c = monomial / h[None, :, None] ** powers[:, None, None]
    return PiecewisePolynomial(c[::-1], breaks)


class PiecewiseEvaluator:
    """Callable ``t -> values`` with shape ``t.shape + (dim,)``, times clipped to the breakpoints."""

    def __init__(self, poly: PiecewisePolynomial) -> None:
        self.poly = poly

    def __call__(self, t: ArrayLike) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        lo, hi = self.poly.x[0], self.poly.x[-1]
        return self.poly(np.clip(t, lo, hi))

    def derivative(self, order: int = 1) -> PiecewiseEvaluator:
        return PiecewiseEvaluator(self.poly.derivative(order))
