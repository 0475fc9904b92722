"""Reference-collection problems from the opty family of sources (csu-hmc/opty's examples-gallery, its ports in
pydy/pst-notebooks, pycollo's tests): constants in ``data/problems/collection_opty.toml``, published values in
``data/paper/collection_opty.csv``. opty's ports of Betts' test problems are registered by ``betts.py``."""

from __future__ import annotations

import math

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

TABLE = "collection_opty"


def sliding_mass() -> MultiPhaseProblem:
    """A unit mass slid from x = 0 to x = 1, at rest at both ends, in minimum time with |f| <= 20, in four phases
    of equal distance (pycollo, tests/integration/test_multiphase.py)."""
    c = constants(TABLE, "sliding_mass")
    n, f_max, v_max, t_max = c["phases"], c["f_max"], c["v_max"], c["t_max"]

    def segment(k: int) -> OptimalControlProblem:
        a, b = k / n, (k + 1) / n  # this phase's stretch of x
        return OptimalControlProblem(
            f"segment_{k + 1}",
            states=[
                State("x", a, b, initial=a, final=b, guess=(a, b)),
                State("v", 0.0, v_max, initial=0.0 if k == 0 else None, final=0.0 if k == n - 1 else None, guess=1.0),
            ],
            controls=[Control("f", -f_max, f_max, guess=0.0)],
            dynamics=lambda x, u, t: [x["v"], u["f"]],
            t0=0.0 if k == 0 else FreeInitialTime(0.0, t_max, a * t_max),
            tf=FreeFinalTime(0.01, t_max, b * t_max) if k == 0 else Duration(0.01, t_max, t_max / n),
        )

    return MultiPhaseProblem([segment(k) for k in range(n)], cost=lambda e: e[f"segment_{n}"].tf)


def sliding_mass_time() -> float:
    """Its exact minimum time: full thrust to x = 1/2, full braking after, t_f = 2 sqrt(1 / f_max)."""
    return 2 * math.sqrt(1 / constants(TABLE, "sliding_mass")["f_max"])


def hyper_sensitive() -> OptimalControlProblem:
    """The hyper-sensitive problem as Betts states it (Ex. 10.7; opty's port): y' = -y^3 + u from y = 1 to 1.5 over
    t_f = 10000, minimising int y^2 + u^2."""
    c = constants(TABLE, "hyper_sensitive")
    return OptimalControlProblem(
        "opty_betts_hyper_sensitive",
        states=[State("y", initial=c["y0"], final=c["yf"], guess=0.0)],
        controls=[Control("u", guess=0.0)],
        dynamics=lambda x, u, t: [-(x["y"] ** 3) + u["u"]],
        tf=c["tf"],
        lagrange=lambda x, u, t: x["y"] ** 2 + u["u"] ** 2,
    )


def hyper_sensitive_limit() -> float:
    """Its optimum as t_f -> infinity (exact here to e^(-2 t_f)): the two boundary layers' costs, from the
    Hamilton-Jacobi equation of the infinite-horizon problem, int_0^(y^2) sqrt(1 + w^2) dw -+ y^4 / 2 for the layer
    leaving y0 (-) and the layer reaching yf (+)."""
    c = constants(TABLE, "hyper_sensitive")

    def area(a: float) -> float:  # int_0^a sqrt(1 + w^2) dw
        return (a * math.sqrt(1 + a * a) + math.asinh(a)) / 2

    y0, yf = c["y0"], c["yf"]
    return area(y0**2) - y0**4 / 2 + area(yf**2) + yf**4 / 2


def vdp_piecewise_constant() -> MultiPhaseProblem:
    """Van der Pol brought near rest over 10 s by a control constant on each of six intervals, x1 >= -0.25 at the
    interval ends (Rockit, tests/problems.py vdp, whose exact optimum tests/test_misc.py quotes): one phase per
    interval, its control a parameter of its own."""
    c = constants(TABLE, "vdp_piecewise_constant")
    n, h = c["pieces"], c["T"] / c["pieces"]

    def floor(k: int) -> list[Constraint]:  # at the grid points: every phase's start, and the last one's end
        ends = [Constraint("x1_floor", lambda x0, xf, t0, tf: x0["x1"], lower=c["x1_min"])]
        if k == n - 1:
            ends.append(Constraint("x1_floor_end", lambda x0, xf, t0, tf: xf["x1"], lower=c["x1_min"]))
        return ends

    def piece(k: int) -> OptimalControlProblem:
        return OptimalControlProblem(
            f"piece_{k + 1}",
            states=[
                State("x1", initial=c["initial"][0] if k == 0 else None, guess=0.0),
                State("x2", initial=c["initial"][1] if k == 0 else None, guess=0.5),
            ],
            controls=[],
            dynamics=lambda x, u, t, p: [(1 - x["x2"] ** 2) * x["x1"] - x["x2"] + p["u"], x["x1"]],
            t0=k * h,
            tf=(k + 1) * h,
            lagrange=lambda x, u, t, p: x["x1"] ** 2 + x["x2"] ** 2 + p["u"] ** 2,
            free_parameters=[FreeParameter("u", *c["u"], guess=0.0)],
            boundary_constraints=floor(k),
        )

    return MultiPhaseProblem([piece(k) for k in range(n)], local_parameters=["u"])


register(
    Reference(
        "pycollo_sliding_mass", "Sliding mass in four phases, minimum time",
        "pycollo (github brocksam/pycollo), tests/integration/test_multiphase.py",
        sliding_mass, ("multi-phase", "bang-bang", "free-final-time", "closed-form"),
        paper=(TABLE, "pycollo_sliding_mass"), quantity="final_time", closed_form=sliding_mass_time,
        start=(4, 4),
        statement=r"\min t_f \quad\text{s.t.}\quad \dot x = v,\ \dot v = f,\ |f| \le 20,\ "
        r"x(0) = 0,\ x(t_f) = 1,\ v(0) = v(t_f) = 0;\ \text{phase } k \text{ on } x \in [\tfrac{k-1}{4}, \tfrac{k}{4}]",
    ),
    Reference(
        "opty_betts_hyper_sensitive", "Hyper-sensitive problem as Betts states it, t_f = 10000",
        "Betts 2020, Ex. 10.7, as opty's examples-gallery states it (beginner/plot_betts_10_7.py)",
        hyper_sensitive, ("stiff", "closed-form"),
        paper=(TABLE, "opty_betts_hyper_sensitive"), closed_form=hyper_sensitive_limit, start=(4, 10),
        statement=r"\min \int_0^{10000} y^2 + u^2\,dt \quad\text{s.t.}\quad \dot y = -y^3 + u,\ y(0) = 1,\ "
        r"y(10000) = 1.5",
    ),
    Reference(
        "rockit_vdp_piecewise_constant", "Van der Pol with a piecewise-constant control (six pieces)",
        "Rockit (github meco-group/rockit), tests/problems.py (vdp) and tests/test_misc.py (test_grid_convergence)",
        vdp_piecewise_constant, ("multi-phase", "parameter-estimation"),
        paper=(TABLE, "rockit_vdp_piecewise_constant"), start=(4, 4), fast=True,
        differs="Rockit's value is IPOPT's optimum with its bounds relaxed by IPOPT's default bound_relax_factor "
        "(1e-8: u beyond +/-1, x1 below -0.25 by as much): refined so, the converged value is Rockit's to 1e-11 "
        "(tests/test_collection.py); with the bounds relaxed by 1e-11, as a refinement to 1e-9 relaxes them, it is "
        "1.6e-8 above",
        statement=r"\begin{aligned}&\min \int_0^{10} x_1^2 + x_2^2 + u^2\,dt \quad\text{s.t.}\quad "
        r"\dot x_1 = (1 - x_2^2)x_1 - x_2 + u,\ \dot x_2 = x_1,\ x(0) = (0, 1),\\ "
        r"&u = u_k \in [-1, 1] \text{ on } [\tfrac{10k}{6}, \tfrac{10(k+1)}{6}),\ k = 0, \dots, 5,\ "
        r"x_1(\tfrac{10j}{6}) \ge -0.25,\ j = 0, \dots, 6\end{aligned}",
    ),
)  # fmt: skip
