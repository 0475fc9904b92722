"""The hang glider, maximum range through a thermal (COPS 3.0; constants in ``data/problems/hang_glider.toml``).

    maximise x(t_f)   subject to   x' = v_x,   y' = v_y,
        v_x' = (-L sin(eta) - D cos(eta)) / m,   v_y' = (L cos(eta) - D sin(eta) - m g) / m,

with the lift ``L = c_L rho S v_r^2 / 2`` and drag ``D = (c0 + k c_L^2) rho S v_r^2 / 2`` relative to the air,
which rises in the thermal ``u_a = u_M (1 - X) exp(-X)``, ``X = (x / R - 2.5)^2``. From a glide at 1000 m to the
same glide at 900 m, ``0 <= c_L <= c_max``, t_f free. A hard problem for collocation: a free final time on every
defect, a control that reaches its upper bound, and dynamics stiff in x near the thermal (Betts 2020, Ex. 10.54).
"""

from __future__ import annotations

import casadi as ca

from ocpkit import Control, FreeFinalTime, OptimalControlProblem, State

from ._data import load_problem_data


def hang_glider(cops: bool = False) -> OptimalControlProblem:
    """Betts' statement (module docstring); ``cops=True``: COPS 3.0's, its rounded constants, its bounds (no box
    on y, v_y, x above or v_x above) and its starting point, unscaled, as a user would type it from the report
    (``[cops]`` in the data file)."""
    d = load_problem_data("hang_glider")
    c, b, box, guess = d["constants"], d["boundary"], d["bounds"], d["guess"]
    if cops:
        return _cops(c, b, box, d["cops"])

    def dynamics(x, u, t):
        vx, vy, cl = x[2], x[3], u[0]
        X = (x[0] / c["R"] - 2.5) ** 2
        Vy = vy - c["u_M"] * (1 - X) * ca.exp(-X)
        vr = ca.sqrt(vx**2 + Vy**2)
        q = 0.5 * c["rho"] * c["S"] * vr  # dynamic pressure over v_r; L sin(eta) = q c_L Vy, ...
        lift, drag = q * cl, q * (c["c0"] + c["k"] * cl**2)
        return ca.vertcat(
            vx,
            vy,
            (-lift * Vy - drag * vx) / c["m"],
            (lift * vx - drag * Vy) / c["m"] - c["g"],
        )

    return OptimalControlProblem(
        "hang_glider",
        states=[
            State("x", *box["x"], initial=b["x0"], scale=1000.0, guess=(b["x0"], guess["x_f"])),
            State("y", *box["y"], initial=b["y0"], final=b["y_f"], scale=1000.0, guess=(b["y0"], b["y_f"])),
            State("vx", *box["vx"], initial=b["vx0"], final=b["vx_f"], scale=10.0, guess=b["vx0"]),
            State("vy", *box["vy"], initial=b["vy0"], final=b["vy_f"], guess=b["vy0"]),
        ],
        controls=[Control("c_L", 0.0, c["c_max"], guess=c["c_max"] / 2)],
        dynamics=dynamics,
        tf=FreeFinalTime(*box["tf"], guess["tf"], scale=100.0),
        mayer=lambda x0, xf, t0, tf: -xf[0],
        objective_scale=1000.0,
        description="Hang glider, maximum range (COPS 3.0; Betts 2020, Ex. 10.54)",
    )


def _cops(c: dict, b: dict, box: dict, cops: dict) -> OptimalControlProblem:
    c = {**c, "g": cops["g"]}

    def dynamics(x, u, t):
        vx, vy, cl = x[2], x[3], u[0]
        r = (x[0] / c["R"] - 2.5) ** 2
        w = vy - c["u_M"] * (1 - r) * ca.exp(-r)
        v = ca.sqrt(vx**2 + w**2)
        lift = 0.5 * cl * c["rho"] * c["S"] * v**2
        drag = 0.5 * (c["c0"] + c["k"] * cl**2) * c["rho"] * c["S"] * v**2
        return ca.vertcat(
            vx, vy, (-lift * (w / v) - drag * (vx / v)) / c["m"], (lift * (vx / v) - drag * (w / v)) / c["m"] - c["g"]
        )

    inf = float("inf")
    return OptimalControlProblem(
        "hang_glider_cops",
        states=[
            State("x", 0.0, inf, initial=b["x0"], guess=(b["x0"], b["x0"] + cops["vx0"])),
            State("y", initial=b["y0"], final=b["y_f"], guess=(b["y0"], b["y_f"])),
            State("vx", 0.0, inf, initial=cops["vx0"], final=cops["vx_f"], guess=cops["vx0"]),
            State("vy", initial=cops["vy0"], final=cops["vy_f"], guess=cops["vy0"]),
        ],
        controls=[Control("c_L", 0.0, c["c_max"], guess=c["c_max"] / 2)],
        dynamics=dynamics,
        tf=FreeFinalTime(*box["tf"], cops["tf_guess"]),
        mayer=lambda x0, xf, t0, tf: -xf[0],
        description="Hang glider, maximum range, as COPS 3.0 states it",
    )
