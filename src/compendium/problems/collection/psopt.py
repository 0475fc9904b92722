"""Reference-collection problems from PSOPT's examples (github.com/PSOPT/psopt, ``examples/<name>/``), with the
costs its manual prints (PSOPT Manual Release 5, Chapter 3; PSOPT Application Examples Document): constants in
``data/problems/collection_psopt.toml``, published values in ``data/paper/collection_psopt.csv``."""

from __future__ import annotations

import math

import casadi as ca
from scipy.integrate import quad
from scipy.optimize import brentq

from ocpkit import Constraint, Control, FreeFinalTime, Link, MultiPhaseProblem, OptimalControlProblem, State

from . import Reference, constants, register

TABLE = "collection_psopt"


def interior_point() -> MultiPhaseProblem:
    """Minimise int_0^1 (x^2 + u^2) dt, x' = u, from 1 to 0.75 through x(0.75) = 0.9 (PSOPT interior_point)."""
    c = constants(TABLE, "interior_point")

    def phase(name, t0, tf, initial, final):
        return OptimalControlProblem(
            name,
            states=[State("x", initial=initial, final=final, guess=(1.0, 0.8))],
            controls=[Control("u", guess=0.0)],
            dynamics=lambda x, u, t: [u["u"]],
            t0=t0,
            tf=tf,
            lagrange=lambda x, u, t: x["x"] ** 2 + u["u"] ** 2,
        )

    before = phase("before", 0.0, c["t_interior"], c["x0"], c["x_interior"])
    after = phase("after", c["t_interior"], c["tf"], None, c["xf"])
    return MultiPhaseProblem([before, after], [Link("before", "after")])


def interior_point_cost() -> float:
    """The exact optimum: on each phase x = A cosh t + B sinh t, whose cost from x_a to x_b over a time T is
    (x_a^2 + x_b^2) coth T - 2 x_a x_b / sinh T."""
    c = constants(TABLE, "interior_point")

    def arc(a: float, b: float, T: float) -> float:
        return (a * a + b * b) / math.tanh(T) - 2 * a * b / math.sinh(T)

    t1, x1 = c["t_interior"], c["x_interior"]
    return arc(c["x0"], x1, t1) + arc(x1, c["xf"], c["tf"] - t1)


def isoperimetric() -> OptimalControlProblem:
    """Minimise int_0^1 x dt, x' = -sin x + u, x: 1 -> 0, with int_0^1 u^2 dt = 10 (PSOPT isoperimetric)."""
    c = constants(TABLE, "isoperimetric")
    return OptimalControlProblem(
        "psopt_isoperimetric",
        states=[
            State("x", -c["x_max"], c["x_max"], initial=c["x0"], final=c["xf"], guess=(c["x0"], c["xf"])),
            State("energy", initial=0.0, final=c["energy"], guess=(0.0, c["energy"]), scale=c["energy"]),
        ],
        controls=[Control("u", -c["u_max"], c["u_max"], guess=-1.0)],
        dynamics=lambda x, u, t: [-ca.sin(x["x"]) + u["u"], u["u"] ** 2],
        tf=c["tf"],
        lagrange=lambda x, u, t: x["x"],
    )


def bryson_max_range() -> OptimalControlProblem:
    """Maximise x(2) of a particle accelerated by a - g u2 along the unit direction (u1, u2), with y(2) = 0.1."""
    c = constants(TABLE, "bryson_max_range")
    return OptimalControlProblem(
        "psopt_bryson_max_range",
        states=[
            State("x", initial=0.0, guess=(0.0, 1.7)),
            State("y", initial=0.0, final=c["yf"], guess=(0.0, c["yf"])),
            State("v", initial=0.0, guess=(0.0, 1.0)),
        ],
        controls=[Control(n, -c["u_bound"], c["u_bound"], guess=g) for n, g in (("u1", 1.0), ("u2", 0.0))],
        dynamics=lambda x, u, t: [x["v"] * u["u1"], x["v"] * u["u2"], c["a"] - c["g"] * u["u2"]],
        tf=c["tf"],
        mayer=lambda x0, xf, t0, tf: -xf["x"],
        path_constraints=[Constraint("unit", lambda x, u, t: u["u1"] ** 2 + u["u2"] ** 2, lower=1.0, upper=1.0)],
    )


def obstacle_avoidance() -> OptimalControlProblem:
    """Steer a particle at constant speed V from (0, 0) to (1.2, 1.6) in t_f = 1 around two discs (PSOPT obstacle)."""
    c = constants(TABLE, "obstacle")
    V, (x0, y0), (x1, y1) = c["V"], c["initial"], c["final"]
    discs = [
        Constraint(f"disc_{k}", lambda x, u, t, a=a, b=b: (x["x"] - a) ** 2 + (x["y"] - b) ** 2, lower=c["clearance"])
        for k, (a, b) in enumerate(c["centres"], start=1)
    ]
    return OptimalControlProblem(
        "psopt_obstacle_avoidance",
        states=[
            State("x", 0.0, 2.0, initial=x0, final=x1, guess=(x0, x1)),
            State("y", 0.0, 2.0, initial=y0, final=y1, guess=(y0, y1)),
        ],
        controls=[Control("theta", period=2 * math.pi, guess=math.atan2(y1 - y0, x1 - x0))],
        dynamics=lambda x, u, t: [V * ca.cos(u["theta"]), V * ca.sin(u["theta"])],
        tf=c["tf"],
        lagrange=lambda x, u, t: (V * ca.cos(u["theta"])) ** 2 + (V * ca.sin(u["theta"])) ** 2,
        path_constraints=discs,
    )


def obstacle_cost() -> float:
    """The cost is the constant V^2 t_f: the speed is fixed, only the path is chosen."""
    c = constants(TABLE, "obstacle")
    return c["V"] ** 2 * c["tf"]


def singular_double_integrator() -> OptimalControlProblem:
    """Minimise int_0^tf (1 + v^2)/2 dt from (2, 0) to rest at 5 with |u| <= 1, t_f free (Locatelli 2017, 11.2-1a)."""
    c = constants(TABLE, "singular_double_integrator")
    (x0, v0), (x1, v1) = c["initial"], c["final"]
    return OptimalControlProblem(
        "psopt_singular_double_integrator",
        states=[
            State("x", -10.0, 10.0, initial=x0, final=x1, guess=(x0, x1)),
            State("v", -5.0, 5.0, initial=v0, final=v1, guess=0.5),
        ],
        controls=[Control("u", -c["u_max"], c["u_max"], guess=0.0)],
        dynamics=lambda x, u, t: [x["v"], u["u"]],
        tf=FreeFinalTime(c["tf"][0], c["tf"][1], c["tf_guess"]),
        lagrange=lambda x, u, t: (1 + x["v"] ** 2) / 2,
    )


def moon_lander() -> OptimalControlProblem:
    """Land softly from h = 1, v = -0.783 with the least fuel, thrust 0 <= T <= 1.227, t_f free (PSOPT moon)."""
    c = constants(TABLE, "moon_lander")
    return OptimalControlProblem(
        "psopt_moon_lander",
        states=[
            State("h", -20.0, 20.0, initial=c["h0"], final=0.0, guess=(c["h0"], 0.0)),
            State("v", -20.0, 20.0, initial=c["v0"], final=0.0, guess=(c["v0"], 0.0)),
            State("m", c["m_min"], c["m0"], initial=c["m0"], guess=(c["m0"], 0.5)),
        ],
        controls=[Control("T", 0.0, c["T_max"], guess=c["T_max"] / 2)],
        dynamics=lambda x, u, t: [x["v"], -c["g"] + u["T"] / x["m"], -u["T"] / c["exhaust_velocity"]],
        tf=FreeFinalTime(c["tf"][0], c["tf"][1], c["tf_guess"]),
        lagrange=lambda x, u, t: u["T"],
    )


def moon_lander_fuel() -> float:
    """The exact optimum: coast, then full thrust T_max to touch down at rest; the coast time t_s and the burn time
    s solve v(s) = 0 and h(s) = 0, and the fuel is T_max s."""
    c = constants(TABLE, "moon_lander")
    g, ve, T, h0, v0 = c["g"], c["exhaust_velocity"], c["T_max"], c["h0"], c["v0"]

    def burn(ts: float) -> tuple[float, float]:  # (height where the burn stops the lander, burn time)
        h1, v1 = h0 + v0 * ts - g * ts * ts / 2, v0 - g * ts
        s = brentq(lambda s: v1 - g * s - ve * math.log(1 - T * s / ve), 1e-12, 0.99 * ve / T)
        m = 1 - T * s / ve
        return h1 + v1 * s - g * s * s / 2 + ve * ve / T * (m * math.log(m) - m + 1), s

    return T * burn(brentq(lambda ts: burn(ts)[0], 0.0, 0.5))[1]


def analytic_x1() -> OptimalControlProblem:
    """Minimise int_0^{pi/2} (y^2 + u cos t) dt, y' = y^2/2 + u, y(0) = 0: singular throughout (Neuenhofen & Kerrigan)."""
    c = constants(TABLE, "analytic_x1")
    return OptimalControlProblem(
        "psopt_analytic_x1",
        states=[State("y", initial=c["y0"], guess=(0.0, -0.5))],
        controls=[Control("u", c["u_bounds"][0], c["u_bounds"][1], guess=-0.5)],
        dynamics=lambda x, u, t: [x["y"] ** 2 / 2 + u["u"]],
        tf=math.pi / 2,
        lagrange=lambda x, u, t: x["y"] ** 2 + ca.cos(t) * u["u"],
    )


def analytic_x1_cost() -> float:
    """The cost of the singular solution y = -sin t / (2 - cos t), u = 1/2 - 3/2 / (2 - cos t)^2 (by quadrature)."""

    def integrand(t: float) -> float:
        y, d = -math.sin(t) / (2 - math.cos(t)), 2 - math.cos(t)
        return y * y + math.cos(t) * (0.5 - 1.5 / (d * d))

    return quad(integrand, 0.0, math.pi / 2, epsabs=1e-14, epsrel=1e-13)[0]


register(
    Reference(
        "psopt_interior_point", "Interior point constraint", "PSOPT Manual R5, Sec. 3.18 (after MISER3)",
        interior_point, ("multi-phase", "closed-form"),
        paper=(TABLE, "psopt_interior_point"), closed_form=interior_point_cost, start=(4, 5), fast=True,
        statement=r"\min \int_0^1 (x^2 + u^2)\,dt \quad\text{s.t.}\quad \dot x = u,\ x(0) = 1,\ x(0.75) = 0.9,\ "
        r"x(1) = 0.75",
    ),
    Reference(
        "psopt_isoperimetric", "Isoperimetric constraint", "PSOPT Manual R5, Sec. 3.19; examples/isoperimetric",
        isoperimetric, ("path-constraint",),
        paper=(TABLE, "psopt_isoperimetric"),
        statement=r"\min \int_0^1 x\,dt \quad\text{s.t.}\quad \dot x = -\sin x + u,\ \int_0^1 u^2\,dt = 10,\ "
        r"x(0) = 1,\ x(1) = 0,\ |u| \le 4",
    ),
    Reference(
        "psopt_bryson_max_range", "Bryson's maximum range", "PSOPT Manual R5, Sec. 3.5; Bryson & Ho 1975",
        bryson_max_range, ("path-constraint", "smooth"),
        paper=(TABLE, "psopt_bryson_max_range"),
        statement=r"\min -x(2) \quad\text{s.t.}\quad \dot x = v u_1,\ \dot y = v u_2,\ \dot v = a - g u_2,\ "
        r"u_1^2 + u_2^2 = 1,\ y(2) = 0.1",
    ),
    Reference(
        "psopt_obstacle_avoidance", "Obstacle avoidance", "PSOPT Manual R5, Sec. 3.34 (after PROPT)",
        obstacle_avoidance, ("path-constraint",),
        paper=(TABLE, "psopt_obstacle_avoidance"), closed_form=obstacle_cost,
        statement=r"\min \int_0^1 (\dot x^2 + \dot y^2)\,dt \quad\text{s.t.}\quad \dot x = V\cos\theta,\ "
        r"\dot y = V\sin\theta,\ (x - 0.4)^2 + (y - 0.5)^2 \ge 0.1,\ (x - 0.8)^2 + (y - 1.5)^2 \ge 0.1",
    ),
    Reference(
        "psopt_analytic_x1", "Neuenhofen-Kerrigan analytic problem", "Neuenhofen & Kerrigan 2020; PSOPT examples/x1",
        analytic_x1, ("singular-arc", "closed-form"),
        paper=(TABLE, "psopt_analytic_x1"), closed_form=analytic_x1_cost,
        statement=r"\min \int_0^{\pi/2} (y^2 + u\cos t)\,dt \quad\text{s.t.}\quad \dot y = y^2/2 + u,\ y(0) = 0,\ "
        r"-1.5 \le u \le 1",
    ),
    Reference(
        "psopt_singular_double_integrator", "Singular arc of a double integrator",
        "Locatelli 2017, Problem 11.2-1a; PSOPT examples/singular_di",
        singular_double_integrator, ("singular-arc", "bang-bang", "free-final-time", "closed-form"),
        paper=(TABLE, "psopt_singular_double_integrator"), closed_form=lambda: 10 / 3,
        statement=r"\min_{u,\,t_f} \int_0^{t_f} \tfrac12(1 + x_2^2)\,dt \quad\text{s.t.}\quad \dot x_1 = x_2,\ "
        r"\dot x_2 = u,\ |u| \le 1,\ x(0) = (2, 0),\ x(t_f) = (5, 0)",
    ),
    Reference(
        "psopt_moon_lander", "Moon lander, minimum fuel", "PSOPT Manual R5, Sec. 3.29 (after PROPT); examples/moon",
        moon_lander, ("bang-bang", "free-final-time", "aerospace"),
        paper=(TABLE, "psopt_moon_lander"), closed_form=moon_lander_fuel,
        agreement=1e-7, why="coast, then full thrust: the switching time converges at a low order",
        statement=r"\min_{T,\,t_f} \int_0^{t_f} T\,dt \quad\text{s.t.}\quad \dot h = v,\ \dot v = -g + T/m,\ "
        r"\dot m = -T/c,\ 0 \le T \le 1.227,\ h(t_f) = v(t_f) = 0",
    ),
)  # fmt: skip
