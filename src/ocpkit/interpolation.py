"""Piecewise-polynomial interpolants of transcribed trajectories."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import PPoly


def piecewise_polynomial(breaks: np.ndarray, monomial: np.ndarray) -> PPoly:
    """A vector-valued :class:`scipy.interpolate.PPoly` from normalised monomial coefficients.

    Parameters
    ----------
    breaks : (n + 1,) segment boundaries in time.
    monomial : (degree + 1, n, dim) coefficients ``a_k`` of ``sum_k a_k s^k`` with
        ``s = (t - breaks[i]) / h_i`` on segment ``i``.
    """
    breaks = np.asarray(breaks, dtype=float)
    h = np.diff(breaks)
    deg = monomial.shape[0] - 1
    powers = np.arange(deg + 1)
    # coefficient of (t - t_i)^k is a_k / h^k; PPoly wants the highest power first
    c = monomial / h[None, :, None] ** powers[:, None, None]
    return PPoly(c[::-1], breaks, extrapolate=False)


class PiecewiseEvaluator:
    """Callable ``t -> values`` with shape ``t.shape + (dim,)`` around a PPoly."""

    def __init__(self, ppoly: PPoly):
        self.ppoly = ppoly

    def __call__(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        lo, hi = self.ppoly.x[0], self.ppoly.x[-1]
        return self.ppoly(np.clip(t, lo, hi))

    def derivative(self, order: int = 1) -> PiecewiseEvaluator:
        return PiecewiseEvaluator(self.ppoly.derivative(order))
