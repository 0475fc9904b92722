"""The compendium's published problems already stated (notebooks 03, 06, 07 and 10), registered in the collection with
the tables that hold their published values (``data/paper/beyond_the_seeds.csv`` and the seeds' own tables)."""

from __future__ import annotations

import math

import numpy as np

from ocpkit import Control, Link, MultiPhaseProblem, OptimalControlProblem, State

from .. import (
    bryson_denham,
    bryson_denham_solution,
    catalyst_mixing,
    catenary,
    delta3_guesses,
    delta3_mass_drops,
    delta3_phases,
    double_integrator_solution,
    double_integrator_thrusters,
    flat_moon_ascent,
    free_flying_robot,
    gasoil_fit,
    goddard_rocket,
    hang_glider,
    hanging_chain,
    hyper_sensitive,
    linear_tangent_solution,
    miser3_state_constraint,
    orbit_raising,
    rayleigh_mixed,
    shuttle_reentry,
    tumour,
)
from . import Reference, register


def _final_state(index: int, scale: float = 1.0):
    def value(solution) -> float:
        return float(solution.state(solution.tf)[index]) * scale

    return value


def _negated(solution) -> float:
    return -float(solution.objective)


def _delta3() -> MultiPhaseProblem:
    phases, drops = delta3_phases(), delta3_mass_drops()
    return MultiPhaseProblem(phases, [Link(k, k + 1, jumps={"m": drops[k]}) for k in range(len(phases) - 1)])


def _delta3_final_mass(solution) -> float:
    return float(solution.phases[-1].state_values[-1, 6])


def hyper_sensitive_limit() -> float:
    """The hyper-sensitive problem's optimum as ``t_f -> infinity``: the two boundary layers' costs, the value
    functions of ``x' = -x^3 + u`` with cost ``(x^2 + u^2) / 2`` (the Hamilton-Jacobi-Bellman equation's stable and
    unstable branches, ``V' = sqrt(x^6 + x^2) -+ x^3``) from 1.5 down to 0 and from 0 up to 1. The finite horizon
    changes it by about ``exp(-t_f)``."""

    def layer(x: float) -> float:  # the integral of x sqrt(x^4 + 1) from 0 to x
        return (x * x * math.sqrt(x**4 + 1) + math.asinh(x * x)) / 4

    return layer(1.5) - 1.5**4 / 4 + layer(1.0) + 1.0 / 4


def hyper_sensitive_linear(tf: float = 10000.0) -> OptimalControlProblem:
    """ASSET's hyper-sensitive problem: ``x' = -x + u``, ``min 1/2 int (x^2 + u^2)``, ``x(0) = 1.5``, ``x(t_f) = 1``."""
    return OptimalControlProblem(
        "hyper_sensitive_linear",
        states=[State("x", initial=1.5, final=1.0)],
        controls=[Control("u")],
        dynamics=lambda x, u, t: -x[0] + u[0],
        tf=float(tf),
        lagrange=lambda x, u, t: (x[0] ** 2 + u[0] ** 2) / 2,
    )


def hyper_sensitive_linear_limit() -> float:
    """Its optimum as ``t_f -> infinity``: ``(sqrt(2) - 1) x0^2 / 2 + (sqrt(2) + 1) xf^2 / 2``, the Riccati
    equation's stable and unstable roots ``-1 +- sqrt(2)`` (the finite horizon changes it by about
    ``exp(-2 sqrt(2) t_f)``)."""
    return ((math.sqrt(2) - 1) * 1.5**2 + (math.sqrt(2) + 1) * 1.0**2) / 2


TABLE = "beyond_the_seeds"

register(
    Reference(
        "hang_glider", "Hang glider, maximum range", "Betts 2010 (3rd ed. 2020, Ex. 10.54); COPS 3.0",
        hang_glider, ("free-final-time", "aerospace", "path-constraint"),
        paper=(TABLE, "hang_glider"), quantity="final_range_m", value=_negated, start=(4, 100),
        statement=r"\max_{c_L,\,t_f} x(t_f) \quad\text{s.t. lift and drag in a thermal updraft}",
    ),
    Reference(
        "hang_glider_cops", "Hang glider, COPS 3.0's statement", "COPS 3.0 (Dolan, Moré & Munson 2004), hang glider",
        lambda: hang_glider(cops=True), ("free-final-time", "aerospace", "unscaled"),
        paper=(TABLE, "hang_glider_cops"), quantity="final_range_m", value=_negated, start=(4, 100),
        kind="discretised", mesh="COPS nh = 400, its discretisation",
        statement=r"\max_{c_L,\,t_f} x(t_f) \quad\text{(COPS' rounded constants, unscaled)}",
    ),
    Reference(
        "tumour_anti_angiogenesis", "Tumour anti-angiogenesis", "Ledzewicz & Schättler 2008; Betts 2010, Ex. 6.17",
        tumour, ("free-final-time", "singular-arc", "bang-bang"),
        paper=(TABLE, "tumour_anti_angiogenesis"), quantity="final_tumour_volume",
        agreement=1e-6, why="a singular arc between bang arcs: both schemes converge to it at a low order",
        statement=r"\min p(t_f)\quad \dot p = -\xi p \ln(p/q),\ \dot q = q(b - \mu - d p^{2/3} - G u),\ "
        r"\dot y = u,\ y(t_f) \le A,\ 0 \le u \le a",
    ),
    Reference(
        "catalyst_mixing", "Catalyst mixing", "COPS 3.0 (Dolan, Moré & Munson 2004), catalyst mixing",
        catalyst_mixing, ("singular-arc", "bang-bang"), start=(4, 30),
        paper=(TABLE, "catalyst_mixing"), kind="discretised", mesh="COPS, its own discretisation",
        agreement=1e-6, why="bang, singular, bang with a Mayer cost: the singular arc converges at a low order",
        statement=r"\min -1 + x_1(1) + x_2(1)\quad \dot x_1 = u(10x_2 - x_1),\ "
        r"\dot x_2 = u(x_1 - 10x_2) - (1-u)x_2,\ 0 \le u \le 1",
    ),
    Reference(
        "free_flying_robot", "Free-flying robot", "Sakawa 1999; Betts 2010, Ex. 6.13",
        free_flying_robot, ("bang-bang", "path-constraint"),
        paper=(TABLE, "free_flying_robot"), agreement=1e-6,
        indirect=False,  # the chain stops here after a minute, by name: notebook 10's row says why
        why="an L1 cost with bang-bang thrusters: the switchings converge at a low order",
        statement=r"\min \int_0^{12} (u_1 + u_2 + u_3 + u_4)\,dt,\ u_1 + u_2 \le 1,\ u_3 + u_4 \le 1",
    ),
    Reference(
        "miser3_state_constraint", "MISER3 state constraint", "Teo, Goh & Wong 1991; PSOPT stc1; PROPT",
        miser3_state_constraint, ("state-constraint-1",),
        paper=(TABLE, "miser3_state_constraint"), kind="discretised", mesh="PSOPT 20 then 50 nodes",
        start=(4, 50), agreement=1e-6, why="a state constraint on an interior arc: its junctions converge slowly",
        statement=r"\min \int_0^1 (x_1^2 + x_2^2 + 0.005u^2)\,dt,\ x_2 \le 8(t - 0.5)^2 - 0.5",
    ),
    Reference(
        "orbit_raising", "Maximum-radius orbit transfer", "Bryson & Ho 1975, Sec. 2.7",
        orbit_raising, ("smooth", "aerospace"),
        paper=(TABLE, "orbit_raising"), quantity="final_radius", value=_final_state(0), start=(4, 20),
        statement=r"\max r(t_f)\quad \text{thrust angle } \phi \text{ free, circular final orbit}",
    ),
    Reference(
        "rayleigh_mixed", "Rayleigh problem with a mixed constraint", "Maurer & Augustin 2001; Betts 2010, Sec. 4.14",
        rayleigh_mixed, ("mixed-constraint",),
        paper=(TABLE, "rayleigh_mixed"), start=(4, 20), kind="discretised",
        mesh="Betts' SOS solution (its final mesh; GMAT's CSALT test asserts it to 1e-7 relative)",
        statement=r"\min \int_0^{4.5} (u^2 + x_1^2)\,dt,\ \dot x_1 = x_2,\ "
        r"\dot x_2 = -x_1 + x_2(1.4 - 0.14x_2^2) + 4u,\ u + x_1/6 \le 0",
    ),
    Reference(
        "shuttle_reentry", "Space shuttle reentry, maximum crossrange", "Betts 2010, Ex. 6.1",
        shuttle_reentry, ("free-final-time", "aerospace"),
        paper=(TABLE, "shuttle_reentry"), quantity="final_latitude_deg", value=_final_state(2, 180 / math.pi),
        start=(4, 40),
        statement=r"\max \theta(t_f)\quad\text{lift and bank angle, spherical Earth, exponential atmosphere}",
    ),
    Reference(
        "hanging_chain", "Hanging chain", "COPS 3.0 (Dolan, Moré & Munson 2004), hanging chain",
        hanging_chain, ("closed-form",),
        paper=(TABLE, "hanging_chain"), closed_form=lambda: catenary()["J"], kind="discretised",
        mesh="COPS, its discretisation",
        statement=r"\min \int_0^1 x\sqrt{1 + u^2}\,dt,\ \dot x = u,\ \int_0^1 \sqrt{1+u^2}\,dt = L",
    ),
    Reference(
        "bryson_denham", "Bryson-Denham, l = 1/9", "Bryson & Ho 1975, Sec. 3.11",
        bryson_denham, ("state-constraint-2", "closed-form"),
        closed_form=lambda: bryson_denham_solution(np.zeros(1))["J"],
        agreement=1e-6, why="a state constraint of order two: the junctions converge at a low order",
        statement=r"\min \tfrac12\int_0^1 u^2\,dt,\ \dot x = v,\ \dot v = u,\ x \le 1/9",
    ),
    Reference(
        "goddard_cops", "Goddard rocket", "COPS 3.0 (Dolan, Moré & Munson 2004), Goddard rocket",
        goddard_rocket, ("singular-arc", "free-final-time", "aerospace"),
        paper=("goddard_cops", None), quantity="final_altitude", value=_negated, kind="discretised",
        mesh="COPS nh = 800", agreement=1e-6, why="full thrust, singular, coast: the singular arc",
        statement=r"\max h(t_f)\quad\text{thrust } 0 \le T \le T_{\max},\ \text{drag } D(h, v)",
    ),
    Reference(
        "goddard_speed_limit", "Goddard rocket with v <= 0.1", "control-toolbox (OptimalControl.jl), Goddard tutorial",
        lambda: goddard_rocket(v_max=0.1), ("singular-arc", "state-constraint-1", "aerospace"),
        paper=("goddard_control_toolbox", None), quantity="final_altitude", value=_negated, kind="discretised",
        mesh="OptimalControl.jl's direct solve in its tests, compared there at rtol 1e-2",
        agreement=1e-6, why="a singular arc and a boundary arc",
        statement=r"\max h(t_f)\quad\text{as Goddard, with } v \le 0.1",
    ),
    Reference(
        "cops_gasoil", "Catalytic cracking of gas oil", "COPS 3.0 (Dolan, Moré & Munson 2004), gas oil",
        None, ("parameter-estimation",),
        paper=("cops_gasoil", None), program=gasoil_fit, kind="discretised", mesh="COPS nh = 100, 200, 400",
        statement=r"\min_\theta \sum_j \|y(t_j) - z_j\|^2,\ \dot y_1 = -(\theta_1 + \theta_3) y_1^2,\ "
        r"\dot y_2 = \theta_1 y_1^2 - \theta_2 y_2",
    ),
    Reference(
        "delta3", "Delta III launch, four phases", "Betts 2010, Sec. 6.15; GPOPS-II (Patterson & Rao 2014)",
        _delta3, ("multi-phase", "aerospace", "path-constraint"),
        paper=("delta3_gpops2", None), quantity="final_mass", value=_delta3_final_mass, start=(8, 4),
        kind="discretised", mesh="Betts' SOCS solution, as public ports print it (yapss' optimum: 7529.712287)",
        # IPOPT's tolerance as notebook 06 solves it (at its default 1e-10 IPOPT stops at its acceptable level), and its
        # iterations capped, so that a mesh it cannot solve stops by name in seconds, not after 3000 slow iterations
        guess=delta3_guesses, ipopt_options={"tol": 1e-8, "max_iter": 500},
        # refined to 1e-8: to 1e-9, its meshes' solves run to IPOPT's iteration cap (over 140 s for Radau, measured)
        tightest=1e-8,
        statement=r"\max m(t_f)\quad\text{four phases, mass drops, a target orbit}",
    ),
    Reference(
        "double_integrator_min_fuel", "Minimum-fuel double integrator", "closed form (bang-off-bang)",
        double_integrator_thrusters, ("bang-bang", "closed-form"),
        closed_form=lambda: double_integrator_solution().fuel,
        agreement=1e-6, why="bang-off-bang: the switchings converge at a low order",
        statement=r"\min \int_0^T (u_+ + u_-)\,dt,\ \dot x_1 = x_2,\ \dot x_2 = u_+ - u_-,\ 0 \le u_\pm \le 1",
    ),
    Reference(
        "flat_moon", "Flat-moon ascent, minimum time", "Bryson & Ho 1975, Sec. 2.7 (linear tangent law)",
        flat_moon_ascent, ("free-final-time", "closed-form", "aerospace"),
        closed_form=lambda: linear_tangent_solution().tf, value=lambda s: float(s.tf), fast=True,
        statement=r"\min t_f\quad \ddot x = a\cos\theta,\ \ddot y = a\sin\theta - g",
    ),
    Reference(
        "hyper_sensitive", "Hyper-sensitive problem, t_f = 10000", "Rao & Mease 2000; GPOPS-II",
        hyper_sensitive, ("stiff", "closed-form"),
        closed_form=hyper_sensitive_limit, start=(4, 10), fast=True,
        statement=r"\min \tfrac12\int_0^{t_f}(x^2 + u^2)\,dt,\ \dot x = -x^3 + u,\ x(0) = 1.5,\ x(t_f) = 1",
    ),
    Reference(
        "hyper_sensitive_linear", "Hyper-sensitive problem, linear (ASSET's), t_f = 10000",
        "ASSET (Pezent et al. 2022), doc/examples/HyperSensitive.rst",
        hyper_sensitive_linear, ("stiff", "closed-form"),
        closed_form=hyper_sensitive_linear_limit, start=(4, 10),
        statement=r"\min \tfrac12\int_0^{t_f}(x^2 + u^2)\,dt,\ \dot x = -x + u,\ x(0) = 1.5,\ x(t_f) = 1",
    ),
)  # fmt: skip
