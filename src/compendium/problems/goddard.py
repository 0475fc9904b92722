"""The Goddard rocket, maximum altitude (COPS 3.0; constants in ``data/problems/goddard.toml``).

    maximise h(t_f)   subject to   h' = v,   v' = (T - D) / m - g,   m' = -T / c,
    D = D_c v^2 exp(-h_c (h - h0) / h0),   g = g0 (h0 / h)^2,   0 <= T <= T_max,

from h = h0, v = v0, m = m0 to the final mass m_c m0, t_f free. The optimal thrust is full, then
singular (a drag-balancing thrust, where the Hamiltonian is linear in T and T is not determined by
its minimisation), then zero: the classical test of how a transcription treats a singular arc.
"""

from __future__ import annotations

import casadi as ca

from ocpkit import Constraint, Control, FreeFinalTime, OptimalControlProblem, State

from ._data import load_problem_data


def goddard_constants() -> dict:
    """The COPS constants and the derived ones: ``c``, ``D_c``, ``T_max``, ``m_f``; ``v_max`` of the speed-limited
    variant."""
    d = load_problem_data("goddard")
    c = dict(d["constants"])
    c["c"] = 0.5 * (c["g0"] * c["h0"]) ** 0.5
    c["D_c"] = 0.5 * c["v_c"] * c["m0"] / c["g0"]
    c["T_max"] = c["T_c"] * c["g0"] * c["m0"]
    c["m_f"] = c["m_c"] * c["m0"]
    c["tf_bounds"] = tuple(d["bounds"]["tf"])
    c["tf_guess"] = d["guess"]["tf"]
    c["v_max"] = d["speed_limit"]["v_max"]
    return c


def goddard_rocket(v_max: float | None = None, *, limit_as_parameter: bool = False) -> OptimalControlProblem:
    """The COPS Goddard rocket; with ``v_max``, the speed limited to ``v <= v_max``: the control-toolbox variant
    (OptimalControl.jl's Goddard tutorial, ``v_max = 0.1`` in ``data/problems/goddard.toml``), whose thrust is
    full, singular, on the speed limit (a boundary arc), then zero. ``limit_as_parameter``: the limit as the path
    constraint ``speed: v - v_max <= 0`` with ``v_max`` a problem parameter (to vary it in a solve or a
    continuation) instead of the bound of the state."""
    c = goddard_constants()
    if v_max is not None and not v_max > 0:
        raise ValueError(f"v_max must be positive, got {v_max}")
    if limit_as_parameter and v_max is None:
        raise ValueError("limit_as_parameter needs v_max")
    bound = v_max is not None and not limit_as_parameter
    extra = {}
    if limit_as_parameter:
        extra = {
            "parameters": {"v_max": float(v_max)},
            "path_constraints": [Constraint("speed", lambda x, u, t, p: x["v"] - p["v_max"], upper=0.0, scale=0.1)],
        }

    def dynamics(x, u, t):
        h, v, m = x[0], x[1], x[2]
        drag = c["D_c"] * v**2 * ca.exp(-c["h_c"] * (h - c["h0"]) / c["h0"])
        gravity = c["g0"] * (c["h0"] / h) ** 2
        return ca.vertcat(v, (u[0] - drag) / m - gravity, -u[0] / c["c"])

    lo, hi = c["tf_bounds"]
    return OptimalControlProblem(
        "goddard_rocket" if v_max is None else "goddard_rocket_speed_limit",
        states=[
            State("h", c["h0"], 2 * c["h0"], initial=c["h0"], guess=(c["h0"], 1.01 * c["h0"]), description="altitude"),
            State(
                "v",
                0.0,
                float(v_max) if bound else 1.0,
                initial=c["v0"],
                scale=0.1,
                guess=0.05,
                description="velocity",
            ),
            State(
                "m", c["m_f"], c["m0"], initial=c["m0"], final=c["m_f"], guess=(c["m0"], c["m_f"]), description="mass"
            ),
        ],
        controls=[Control("T", 0.0, c["T_max"], scale=c["T_max"], guess=c["T_max"] / 2, description="thrust")],
        dynamics=dynamics,
        tf=FreeFinalTime(lo, hi, c["tf_guess"], scale=0.1),
        mayer=lambda x0, xf, t0, tf: -xf[0],
        description="Goddard rocket, maximum altitude (COPS 3.0)"
        + ("" if v_max is None else f", speed limited to {v_max:g} (control-toolbox)"),
        **extra,
    )
