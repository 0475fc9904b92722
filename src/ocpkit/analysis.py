"""Convergence orders of a scheme from errors on a sequence of meshes.

Differences between two solutions are :meth:`ocpkit.trajectory.Trajectory.difference`.
"""

from __future__ import annotations

import numpy as np


def convergence_order(segments, errors) -> float:
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
