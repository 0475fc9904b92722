"""Bryson-Denham: a double integrator under the state constraint x <= l (Bryson & Ho, *Applied Optimal Control*,
Sec. 3.11), with its closed-form solution.

    minimise    1/2 int_0^1 u^2 dt,   x' = v,  v' = u,
                x(0) = 0, v(0) = 1, x(1) = 0, v(1) = -1,   x(t) <= l.

For l < 1/6 the constraint is active on ``[3l, 1 - 3l]`` and ``J = 4 / (9 l)``. With the
constraint adjoined directly (``H = u^2/2 + lambda_x v + lambda_v u + mu (x - l)``), the
costate ``lambda_x`` is ``2 / (9 l^2)`` before the boundary arc, 0 on it and the opposite
after it, so the multiplier ``mu`` is two atoms of mass ``2 / (9 l^2)`` at the junctions;
``lambda_v = -u``.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ocpkit import Constraint, Control, OptimalControlProblem, State


def bryson_denham(limit: float = 1.0 / 9.0) -> OptimalControlProblem:
    """The problem with ``x <= limit`` as a path constraint (not a state bound: its multiplier is reported)."""
    if not 0 < limit < 1 / 6:
        raise ValueError(f"the closed form holds for 0 < limit < 1/6, got {limit!r}")
    return OptimalControlProblem(
        "bryson_denham",
        states=[State("x", initial=0.0, final=0.0), State("v", initial=1.0, final=-1.0)],
        controls=[Control("u", lower=-20.0, upper=20.0)],
        dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=1.0,
        lagrange=lambda x, u, t: u[0] ** 2 / 2,
        path_constraints=[Constraint("x_max", lambda x, u, t: x[0], upper=limit)],
    )


def bryson_denham_solution(t, limit: float = 1.0 / 9.0) -> dict:
    """The closed form at times ``t``: ``x, v, u, lambda_x, lambda_v``, and ``J``, the junction times and the
    mass of each multiplier atom."""
    t = np.asarray(t, dtype=float)
    s = np.minimum(t, 1 - t)
    a = np.clip(1 - s / (3 * limit), 0, None)
    u = -2 / (3 * limit) * a
    jump = 2 / (9 * limit**2)
    return {
        "x": limit * (1 - a**3),
        "v": np.sign(0.5 - t) * a**2,
        "u": u,
        "lambda_x": np.where(t < 3 * limit, jump, np.where(t > 1 - 3 * limit, -jump, 0.0)),
        "lambda_v": -u,
        "J": 4 / (9 * limit),
        "junctions": (3 * limit, 1 - 3 * limit),
        "atom": jump,
    }
