"""Grazing switchings: where a switching function comes near zero without crossing it.

A switching function ``g_k`` that touches zero inside an arc, on the arc's own side, marks an arc about to appear (or
one just lost): moving the unknowns by ``d`` towards it creates an arc whose length grows as ``sqrt(d)``, so the
shooting function is not differentiable there, and a root-finder whose model is the Jacobian without that arc stops
at the touch. Martinon & Gergaud's low-thrust transfer at 0.2 N stalls so (notebook 05): the iteration loses a short
coast of the extremal and drives the switching function's minimum there to 1e-5.

:func:`closest_approach` finds the nearest such approach along a recorded integration: the switching functions on
``per_step`` points of each step's dense output (:meth:`ShootingTrajectory.switching
<ocpkit.shooting.ShootingTrajectory.switching>`), their interior extrema on the arc's side of zero, the nearest
refined by a bounded scalar minimisation. Extrema at ``t0`` and ``tf`` are not approaches (an arc there is born at
an end, which the end conditions see), nor are stretches where ``g`` stays within :data:`SINGULAR` of its range
from zero a whole step each side (a singular arc, whose switching function vanishes identically: not a touch).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import minimize_scalar

from .trajectory import ShootingTrajectory

#: samples of the dense output evaluated at once
CHUNK = 50_000
#: an approach within this share of the switching function's range along the flight is a grazing switching
GRAZING = 1e-3
#: a switching function within this share of its range a whole step either side of an extremum vanishes there
#: identically (a singular arc, zero to rounding): not an approach
SINGULAR = 1e-8


class Approach(NamedTuple):
    """Where switching function number ``function`` (``label``: of which controls) comes nearest zero without
    crossing it: at ``t``, with value ``g``; ``scale`` its largest ``|g|`` along the flight."""

    t: float
    function: int
    g: float
    scale: float
    label: str = ""

    @property
    def relative(self) -> float:
        """``|g| / scale``: how near zero, as a share of the function's range."""
        return abs(self.g) / self.scale if self.scale > 0 else float("inf")

    @property
    def grazing(self) -> bool:
        """Within :data:`GRAZING` of zero, relative to the function's range."""
        return self.relative <= GRAZING

    def describe(self) -> str:
        """``the switching function of u comes within 9.4e-06 of zero (1e-05 of its range) at t = 710.018 …``."""
        name = self.label or f"switching function {self.function}"
        return (
            f"{name} comes within {abs(self.g):.2g} of zero ({self.relative:.1g} of its range) at t = {self.t:.6g} "
            "without crossing it"
        )


def _labels(trajectory: ShootingTrajectory) -> list[str]:
    """``the switching function of u`` (``… of ux, uy (threshold 2)`` in a group of several), one per function."""
    names = trajectory.problem.control_names
    labels = []
    for group in trajectory.system.law.groups:
        controls = ", ".join(names[i] for i in group.indices)
        for k in range(len(group.thresholds)):
            which = f" (threshold {k + 1})" if len(group.thresholds) > 1 else ""
            labels.append(f"the switching function of {controls}{which}")
    return labels


def closest_approach(trajectory: ShootingTrajectory, per_step: int = 8) -> Approach | None:
    """The nearest approach to zero without a crossing of any switching function along ``trajectory`` (a recorded
    integration); None where no switching function turns back before zero inside the flight."""
    edges = trajectory.integration.step_times
    edges = edges[np.concatenate([[True], np.diff(edges) > 0])]  # (a switching at tf repeats the last time)
    s = (np.arange(per_step) / per_step)[None, :]
    t = np.concatenate([(edges[:-1, None] + s * np.diff(edges)[:, None]).ravel(), edges[-1:]])
    # in chunks: a long flight (1e5 steps, 8e5 samples) would otherwise hold the dense output's work arrays at once
    G = np.concatenate([trajectory.switching(part) for part in np.array_split(t, max(1, t.size // CHUNK))])
    labels = _labels(trajectory)
    best: Approach | None = None
    for k in range(G.shape[1]):
        g = G[:, k]
        scale = float(np.abs(g).max())
        inner, before, after = g[1:-1], g[:-2], g[2:]
        turns = ((inner >= before) & (inner >= after) & (inner < 0)) | (
            (inner <= before) & (inner <= after) & (inner > 0)
        )
        candidates = np.flatnonzero(turns) + 1
        lo, hi = np.maximum(candidates - per_step, 0), np.minimum(candidates + per_step, g.size - 1)
        flat = np.maximum(np.abs(g[lo]), np.abs(g[hi])) < SINGULAR * scale  # zero throughout: a singular arc
        candidates = candidates[~flat]
        if candidates.size == 0:
            continue
        i = candidates[np.argmin(np.abs(g[candidates]))]
        side = np.sign(g[i])
        found = minimize_scalar(
            lambda tau, k=k, side=side: side * trajectory.switching(np.array([tau]))[0, k],
            bounds=(t[i - 1], t[i + 1]),
            method="bounded",
            options={"xatol": 1e-12 * max(1.0, abs(t[i]))},
        )
        # a crossing inside the bracket (the refinement went through zero): the sampled extremum stands
        at, value = (float(found.x), side * found.fun) if found.fun > 0 else (float(t[i]), float(g[i]))
        approach = Approach(at, k, float(value), scale, labels[k] if k < len(labels) else "")
        if best is None or approach.relative < best.relative:
            best = approach
    return best


__all__ = ["GRAZING", "SINGULAR", "Approach", "closest_approach"]
