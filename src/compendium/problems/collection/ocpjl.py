"""Reference-collection problems of OptimalControlProblems.jl (control-toolbox: each problem as an OptimalControl model
and a JuMP model, solved on one grid; github.com/control-toolbox/OptimalControlProblems.jl): constants in
``data/problems/collection_ocpjl.toml``, the objective values its documentation pages print in
``data/paper/collection_ocpjl.csv`` (each the optimum of its trapezoidal NLP on its grid: ``discretised``)."""

from __future__ import annotations

import math

import casadi as ca

from ocpkit import Control, FreeFinalTime, OptimalControlProblem, State

from . import Reference, constants, register

TABLE = "collection_ocpjl"


def vanderpol() -> OptimalControlProblem:
    """The controlled Van der Pol oscillator, quadratic cost on a fixed horizon (OptimalControlProblems.jl, BOCOP)."""
    c = constants(TABLE, "vanderpol")
    w, e = c["omega"], c["epsilon"]
    return OptimalControlProblem(
        "ocpjl_vanderpol",
        states=[State("x1", initial=c["x0"][0], guess=c["x0"][0]), State("x2", initial=c["x0"][1], guess=0.0)],
        controls=[Control("u", guess=0.0)],
        dynamics=lambda x, u, t: [x["x2"], e * w * (1 - x["x1"] ** 2) * x["x2"] - w**2 * x["x1"] + u["u"]],
        tf=c["tf"],
        lagrange=lambda x, u, t: (x["x1"] ** 2 + x["x2"] ** 2 + u["u"] ** 2) / 2,
    )


def double_oscillator() -> OptimalControlProblem:
    """Two masses, springs and a controlled damper under a periodic force (OptimalControlProblems.jl; CLP 2018)."""
    c = constants(TABLE, "double_oscillator")
    m1, m2, k1, k2, damping, T = c["m1"], c["m2"], c["k1"], c["k2"], c["c"], 2 * math.pi

    def dynamics(x, u, t):
        x1, x2, v1, v2 = x["x1"], x["x2"], x["x3"], x["x4"]
        return [
            v1,
            v2,
            -(k1 + k2) / m1 * x1 + k2 / m1 * x2 + ca.sin(2 * math.pi * t / T) / m1,
            k2 / m2 * (x1 - x2) - damping * (1 - u["u"]) / m2 * v2,
        ]

    return OptimalControlProblem(
        "ocpjl_double_oscillator",
        states=[State("x1", initial=0.0, guess=0.0), State("x2", initial=0.0, guess=0.0)]
        + [State(n, guess=0.0) for n in ("x3", "x4")],
        controls=[Control("u", -1.0, 1.0, guess=0.0)],
        dynamics=dynamics,
        tf=T,
        lagrange=lambda x, u, t: (x["x1"] ** 2 + x["x2"] ** 2 + u["u"] ** 2) / 2,
        objective_scale=1e-3,
    )


def dielectrophoretic_particle() -> OptimalControlProblem:
    """A particle steered by a dielectrophoretic field from x = 1 to x = 2 in minimum time (OptimalControlProblems.jl)."""
    c = constants(TABLE, "dielectrophoretic_particle")
    return OptimalControlProblem(
        "ocpjl_dielectrophoretic_particle",
        states=[
            State("x", initial=c["x0"], final=c["xf"], guess=(c["x0"], c["xf"])),
            State("y", initial=0.0, guess=0.5),
        ],
        controls=[Control("u", -1.0, 1.0, guess=0.5)],
        dynamics=lambda x, u, t: [x["y"] * u["u"] + c["alpha"] * u["u"] ** 2, -c["c"] * x["y"] + u["u"]],
        tf=FreeFinalTime(0.1, 100.0, 5.0),
        mayer=lambda x0, xf, t0, tf: tf,
    )


def mountain_car() -> OptimalControlProblem:
    """An underpowered car rocking out of a valley to the hilltop in minimum time (OptimalControlProblems.jl; Dymos)."""
    c = constants(TABLE, "mountain_car")
    lo, hi = c["pos_bounds"]
    return OptimalControlProblem(
        "ocpjl_mountain_car",
        states=[
            State("pos", lo, hi, initial=c["pos_t0"], final=c["pos_tf"], guess=(c["pos_t0"], c["pos_tf"])),
            State(
                "vel",
                -c["vel_max"],
                c["vel_max"],
                initial=0.0,
                final=(0.0, c["vel_max"]),
                scale=c["vel_max"],
                guess=0.0,
            ),
        ],
        controls=[Control("u", -1.0, 1.0, guess=0.0)],
        dynamics=lambda x, u, t: [x["vel"], c["a"] * u["u"] - c["b"] * ca.cos(c["c"] * x["pos"])],
        tf=FreeFinalTime(0.1, 1000.0, c["tf_guess"], scale=100.0),
        mayer=lambda x0, xf, t0, tf: tf,
        objective_scale=100.0,
    )


def _tf(solution) -> float:
    return float(solution.tf)


_MESH = "OptimalControlProblems.jl docs, N = 500 steps, trapezoidal"

register(
    Reference(
        "ocpjl_vanderpol", "Van der Pol oscillator, quadratic cost",
        "OptimalControlProblems.jl, vanderpol (after BOCOP); docs page 'Vanderpol'",
        vanderpol, ("smooth",), paper=(TABLE, "ocpjl_vanderpol"), kind="discretised", mesh=_MESH, start=(4, 10),
        statement=r"\min \tfrac12\int_0^2 (x_1^2 + x_2^2 + u^2)\,dt \quad\text{s.t.}\quad \dot x_1 = x_2,\ "
        r"\dot x_2 = \varepsilon\omega(1 - x_1^2)x_2 - \omega^2 x_1 + u,\ x(0) = (1, 0)",
    ),
    Reference(
        "ocpjl_double_oscillator", "Double oscillator with a controlled damper",
        "OptimalControlProblems.jl, double_oscillator (Coudurier, Lepreux & Petit 2018); docs page 'Double oscillator'",
        double_oscillator, ("smooth",), paper=(TABLE, "ocpjl_double_oscillator"),
        kind="discretised", mesh=_MESH, start=(4, 20),
        statement=r"\begin{aligned}&\min \tfrac12\int_0^{2\pi} (x_1^2 + x_2^2 + u^2)\,dt,\quad |u| \le 1,\ "
        r"x_1(0) = x_2(0) = 0,\\ &\dot x_1 = x_3,\ \dot x_2 = x_4,\ "
        r"\dot x_3 = \tfrac{-(k_1 + k_2)x_1 + k_2 x_2 + \sin t}{m_1},\ "
        r"\dot x_4 = \tfrac{k_2(x_1 - x_2) - c(1 - u)x_4}{m_2}\end{aligned}",
    ),
    Reference(
        "ocpjl_dielectrophoretic_particle", "Dielectrophoretic particle, minimum time",
        "OptimalControlProblems.jl, dielectrophoretic_particle (Chang, Petit & Rouchon 2006); docs page "
        "'Dielectrophoretic particle'",
        dielectrophoretic_particle, ("free-final-time", "path-constraint"),
        paper=(TABLE, "ocpjl_dielectrophoretic_particle"), quantity="tf", value=_tf, kind="discretised", mesh=_MESH,
        start=(4, 20),
        statement=r"\min t_f \quad\text{s.t.}\quad \dot x = y u + \alpha u^2,\ \dot y = -c y + u,\ |u| \le 1,\ "
        r"(x, y)(0) = (1, 0),\ x(t_f) = 2",
    ),
    Reference(
        "ocpjl_mountain_car", "Mountain car, minimum time",
        "OptimalControlProblems.jl, mountain_car (after Dymos' example; Moore 1990); docs page 'Mountain car'",
        mountain_car, ("free-final-time", "bang-bang"), paper=(TABLE, "ocpjl_mountain_car"), quantity="tf",
        value=_tf, kind="discretised", mesh="OptimalControlProblems.jl docs, N = 200 steps, trapezoidal",
        start=(3, 40), agreement=1e-6, why="bang-bang: the switchings converge at a low order",
        statement=r"\min t_f \quad\text{s.t.}\quad \dot p = v,\ \dot v = a u - b\cos(c p),\ |u| \le 1,\ "
        r"|v| \le 0.07,\ -1.2 \le p \le 0.5,\ (p, v)(0) = (-0.5, 0),\ p(t_f) = 0.5,\ v(t_f) \ge 0",
    ),
)  # fmt: skip
