"""The lunar ascent with the pitch attitude as a fast state (``data/problems/attitude_ascent.toml``).

Translational states ``X, Y, U, V`` obey Desai & Conway's Eqs. (8)-(11) with the thrust angle ``theta`` now a
state; ``theta' = q``, ``q' = u`` with ``u`` the commanded pitch acceleration. Minimise
``t_f + (w / 2) int u^2 dt``. The pitch-over from the vertical lift-off is a boundary layer of relative width
about ``w^(1/4)``: the attitude, its rate, the control and, through the thrust direction, the velocities change
on that timescale; the positions, integrals of the velocities, stay slow.
"""

from __future__ import annotations

import math

import casadi as ca

from ocpkit import Control, FreeFinalTime, OptimalControlProblem, State

from ._data import load_problem_data
from .lunar_ascent import ascent_rates, ascent_states, lunar_ascent_constants


def attitude_ascent(effort_weight: float | None = None) -> OptimalControlProblem:
    """Minimum time plus attitude effort, lunar ascent with pitch dynamics (module docstring).

    ``effort_weight``: the weight ``w`` of ``(w / 2) int u^2 dt`` (default from the data file).
    """
    c = lunar_ascent_constants()
    d = load_problem_data("attitude_ascent")
    att = d["attitude"]
    w = att["effort_weight"] if effort_weight is None else float(effort_weight)
    if not (w > 0 and math.isfinite(w)):
        raise ValueError(f"effort_weight must be positive and finite, got {effort_weight!r}")
    g, a, eps = c["g"], c["a"], c["speed_smoothing"]

    def dynamics(x, u, t, P=None):
        X, Y, U, V, theta, q = ca.vertsplit(x)
        return ca.vertcat(*ascent_rates(X, Y, U, V, theta, a, g, eps), q, u[0])

    lo, hi = att["pitch_bounds_rad"]
    states = ascent_states(c) + [
        State(
            "theta",
            lower=lo,
            upper=hi,
            initial=att["initial_pitch_rad"],
            guess=(att["initial_pitch_rad"], d["guess"]["theta_end_rad"]),
            unit="rad",
            description="pitch angle (thrust direction)",
        ),
        State(
            "q",
            initial=att["initial_rate"],
            final=att["final_rate"],
            scale=d["scaling"]["rate"],
            guess=0.0,
            description="pitch rate",
        ),
    ]
    controls = [Control("u", scale=d["scaling"]["acceleration"], guess=0.0, description="commanded pitch acceleration")]
    tlo, thi = c["tf_bounds"]
    return OptimalControlProblem(
        "attitude_ascent",
        states,
        controls,
        dynamics,
        tf=FreeFinalTime(tlo, thi, c["guess"]["tf"]),
        mayer=lambda x0, xf, t0, tf, P=None: tf,
        lagrange=lambda x, u, t, P=None: 0.5 * w * u[0] ** 2,
        description="lunar ascent with pitch attitude dynamics, minimum time plus attitude effort",
    )
