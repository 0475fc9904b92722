"""Textbook problems of the reference collection, most with a closed form: the brachistochrone, Zermelo's navigation
in a linear current, the minimum-time double integrator, Bryson-Denham's two regimes (a boundary arc, a touch point),
the bang-singular-bang turnpike, the unconstrained Rayleigh problem, linear-quadratic regulators with a fixed and a
free final time, and a minimum-energy problem with a free final time. Constants in
``data/problems/collection_classics.toml``, published values in ``data/paper/collection_classics.csv``.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq, fsolve

from ocpkit import Constraint, Control, FreeFinalTime, OptimalControlProblem, State

from ..bryson_denham import bryson_denham_solution
from . import Reference, constants, register

TABLE = "collection_classics"


# -- the statements -------------------------------------------------------------------------------------------------
def brachistochrone() -> OptimalControlProblem:
    """Slide from rest at (0, 10) to (10, 5) in the least time (Dymos' brachistochrone, theta from the vertical)."""
    c = constants(TABLE, "brachistochrone")
    (x0, y0), (x1, y1), g = c["start"], c["end"], c["g"]
    return OptimalControlProblem(
        "classic_brachistochrone",
        states=[
            State("x", 0.0, 20.0, initial=x0, final=x1, guess=(x0, x1), scale=10.0),
            State("y", 0.0, 20.0, initial=y0, final=y1, guess=(y0, y1), scale=10.0),
            State("v", 0.0, 50.0, initial=0.0, guess=(0.0, 10.0), scale=10.0),
        ],
        controls=[Control("theta", 0.0, math.pi, guess=(0.1, 1.7))],
        dynamics=lambda x, u, t: [x["v"] * ca.sin(u["theta"]), -x["v"] * ca.cos(u["theta"]), g * ca.cos(u["theta"])],
        tf=FreeFinalTime(c["tf"][0], c["tf"][1], c["tf_guess"]),
        mayer=lambda x0, xf, t0, tf: tf,
    )


def min_time_double_integrator() -> OptimalControlProblem:
    """Bring the double integrator from (-1, 0) to rest at the origin in the least time, |u| <= 1 (CTProblems.jl)."""
    c = constants(TABLE, "min_time_double_integrator")
    (q0, v0), (q1, v1) = c["x0"], c["xf"]
    return OptimalControlProblem(
        "classic_min_time_double_integrator",
        states=[State("q", initial=q0, final=q1, guess=(q0, q1)), State("v", initial=v0, final=v1, guess=0.5)],
        controls=[Control("u", -c["u_max"], c["u_max"], guess=0.0)],
        dynamics=lambda x, u, t: [x["v"], u["u"]],
        tf=FreeFinalTime(c["tf"][0], c["tf"][1], c["tf_guess"]),
        mayer=lambda x0, xf, t0, tf: tf,
    )


def bryson_denham(regime: str) -> OptimalControlProblem:
    """Minimise 1/2 int u^2 from (0, 1) to (0, -1) in unit time under x <= l (Bryson & Ho 1975, Sec. 3.11)."""
    c = constants(TABLE, "bryson_denham")
    limit = c[regime]
    return OptimalControlProblem(
        f"classic_bryson_denham_{regime}",
        states=[
            State("x", initial=0.0, final=0.0, guess=limit / 2),
            State("v", initial=1.0, final=-1.0, guess=(1, -1)),
        ],
        controls=[Control("u", -c["u_max"], c["u_max"], guess=-2.0)],
        dynamics=lambda x, u, t: [x["v"], u["u"]],
        tf=1.0,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
        path_constraints=[Constraint("x_max", lambda x, u, t: x["x"], upper=limit)],
    )


def turnpike() -> OptimalControlProblem:
    """Minimise int x^2 with x' = u, |u| <= 1, from x(0) = 1 to x(2) = 1/2 (OptimalControl.jl's turnpike)."""
    c = constants(TABLE, "turnpike")
    return OptimalControlProblem(
        "classic_turnpike",
        states=[State("x", initial=c["x0"], final=c["xf"], guess=(c["x0"], c["xf"]))],
        controls=[Control("u", -c["u_max"], c["u_max"], guess=0.0)],
        dynamics=lambda x, u, t: [u["u"]],
        tf=c["tf"],
        lagrange=lambda x, u, t: x["x"] ** 2,
    )


def lqr_oscillator() -> OptimalControlProblem:
    """Regulate the harmonic oscillator from (0, 1): minimise 1/2 int |x|^2 + u^2 over [0, 5] (CTProblems.jl)."""
    c = constants(TABLE, "lqr_oscillator")
    return OptimalControlProblem(
        "classic_lqr_oscillator",
        states=[State("x1", initial=c["x0"][0], guess=0.0), State("x2", initial=c["x0"][1], guess=0.0)],
        controls=[Control("u", guess=0.0)],
        dynamics=lambda x, u, t: [x["x2"], -x["x1"] + u["u"]],
        tf=c["tf"],
        lagrange=lambda x, u, t: (x["x1"] ** 2 + x["x2"] ** 2 + u["u"] ** 2) / 2,
    )


def lqr_free_time() -> OptimalControlProblem:
    """Steer x' = u from 0 to 1 minimising tf + 1/2 int x^2 + u^2, the final time free (CTProblems.jl)."""
    c = constants(TABLE, "lqr_free_time")
    return OptimalControlProblem(
        "classic_lqr_free_time",
        states=[State("x", initial=c["x0"], final=c["xf"], guess=(c["x0"], c["xf"]))],
        controls=[Control("u", guess=1.0)],
        dynamics=lambda x, u, t: [u["u"]],
        tf=FreeFinalTime(c["tf"][0], c["tf"][1], c["tf_guess"]),
        mayer=lambda x0, xf, t0, tf: tf,
        lagrange=lambda x, u, t: (x["x"] ** 2 + u["u"] ** 2) / 2,
    )


def energy_free_time() -> OptimalControlProblem:
    """Steer x' = u from 0 to x(tf) = tf + 10 minimising 1/2 int u^2, the final time free (CTProblems.jl)."""
    c = constants(TABLE, "energy_free_time")
    return OptimalControlProblem(
        "classic_energy_free_time",
        states=[State("x", initial=c["x0"], guess=(c["x0"], c["tf_guess"] + c["offset"]), scale=10.0)],
        controls=[Control("u", guess=2.0)],
        dynamics=lambda x, u, t: [u["u"]],
        tf=FreeFinalTime(c["tf"][0], c["tf"][1], c["tf_guess"], scale=10.0),
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
        boundary_constraints=[
            Constraint("target", lambda x0, xf, t0, tf: xf["x"] - tf - c["offset"], lower=0.0, upper=0.0)
        ],
        objective_scale=10.0,
    )


def zermelo() -> OptimalControlProblem:
    """Steer at unit speed through the current ``c y`` from (3.5, -1.8) to the origin in the least time (Betts)."""
    c = constants(TABLE, "zermelo")
    (x0, y0), speed, shear = c["start"], c["speed"], c["shear"]
    return OptimalControlProblem(
        "classic_zermelo",
        states=[State("x", initial=x0, final=0.0, guess=(x0, 0.0)), State("y", initial=y0, final=0.0, guess=(y0, 0.0))],
        controls=[Control("theta", period=2 * math.pi, guess=(1.8, 4.2))],
        dynamics=lambda x, u, t: [speed * ca.cos(u["theta"]) + shear * x["y"], speed * ca.sin(u["theta"])],
        tf=FreeFinalTime(c["tf"][0], c["tf"][1], c["tf_guess"]),
        mayer=lambda x0, xf, t0, tf: tf,
    )


def rayleigh() -> OptimalControlProblem:
    """Minimise int x1^2 + u^2 over [0, 2.5] for the Rayleigh oscillator from (-5, -5), the end free (PROPT)."""
    c = constants(TABLE, "rayleigh")
    (a, b), gain = c["damping"], c["gain"]
    return OptimalControlProblem(
        "classic_rayleigh",
        states=[State("x1", initial=c["x0"][0], guess=0.0), State("x2", initial=c["x0"][1], guess=0.0)],
        controls=[Control("u", guess=0.0)],
        dynamics=lambda x, u, t: [x["x2"], -x["x1"] + x["x2"] * (a - b * x["x2"] ** 2) + gain * u["u"]],
        tf=c["tf"],
        lagrange=lambda x, u, t: x["x1"] ** 2 + u["u"] ** 2,
    )


# -- their closed forms ---------------------------------------------------------------------------------------------
def brachistochrone_time() -> float:
    """The cycloid's descent time: ``x = R (phi - sin phi)``, drop ``R (1 - cos phi)``, ``t = phi sqrt(R / g)``."""
    c = constants(TABLE, "brachistochrone")
    (x0, y0), (x1, y1), g = c["start"], c["end"], c["g"]
    ratio = (x1 - x0) / (y0 - y1)
    phi = brentq(lambda p: p - math.sin(p) - ratio * (1 - math.cos(p)), 1e-6, 2 * math.pi - 1e-9, xtol=1e-15)
    radius = (y0 - y1) / (1 - math.cos(phi))
    return phi * math.sqrt(radius / g)


def zermelo_time() -> float:
    """Bryson & Ho's linear-current solution: ``tan(theta) = tan(theta_0) - c t / V``, so that ``y`` and ``x`` are
    integrals of ``sec(theta)`` and ``sec(theta)^3`` over ``theta``; ``(theta_0, t_f)`` put the end at the origin."""
    c = constants(TABLE, "zermelo")
    (x0, y0), speed, shear = c["start"], c["speed"], c["shear"]
    sec = lambda a: 1 / math.cos(a)  # noqa: E731
    log_sec = lambda a: math.log(abs(sec(a) + math.tan(a)))  # noqa: E731  (the integral of sec)
    sec3 = lambda a: (sec(a) * math.tan(a) + log_sec(a)) / 2  # noqa: E731  (the integral of sec^3)

    def ends(z):  # on the branch theta in (pi/2, 3 pi/2): heading upstream, against the current
        th0, tf = z
        th1 = math.pi + math.atan(math.tan(th0) - shear * tf / speed)
        rate = -shear  # d tan(theta) / dt, so that dt = sec^2(theta) dtheta / rate
        y1 = y0 + speed * (sec(th1) - sec(th0)) / rate
        x_current = shear * ((y0 - speed * sec(th0) / rate) * tf + speed * (sec3(th1) - sec3(th0)) / rate**2)
        return [x0 + speed * (log_sec(th1) - log_sec(th0)) / rate + x_current, y1]

    return float(fsolve(ends, (1.8, c["tf_guess"]), xtol=1e-14)[1])


def bryson_denham_cost(regime: str) -> float:
    """``4 / (9 l)`` on a boundary arc (``l <= 1/6``); with a touch point at ``t = 1/2`` (``1/6 <= l <= 1/4``), the
    cubic ``x = t + a t^2 + b t^3`` with ``v(1/2) = 0``, ``x(1/2) = l``: ``a = 12 l - 4``, ``b = 4 - 16 l``."""
    limit = constants(TABLE, "bryson_denham")[regime]
    if limit <= 1 / 6:
        return 4 / (9 * limit)
    c0, c1 = 2 * (12 * limit - 4), 6 * (4 - 16 * limit)  # u = c0 + c1 t on [0, 1/2], mirrored on [1/2, 1]
    return c0**2 / 2 + c0 * c1 / 4 + c1**2 / 24


def bryson_denham_extremal(regime: str) -> dict[str, float]:
    """The closed form's junctions, costate jumps and cost (Bryson & Ho 1975, Sec. 3.11): on a boundary arc
    (``l <= 1/6``) entered at ``3 l`` and left at ``1 - 3 l``, ``lambda_x`` jumps by ``2 / (9 l^2)`` at each; at the
    touch point ``t = 1/2`` (``1/6 <= l <= 1/4``) by ``2 u' = 12 (4 - 16 l)`` (``u`` the cubic's second derivative,
    :func:`bryson_denham_cost`)."""
    limit = constants(TABLE, "bryson_denham")[regime]
    if limit <= 1 / 6:  # the seeds' closed form (compendium.problems.bryson_denham)
        exact = bryson_denham_solution(np.zeros(1), limit)
        (t1, t2), jump = exact["junctions"], exact["atom"]
        return {"t1": t1, "t2": t2, "jump1": jump, "jump2": jump, "objective": exact["J"]}
    return {"t1": 0.5, "jump1": 12 * (4 - 16 * limit), "objective": bryson_denham_cost(regime)}


def turnpike_extremal() -> dict[str, float]:
    """Full braking to ``x = 0`` at ``t1 = x0 / u_max``, the singular arc ``x = 0`` to ``t2 = tf - xf / u_max``, full
    thrust to ``xf``: ``J = (x0^3 + xf^3) / (3 u_max)`` (3/8 for OptimalControl.jl's turnpike)."""
    c = constants(TABLE, "turnpike")
    return {
        "t1": c["x0"] / c["u_max"],
        "t2": c["tf"] - c["xf"] / c["u_max"],
        "objective": (c["x0"] ** 3 + c["xf"] ** 3) / (3 * c["u_max"]),
    }


def lqr_oscillator_cost() -> float:
    """``x0' p0 / 2``, the costate ``p0`` from the Hamiltonian flow's exponential and ``p(tf) = 0``."""
    c = constants(TABLE, "lqr_oscillator")
    a, b = np.array([[0.0, 1.0], [-1.0, 0.0]]), np.array([[0.0], [1.0]])
    flow = expm(np.block([[a, -b @ b.T], [-np.eye(2), -a.T]]) * c["tf"])
    x0 = np.array(c["x0"])
    p0 = -np.linalg.solve(flow[2:, 2:], flow[2:, :2] @ x0)
    return float(x0 @ p0 / 2)


def lqr_free_time_cost() -> float:
    """``tf + coth(tf) / 2`` at ``sinh(tf)^2 = 1/2`` (``x(tf) = 1``)."""
    c = constants(TABLE, "lqr_free_time")
    tf = math.atanh(math.sqrt(c["xf"] ** 2 / (2 + c["xf"] ** 2)))
    return tf + c["xf"] ** 2 / (2 * math.tanh(tf))


def _tf(solution) -> float:
    return float(solution.tf)


SINGULAR = "a bang-singular-bang control: the junctions converge at a low order"

register(
    Reference(
        "classic_brachistochrone", "Brachistochrone, minimum time", "Bernoulli 1696; Dymos' brachistochrone example",
        brachistochrone, ("free-final-time", "closed-form"),
        paper=(TABLE, "classic_brachistochrone"), quantity="final_time", value=_tf, closed_form=brachistochrone_time,
        statement=r"\min t_f\quad \dot x = v\sin\theta,\ \dot y = -v\cos\theta,\ \dot v = g\cos\theta,\ "
        r"(x, y)(0) = (0, 10),\ (x, y)(t_f) = (10, 5)",
    ),
    Reference(
        "classic_zermelo", "Zermelo's navigation problem, linear current", "Betts 2020, Ex. 10.148; Bryson & Ho, Sec. 2.7",
        zermelo, ("free-final-time", "closed-form"),
        paper=(TABLE, "classic_zermelo"), quantity="final_time", value=_tf, closed_form=zermelo_time,
        statement=r"\min t_f\quad \dot x = \cos\theta - y,\ \dot y = \sin\theta,\ (x, y)(0) = (3.5, -1.8),\ "
        r"(x, y)(t_f) = (0, 0)",
    ),
    Reference(
        "classic_min_time_double_integrator", "Minimum-time double integrator", "CTProblems.jl, double_integrator_time",
        min_time_double_integrator, ("bang-bang", "free-final-time", "closed-form"),
        quantity="final_time", value=_tf, closed_form=lambda: 2.0,
        statement=r"\min t_f\quad \dot q = v,\ \dot v = u,\ |u| \le 1,\ (q, v)(0) = (-1, 0),\ (q, v)(t_f) = (0, 0)",
    ),
    Reference(
        "classic_bryson_denham_boundary_arc", "Bryson-Denham, l = 0.1 (boundary arc)", "Bryson & Ho 1975, Sec. 3.11",
        lambda: bryson_denham("boundary_arc"), ("state-constraint-2", "closed-form"),
        closed_form=lambda: bryson_denham_cost("boundary_arc"),
        agreement=1e-6, why="a state constraint of order two: the junctions converge at a low order",
        statement=r"\min \tfrac12\int_0^1 u^2\,dt,\ \dot x = v,\ \dot v = u,\ (x, v)(0) = (0, 1),\ "
        r"(x, v)(1) = (0, -1),\ x \le 0.1",
    ),
    Reference(
        "classic_bryson_denham_touch_point", "Bryson-Denham, l = 0.2 (touch point)", "Bryson & Ho 1975, Sec. 3.11",
        lambda: bryson_denham("touch_point"), ("state-constraint-2", "closed-form"),
        closed_form=lambda: bryson_denham_cost("touch_point"),
        agreement=1e-6, why="a state constraint of order two met at one point",
        statement=r"\min \tfrac12\int_0^1 u^2\,dt,\ \dot x = v,\ \dot v = u,\ (x, v)(0) = (0, 1),\ "
        r"(x, v)(1) = (0, -1),\ x \le 0.2",
    ),
    Reference(
        "classic_turnpike", "Turnpike, bang-singular-bang", "OptimalControl.jl, turnpike example",
        turnpike, ("singular-arc", "bang-bang", "closed-form"),
        paper=(TABLE, "classic_turnpike"), closed_form=lambda: 3 / 8, agreement=1e-6, why=SINGULAR,
        statement=r"\min \int_0^2 x^2\,dt,\ \dot x = u,\ |u| \le 1,\ x(0) = 1,\ x(2) = \tfrac12",
    ),
    Reference(
        "classic_rayleigh", "Rayleigh problem, unconstrained", "TOMLAB PROPT, Rayleigh Unconstrained (Liang 2003)",
        rayleigh, ("smooth",),
        paper=(TABLE, "classic_rayleigh"), kind="discretised", mesh="PROPT, 50 collocation points",
        statement=r"\min \int_0^{2.5} (x_1^2 + u^2)\,dt,\ \dot x_1 = x_2,\ "
        r"\dot x_2 = -x_1 + x_2(1.4 - 0.14x_2^2) + 4u,\ x(0) = (-5, -5)",
    ),
    Reference(
        "classic_lqr_oscillator", "Linear-quadratic regulator, harmonic oscillator", "CTProblems.jl, lqr_ricatti",
        lqr_oscillator, ("smooth", "closed-form"),
        closed_form=lqr_oscillator_cost, fast=True,
        statement=r"\min \tfrac12\int_0^5 (x_1^2 + x_2^2 + u^2)\,dt,\ \dot x_1 = x_2,\ \dot x_2 = -x_1 + u,\ "
        r"x(0) = (0, 1)",
    ),
    Reference(
        "classic_lqr_free_time", "Linear-quadratic cost, free final time", "CTProblems.jl, simple_integrator_lqr_free_tf",
        lqr_free_time, ("smooth", "free-final-time", "closed-form"),
        closed_form=lqr_free_time_cost,
        statement=r"\min t_f + \tfrac12\int_0^{t_f} (x^2 + u^2)\,dt,\ \dot x = u,\ x(0) = 0,\ x(t_f) = 1",
    ),
    Reference(
        "classic_energy_free_time", "Minimum energy, free final time", "CTProblems.jl, simple_integrator_energy_free_tf",
        energy_free_time, ("smooth", "free-final-time", "closed-form"),
        closed_form=lambda: 20.0,
        statement=r"\min \tfrac12\int_0^{t_f} u^2\,dt,\ \dot x = u,\ x(0) = 0,\ x(t_f) = t_f + 10",
    ),
)  # fmt: skip
