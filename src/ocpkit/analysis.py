"""Convergence orders of a scheme from errors on a sequence of meshes.

Differences between two solutions are :meth:`ocpkit.trajectory.Trajectory.difference`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from .trajectory import Trajectory


def convergence_order(segments: ArrayLike, errors: ArrayLike) -> float:
    """Least-squares slope ``p`` of ``log(error) = c - p log(segments)``.

    A scheme whose error falls like ``h^p = (1/n)^p`` has order ``p``. Points
    with non-positive or non-finite errors are ignored.
    """
    n = np.asarray(segments, dtype=float)
    e = np.asarray(errors, dtype=float)
    ok = np.isfinite(e) & (e > 0) & np.isfinite(n) & (n > 0)
    if ok.sum() < 2:
        raise ValueError("need at least two positive errors to fit an order")
    slope = np.polyfit(np.log(n[ok]), np.log(e[ok]), 1)[0]
    return float(-slope)


def total_variation(trajectory: Trajectory, control: str | int = 0, n: int = 2001) -> float:
    """Total variation ``sum |u(t_{k+1}) - u(t_k)|`` of one admissible control on ``n`` equally spaced times.

    A measure of chattering: a control that oscillates between mesh points on a singular arc
    has a variation far above the true control's (for a monotone control, ``|u(tf) - u(t0)|``),
    and growing as the mesh is refined.
    """
    names = trajectory.problem.control_names
    i = names.index(control) if isinstance(control, str) else int(control)
    if n < 2:
        raise ValueError(f"need at least 2 sample times, got {n}")
    u = trajectory.control(trajectory.time_grid(n))[:, i]
    return float(np.abs(np.diff(u)).sum())
