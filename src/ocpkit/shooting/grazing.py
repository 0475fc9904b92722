"""Grazing switchings: where a switching function comes near zero without crossing it.

A switching function ``g_k`` that touches zero inside an arc, on the arc's own side, marks an arc about to appear (or
one just lost): moving the unknowns by ``d`` towards it creates an arc whose length grows as ``sqrt(d)``, so the
shooting function is not differentiable there, and a root-finder whose model is the Jacobian without that arc stops
at the touch. Martinon & Gergaud's low-thrust transfer at 0.2 N stalls so (notebook 05): the iteration loses a short
coast of the extremal and drives the switching function's minimum there to 1e-5.

:func:`closest_approach` finds the nearest such approach along a recorded integration: the switching functions on
``per_step`` points of each step's dense output (the quintic Hermite interpolant of
:class:`~ocpkit.shooting.trajectory.ShootingTrajectory`), their interior extrema on the arc's side of zero, the
smallest refined by a bounded scalar minimisation.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import minimize_scalar

from .trajectory import ShootingTrajectory

#: an approach within this share of the switching function's range along the flight is a grazing switching
GRAZING = 1e-3


class Approach(NamedTuple):
    """Where switching function ``index`` comes nearest zero without crossing it: at ``t``, with value ``g``;
    ``scale`` its largest ``|g|`` along the flight."""

    t: float
    index: int
    g: float
    scale: float

    @property
    def relative(self) -> float:
        """``|g| / scale``: how near zero, as a share of the function's range."""
        return abs(self.g) / self.scale if self.scale > 0 else float("inf")

    @property
    def grazing(self) -> bool:
        """Within :data:`GRAZING` of zero, relative to the function's range."""
        return self.relative <= GRAZING

    def describe(self) -> str:
        return (
            f"switching function {self.index} comes within {abs(self.g):.2g} of zero ({self.relative:.1g} of its "
            f"range) at t = {self.t:.6g} without crossing it"
        )


def closest_approach(trajectory: ShootingTrajectory, per_step: int = 8) -> Approach | None:
    """The nearest approach to zero without a crossing of any switching function along ``trajectory`` (a recorded
    integration); None where none has an interior extremum on its arc's side."""
    system = trajectory.system
    edges = trajectory._t
    s = (np.arange(per_step) / per_step)[None, :]
    t = np.concatenate([(edges[:-1, None] + s * np.diff(edges)[:, None]).ravel(), edges[-1:]])
    P = trajectory.full_parameters

    def g_at(times: np.ndarray) -> np.ndarray:
        Y, _ = trajectory._y(times)
        return np.asarray(system.switching.map(times.size)(Y.T, P)).T

    G = g_at(t)
    best: Approach | None = None
    for k in range(G.shape[1]):
        g = G[:, k]
        inner, before, after = g[1:-1], g[:-2], g[2:]
        touch = ((inner >= before) & (inner >= after) & (inner < 0)) | ((inner <= before) & (inner <= after) & (inner > 0))
        candidates = np.flatnonzero(touch) + 1
        if candidates.size == 0:
            continue
        i = candidates[np.argmin(np.abs(g[candidates]))]
        side = np.sign(g[i])
        found = minimize_scalar(
            lambda tau, k=k, side=side: side * g_at(np.array([tau]))[0, k],
            bounds=(t[i - 1], t[i + 1]),
            method="bounded",
            options={"xatol": 1e-12 * max(1.0, abs(t[i]))},
        )
        value = side * found.fun if found.fun > 0 else g[i]  # (a crossing inside the bracket: the sample)
        approach = Approach(float(found.x), k, float(value), float(np.abs(g).max()))
        if best is None or approach.relative < best.relative:
            best = approach
    return best


__all__ = ["GRAZING", "Approach", "closest_approach"]
