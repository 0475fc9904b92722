"""Small numerical analyses shared by the notebooks: convergence orders, differences."""

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


def max_difference_pct(solution, reference, n: int = 2001) -> dict:
    """Largest difference of each variable between two solutions, in percent of the reference's magnitude.

    For each state and control ``v``: ``100 max_k |v(s_k) - v_ref(s_k)| / max_k |v_ref(s_k)|``
    over ``n`` points ``s_k`` equally spaced in normalised time ``s = (t - t0) / (tf - t0)``
    (each solution on its own final time, so a tf difference does not pose as a
    state difference). Also returns ``"states"`` and ``"controls"``: the largest
    over each group (Desai & Conway's "Max Difference" columns), and
    ``"tf"``: the relative final-time difference in percent.
    """
    if n < 2:
        raise ValueError("n must be at least 2")
    pa, pb = solution.problem, reference.problem
    if pa.state_names != pb.state_names or pa.control_names != pb.control_names:
        raise ValueError("solutions of different problems cannot be compared")
    s = np.linspace(0.0, 1.0, n)

    def at(sol):
        t = sol.t0 + s * (sol.tf - sol.t0)
        return sol.state(t), sol.control(t)

    xa, ua = at(solution)
    xb, ub = at(reference)
    out = {}
    for names, a, b in ((pa.state_names, xa, xb), (pa.control_names, ua, ub)):
        for j, name in enumerate(names):
            scale = np.abs(b[:, j]).max()
            out[name] = float(100 * np.abs(a[:, j] - b[:, j]).max() / scale) if scale > 0 else float("nan")
    out["states"] = max(out[k] for k in pa.state_names)
    out["controls"] = max((out[k] for k in pa.control_names), default=float("nan"))
    out["tf"] = float(100 * abs(solution.tf - reference.tf) / abs(reference.tf - reference.t0))
    return out
