"""How accurate a solution is: the relative discretisation error of its states on each mesh interval.

The estimate of Patterson, Hager & Rao ("A ph mesh refinement method for optimal control",
Optimal Control Applications and Methods 36, 2015, Sec. 3): on each interval ``[t_a, t_b]``
between breakpoints, take ``M`` Legendre-Gauss-Radau points ``tau_1 = -1 < ... < tau_M`` and
``tau_{M+1} = +1``, sample the solution's state ``X`` and control ``U`` there, and integrate the
dynamics along them with the ``M``-point interpolatory quadrature:

    Xhat_j = X(t_a) + (t_b - t_a) / 2 * sum_l A_jl f(X_l, U_l, t_l),     j = 2 .. M + 1,

``A`` the integration matrix of the Lagrange basis (:func:`ocpkit.nodes.integration_matrix`). The
relative error of state ``i`` at point ``j`` is ``|Xhat_ij - X_ij| / (1 + max_l |X_il|)``, and the
interval's error the largest over states and points. With ``M`` at least one more than the
degree of the scheme's state polynomial (Patterson et al. use ``N + 1`` for ``N`` LGR points;
HLGL's states are quintic), an interpolant that satisfies the dynamics exactly on a problem the
quadrature integrates exactly gives an estimate at rounding level. The control is the solution's
admissible one (within the bounds), as :meth:`~ocpkit.Trajectory.reintegrate` flies it.
This is the same estimate for every scheme (HLGL's quintic segments, multi-rate coarse segments,
Radau intervals), so their accuracy compares directly.
"""

from __future__ import annotations

import warnings

import numpy as np

from .nodes import lgr_estimate_points

#: Estimate points per interval when a scheme does not say (above the degree of HLGL's quintic states)
DEFAULT_ESTIMATE_POINTS = 8


class AccuracyWarning(UserWarning):
    """A solve succeeded but its estimated discretisation error exceeds the threshold asked for."""


def interval_errors(trajectory, points=None, breakpoints=None) -> np.ndarray:
    """The relative state error estimate on each interval between ``breakpoints`` (module docstring).

    ``points``: LGR points per interval (an int, or one per interval); default
    :data:`DEFAULT_ESTIMATE_POINTS`. ``breakpoints``: default ``trajectory.breakpoints``.
    """
    bp = np.asarray(trajectory.breakpoints if breakpoints is None else breakpoints, dtype=float)
    K = bp.size - 1
    M = np.full(K, DEFAULT_ESTIMATE_POINTS if points is None else 0, dtype=np.int64)
    if points is not None:
        M[:] = np.broadcast_to(np.asarray(points, dtype=np.int64), (K,))
    if np.any(M < 2):
        raise ValueError(f"the error estimate needs at least 2 points per interval, got {M.min()}")
    problem = trajectory.problem
    P = problem.parameter_vector() if problem.parameters else np.zeros(0)
    out = np.empty(K)
    for m in np.unique(M):
        ks = np.flatnonzero(M == m)
        tau, A = lgr_estimate_points(int(m))
        a, b = bp[ks], bp[ks + 1]
        t = a[:, None] + (b - a)[:, None] * (np.append(tau, 1.0)[None, :] + 1.0) / 2.0  # (k, m + 1)
        X = trajectory.state(t)  # (k, m + 1, nx)
        U = trajectory.control(t[:, :m])
        n = ks.size * int(m)
        F = np.asarray(problem.f.map(n)(X[:, :m].reshape(n, -1).T, U.reshape(n, -1).T, t[:, :m].reshape(1, n), P)).T
        F = F.reshape(ks.size, int(m), -1)
        Xhat = X[:, :1] + ((b - a) / 2.0)[:, None, None] * np.einsum("jl,kli->kji", A, F)
        denom = 1.0 + np.abs(X).max(axis=1, keepdims=True)
        out[ks] = (np.abs(Xhat - X) / denom).max(axis=(1, 2))
    return out


#: Samples per interval, and the distance to a bound (a fraction of the bounds' range) that counts as on it
SWITCH_SAMPLES, SWITCH_BAND = 64, 1e-3


def control_switches(trajectory, breakpoints=None, samples: int = SWITCH_SAMPLES, band: float = SWITCH_BAND):
    """Where a bounded control switches inside each interval: cuts (fractions in (0, 1)) around it, or none.

    A bang-bang switch or the junction of a bound arc with an interior (singular, or
    smooth) arc is a jump or a corner of the control, which no polynomial degree on the
    interval resolves: the refinement cuts there instead (in the spirit of the
    nonsmoothness detection of Liu, Hager & Rao, J. Franklin Inst. 352, 2015). On each
    interval the admissible control is sampled at ``samples`` midpoints; each bounded
    control is on its lower bound, on its upper bound, or between them (within ``band``
    times the range, or of a one-sided bound's scale). Where that status changes, a
    polynomial smears a jump across the interval, with overshoot near its ends, so a jump is
    placed where the control that switches (the one moving most, if several) crosses the
    middle of its range on the interval, at its steepest such crossing. From one bound to the
    other that is all; between a bound and the interior the control may instead meet or
    leave its bound continuously (a corner), which is where its status changes (the change
    nearest the crossing: overshoot near the interval's ends changes it too), so that place
    is bracketed too. Each place is bracketed by two cuts a sample either side (one
    where the other would fall on an end); each mesh iteration narrows a bracket by about
    ``samples / 2``. Controls with equal bounds are ignored.
    """
    bp = np.asarray(trajectory.breakpoints if breakpoints is None else breakpoints, dtype=float)
    controls = trajectory.problem.controls
    K = bp.size - 1
    if not controls or K < 1:
        return [np.zeros(0) for _ in range(K)]
    lo = np.array([c.lower for c in controls], dtype=float)
    hi = np.array([c.upper for c in controls], dtype=float)
    width = np.where(np.isfinite(lo) & np.isfinite(hi), hi - lo, [c.scale for c in controls])
    bounded = (np.isfinite(lo) | np.isfinite(hi)) & (width > 0)
    if not bounded.any():
        return [np.zeros(0) for _ in range(K)]
    width = np.where(width > 0, width, 1.0)
    s = (np.arange(samples) + 0.5) / samples
    t = bp[:-1, None] + np.diff(bp)[:, None] * s[None, :]
    U = trajectory.control(t)  # (K, samples, nu)
    status = np.where(U <= lo + band * width, -1, 0) + np.where(U >= hi - band * width, 1, 0)
    changed = status[:, 1:] != status[:, :-1]  # (K, samples - 1, nu): between samples j and j + 1
    switching = changed.any(axis=1) & bounded  # (K, nu): controls that switch
    # the switching control that moves most; where it crosses the middle of its range on the interval
    spread = np.where(switching, (U.max(axis=1) - U.min(axis=1)) / width, -1.0)  # (K, nu)
    i = np.argmax(spread, axis=1)
    V = np.take_along_axis(U, i[:, None, None], axis=2)[:, :, 0]  # (K, samples)
    step = np.abs(np.diff(V, axis=1))
    side = V > (V.max(axis=1, keepdims=True) + V.min(axis=1, keepdims=True)) / 2
    crossing = side[:, 1:] != side[:, :-1]
    j_cross = np.argmax(np.where(crossing, step, -1.0), axis=1)
    # the status change nearest the crossing (overshoot near the interval's ends changes the status too)
    Vc = np.take_along_axis(changed, i[:, None, None], axis=2)[:, :, 0]  # (K, samples - 1)
    distance = np.abs(np.arange(samples - 1)[None, :] - j_cross[:, None])
    j_status = np.argmin(np.where(Vc, distance, samples), axis=1)
    Vs = np.take_along_axis(status, i[:, None, None], axis=2)[:, :, 0]  # (K, samples)
    out = []
    for k in range(K):
        if not switching[k].any():
            out.append(np.zeros(0))
            continue
        # from one bound to the other: a jump, at the mid-range crossing; between a bound and the interior: a
        # jump there or a corner where the status changes, so both are bracketed
        centres = [j_cross[k]]
        if not ((Vs[k] == -1).any() and (Vs[k] == 1).any()):
            centres.append(j_status[k])
        cuts = np.unique(np.concatenate([np.array([j, j + 2]) / samples for j in centres]))
        out.append(cuts[(cuts > 0.0) & (cuts < 1.0)])
    return out


def warn_if_inaccurate(label: str, errors: np.ndarray, breakpoints: np.ndarray, threshold: float | None) -> None:
    """Warn (:class:`AccuracyWarning`) naming the estimate and the interval when it exceeds ``threshold``."""
    if threshold is None or errors.size == 0:
        return
    k = int(np.argmax(errors))
    if errors[k] > threshold:
        warnings.warn(
            f"{label}: estimated relative state error {errors[k]:.1e} on interval {k} "
            f"[{breakpoints[k]:.6g}, {breakpoints[k + 1]:.6g}] exceeds {threshold:g}; refine the mesh "
            "(solve(mesh_tolerance=...)) or check the solution (reintegrate())",
            AccuracyWarning,
            stacklevel=3,
        )
