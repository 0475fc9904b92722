"""Reference-collection problems of yapss' examples (github.com/stevenrhall/yapss; problems GPOPS-II also poses),
with the values their tests assert; constants in ``data/problems/collection_gpops.toml``."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
from scipy.optimize import fsolve

from ocpkit import (
    Constraint,
    Control,
    Duration,
    FreeFinalTime,
    FreeInitialTime,
    FreeParameter,
    MultiPhaseProblem,
    OptimalControlProblem,
    State,
)

from . import Reference, constants, register

TABLE = "collection_gpops"


def goddard_three_phase() -> MultiPhaseProblem:
    """Goddard rocket, maximum altitude, in three phases: full thrust, the singular arc imposed as a path
    constraint (thrust free in 1-99 % of its maximum), then coast to the dry mass (yapss goddard_problem_3_phase)."""
    c = constants(TABLE, "goddard_three_phase")
    Tm = c["T_max"]

    def drag(x):
        return c["sigma"] * x["v"] ** 2 * ca.exp(-x["h"] / c["h_s"])

    def singular_arc(x, u, t):  # m g = (1 + v / c) D on the singular arc
        return x["m"] * c["g"] - (1 + x["v"] / c["c"]) * drag(x)

    def phase(name, T, t0, tf, path=(), m_final=None):
        return OptimalControlProblem(
            name,
            states=[
                State("h", 0.0, c["h_max"], initial=0.0 if name == "boost" else None, scale=1e4, guess=(0, 18e3)),
                State("v", 0.0, c["v_max"], initial=0.0 if name == "boost" else None, scale=1e3, guess=500.0),
                State("m", c["mf"], c["m0"], initial=c["m0"] if name == "boost" else None, final=m_final),
            ],
            controls=[Control("T", *T, scale=Tm, guess=T[1])],
            dynamics=lambda x, u, t: [x["v"], (u["T"] - drag(x)) / x["m"] - c["g"], -u["T"] / c["c"]],
            t0=t0,
            tf=tf,
            path_constraints=path,
        )

    return MultiPhaseProblem(
        [
            phase("boost", (Tm, Tm), 0.0, FreeFinalTime(1, 100, 15, scale=10)),
            phase(
                "singular",
                (0.01 * Tm, 0.99 * Tm),
                FreeInitialTime(1, 100, 15),
                Duration(1, 100, 15, scale=10),
                path=[Constraint("singular_arc", singular_arc, lower=0.0, upper=0.0, scale=Tm)],
            ),
            phase("coast", (0.0, 0.0), FreeInitialTime(2, 200, 30), Duration(1, 100, 15, scale=10), m_final=c["mf"]),
        ],
        cost=lambda e: -e["coast"].xf["h"],
    )


def dynamic_soaring() -> OptimalControlProblem:
    """Dynamic soaring: the least wind gradient beta (W = beta h) sustaining a closed 360-degree loop of a glider
    with a load-factor limit (Zhao 2004; yapss dynamic_soaring)."""
    c = constants(TABLE, "dynamic_soaring")
    m, g, deg = c["m"], c["g"], math.pi / 180

    def dynamics(x, u, t, p):
        v, gamma, psi, CL, phi = x["v"], x["gamma"], x["psi"], u["CL"], u["phi"]
        q = c["rho"] * v**2 / 2
        lift, drag = q * c["S"] * CL, q * c["S"] * (c["CD0"] + c["K"] * CL**2)
        dW = p["beta"] * v * ca.sin(gamma)  # the wind's rate of change along the path
        return [
            v * ca.cos(gamma) * ca.sin(psi) + p["beta"] * x["h"] + c["W0"],
            v * ca.cos(gamma) * ca.cos(psi),
            v * ca.sin(gamma),
            -drag / m - g * ca.sin(gamma) - dW * ca.cos(gamma) * ca.sin(psi),
            (lift * ca.cos(phi) - m * g * ca.cos(gamma) + m * dW * ca.sin(gamma) * ca.sin(psi)) / (m * v),
            (lift * ca.sin(phi) - m * dW * ca.cos(psi)) / (m * v * ca.cos(gamma)),
        ]

    return OptimalControlProblem(
        "dynamic_soaring",
        states=[
            State("x", -c["x_max"], c["x_max"], initial=0.0, final=0.0, scale=1e3, guess=(-600.0, -600.0)),
            State("y", -c["y_max"], c["y_max"], initial=0.0, final=0.0, scale=1e3, guess=0.0),
            State("h", 0.0, c["h_max"], initial=0.0, final=0.0, scale=1e3, guess=400.0),
            State("v", *c["v"], scale=200.0, guess=150.0),
            State("gamma", -c["gamma_max"] * deg, c["gamma_max"] * deg, guess=0.0),
            State("psi", -c["psi_max"] * deg, c["psi_max"] * deg, scale=6.0, guess=(0.0, 2 * math.pi)),
        ],
        controls=[
            Control("CL", 0.0, c["CL_max"], guess=0.5),
            Control("phi", -c["phi_max"] * deg, c["phi_max"] * deg, guess=45 * deg),
        ],
        dynamics=dynamics,
        tf=FreeFinalTime(*c["tf"], 24.0, scale=30.0),
        free_parameters=[FreeParameter("beta", *c["beta"], guess=0.08, scale=0.1)],
        mayer=lambda x0, xf, t0, tf, p: p["beta"],
        path_constraints=[
            Constraint(
                "load_factor",
                lambda x, u, t: c["rho"] * c["S"] * u["CL"] * x["v"] ** 2 / (2 * m * g),
                *c["load_factor"],
                scale=5.0,
            )
        ],
        boundary_constraints=[
            Constraint(
                "periodic",
                lambda x0, xf, t0, tf: [xf["v"] - x0["v"], xf["gamma"] - x0["gamma"], xf["psi"] - x0["psi"]],
                lower=[0, 0, 2 * math.pi],
                upper=[0, 0, 2 * math.pi],
            )
        ],
        objective_scale=0.1,
    )


def newton_nose_drag() -> float:
    """Newton's solution: with p = -y' >= 1 along the curve, r = r0 (1 + p^2)^2 / (4p) and
    y = y_max - r0 (p^2 + 3p^4/4 - ln p - 7/4) / 4 from the tip (p = 1) to the base (r = 1, y = 0), which fix r0
    and the base's slope; C_D = 4 r0^2 + r0^2 / 2 [ln p + 5p^2/2 + 3p^4/4 + 1/(2p^2)] from 1 to that slope."""
    h = constants(TABLE, "newton_nose")["y_max"]

    def ends(z):
        r0, p = z
        return [r0 * (1 + p * p) ** 2 / (4 * p) - 1, h - r0 / 4 * (p * p + 0.75 * p**4 - math.log(p) - 1.75)]

    r0, p = fsolve(ends, (0.35, 1.9), xtol=1e-13)

    def F(q):
        return math.log(q) + 2.5 * q * q + 0.75 * q**4 + 0.5 / (q * q)

    return float(4 * r0 * r0 + r0 * r0 / 2 * (F(p) - F(1.0)))


def newton_nose() -> OptimalControlProblem:
    """Newton's minimal-resistance nose of height y_max: the profile y(r), concave, from a flat tip of free radius r0
    to the base r = 1, minimising its drag coefficient (yapss newton, second formulation)."""
    c = constants(TABLE, "newton_nose")
    return OptimalControlProblem(
        "newton_nose",
        states=[
            State("y", 0.0, c["y_max"], initial=c["y_max"], final=0.0, guess=(c["y_max"], 0.0)),
            State("dy", upper=0.0, guess=-c["y_max"]),  # the slope y'(r)
        ],
        controls=[Control("u", upper=0.0, guess=0.0)],  # y''(r) <= 0: a concave profile
        dynamics=lambda x, u, t: [x["dy"], u["u"]],
        t0=FreeInitialTime(0.0, c["r0_max"], 0.3),
        tf=1.0,  # the time is the radius r
        mayer=lambda x0, xf, t0, tf: 4 * t0**2,  # the flat tip's drag
        lagrange=lambda x, u, t: 8 * t / (1 + x["dy"] ** 2),
    )


def isoperimetric() -> OptimalControlProblem:
    """The isoperimetric problem: the closed curve of unit length enclosing the largest area, its centroid pinned
    near the origin (yapss isoperimetric); the circle, area 1 / (4 pi)."""
    c = constants(TABLE, "isoperimetric")
    box = c["xy_max"]
    return OptimalControlProblem(
        "isoperimetric",
        states=[
            State("x", -box, box, guess=lambda t: np.cos(2 * np.pi * t)),
            State("y", -box, box, guess=lambda t: -np.sin(2 * np.pi * t)),
            # int x ds and int y ds, pinned near 0 (the translation's freedom)
            State("X", initial=0.0, final=tuple(c["centroid"]), guess=0.0),
            State("Y", initial=0.0, final=tuple(c["centroid"]), guess=0.0),
        ],
        controls=[Control("ux", -c["u_max"], c["u_max"], guess=0.0), Control("uy", -c["u_max"], c["u_max"], guess=0.0)],
        dynamics=lambda x, u, t: [u["ux"], u["uy"], x["x"], x["y"]],
        tf=1.0,  # the time is the arc length
        lagrange=lambda x, u, t: -(x["y"] * u["ux"] - x["x"] * u["uy"]) / 2,  # minus the area swept
        path_constraints=[Constraint("unit_speed", lambda x, u, t: u["ux"] ** 2 + u["uy"] ** 2, lower=1.0, upper=1.0)],
        boundary_constraints=[
            Constraint("closed", lambda x0, xf, t0, tf: [xf["x"] - x0["x"], xf["y"] - x0["y"]], lower=0.0, upper=0.0)
        ],
    )


def _maximised(solution) -> float:
    return -float(solution.objective)


register(
    Reference(
        "gpops_goddard_three_phase", "Goddard rocket in three phases (singular arc imposed)",
        "yapss example goddard_problem_3_phase; GPOPS-II example goddardRocket (same constants)",
        goddard_three_phase, ("multi-phase", "singular-arc", "free-final-time", "aerospace"),
        paper=(TABLE, "gpops_goddard_three_phase"), quantity="final_altitude_ft", value=_maximised, start=(4, 5),
        statement=r"\begin{aligned}&\max h(t_f)\quad \dot h = v,\ \dot v = (T - \sigma v^2 e^{-h/h_s})/m - g,\ "
        r"\dot m = -T/c,\\ &T = T_{\max} \text{ (boost)},\ mg = (1 + v/c)\,\sigma v^2 e^{-h/h_s} "
        r"\text{ (singular arc)},\ T = 0,\ m(t_f) = m_f \text{ (coast)}\end{aligned}",
    ),
    Reference(
        "gpops_dynamic_soaring", "Dynamic soaring, least wind gradient", "Zhao 2004; Darby, Hager & Rao 2011 (GPOPS); "
        "yapss example dynamic_soaring",
        dynamic_soaring, ("parameter-estimation", "free-final-time", "path-constraint", "aerospace"),
        paper=(TABLE, "gpops_dynamic_soaring"), quantity="wind_gradient", kind="discretised",
        mesh="yapss, 50 segments of 6 LGL points", start=(4, 20), agreement=1e-5,
        why="the load-factor limit is met on arcs whose junctions kink the states' derivatives: both schemes converge "
        "to them at a low order",
        statement=r"\begin{aligned}&\min_{\beta,\,C_L,\,\phi,\,t_f} \beta\quad W_x = \beta h,\ "
        r"(x, y, h)(0) = (x, y, h)(t_f) = 0,\\ &(v, \gamma)(t_f) = (v, \gamma)(0),\ \psi(t_f) = \psi(0) + 2\pi,\ "
        r"-2 \le \tfrac{\rho S C_L v^2}{2 m g} \le 5\end{aligned}",
    ),
    Reference(
        "gpops_newton_nose", "Newton's minimal-resistance nose", "Newton 1687; yapss example newton (setup2)",
        newton_nose, ("closed-form", "smooth"),
        paper=(TABLE, "gpops_newton_nose"), quantity="drag_coefficient", closed_form=newton_nose_drag,
        kind="discretised", mesh="yapss default mesh, bounds relaxed by IPOPT's bound_relax_factor",
        statement=r"\min_{r_0}\ 4r_0^2 + \int_{r_0}^{1} \frac{8r}{1 + y'^2}\,dr,\ y(r_0) = y_{\max},\ y(1) = 0,\ "
        r"y'' \le 0,\ 0 \le r_0 \le 0.7",
    ),
    Reference(
        "gpops_isoperimetric", "Isoperimetric problem (the circle)", "Dido; yapss example isoperimetric",
        isoperimetric, ("closed-form", "path-constraint"),
        closed_form=lambda: 1 / (4 * math.pi), value=_maximised,
        statement=r"\max \tfrac12\int_0^1 (y u_x - x u_y)\,ds,\ \dot x = u_x,\ \dot y = u_y,\ u_x^2 + u_y^2 = 1,\ "
        r"(x, y)(1) = (x, y)(0),\ \left|\int_0^1 x\,ds\right|, \left|\int_0^1 y\,ds\right| \le 10^{-4}",
    ),
)  # fmt: skip
