"""Betts' test problems (*Practical Methods for Optimal Control Using Nonlinear Programming*, 3rd ed., SIAM 2020,
Chapter 10), registered in the collection; constants in ``data/problems/collection_betts.toml``, published values in
``data/paper/collection_betts.csv``."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ocpkit import Constraint, Control, FreeFinalTime, OptimalControlProblem, State

from ..flat_moon import LinearTangentSolution
from . import Reference, constants, register

TABLE = "collection_betts"


def van_der_pol() -> OptimalControlProblem:
    """Van der Pol oscillator brought to rest, its velocity bounded below (Betts 2020, Ex. 10.144)."""
    c = constants(TABLE, "van_der_pol")
    return OptimalControlProblem(
        "betts_van_der_pol_state_constraint",
        states=[
            State("y1", initial=c["initial"][0], guess=(c["initial"][0], 0.0)),
            State("y2", c["y2_min"], initial=c["initial"][1], guess=0.0),
        ],
        controls=[Control("u", guess=0.0)],
        dynamics=lambda x, u, t: [x["y2"], (1 - x["y1"] ** 2) * x["y2"] - x["y1"] + u["u"]],
        tf=c["tf"],
        lagrange=lambda x, u, t: u["u"] ** 2 + x["y1"] ** 2 + x["y2"] ** 2,
        description="Van der Pol oscillator with y2 >= -0.4 (Betts 2020, Ex. 10.144)",
    )


def linear_tangent_steering() -> OptimalControlProblem:
    """Linear tangent steering: reach a height and a horizontal speed in minimum time (Betts 2020, Ex. 10.73)."""
    c = constants(TABLE, "linear_tangent_steering")
    a, (y_f, vx_f, vy_f) = c["a"], c["final"]
    return OptimalControlProblem(
        "betts_linear_tangent_steering",
        states=[
            State("x", initial=0.0, guess=(0.0, 12.0)),
            State("y", initial=0.0, final=y_f, guess=(0.0, y_f)),
            State("vx", initial=0.0, final=vx_f, guess=(0.0, vx_f), scale=10.0),
            State("vy", initial=0.0, final=vy_f, guess=10.0, scale=10.0),
        ],
        controls=[Control("u", -math.pi / 2, math.pi / 2, guess=0.0)],
        dynamics=lambda x, u, t: [x["vx"], x["vy"], a * ca.cos(u["u"]), a * ca.sin(u["u"])],
        tf=FreeFinalTime(*c["tf"], c["tf_guess"]),
        mayer=lambda x0, xf, t0, tf: tf,
        description="Linear tangent steering, minimum time (Betts 2020, Ex. 10.73)",
    )


def linear_tangent_steering_time() -> float:
    """Its exact minimum time: the linear tangent law ``tan u = tan u0 - c t`` (no gravity), whose three terminal
    conditions fix ``(tan u0, c, t_f)``."""
    from scipy.optimize import root  # here, not at import: posing the problem needs no SciPy

    c = constants(TABLE, "linear_tangent_steering")
    target = np.array(c["final"])

    def residual(z):
        return (LinearTangentSolution(c["a"], 0.0, z[0], z[1], z[2]).state(z[2])[1:] - target) / 10.0

    solution = root(residual, [1.0, 5.0, c["tf_guess"]], method="hybr", tol=1e-14)
    if np.max(np.abs(solution.fun)) > 1e-10:
        raise RuntimeError(f"linear tangent steering: the terminal conditions were not met ({solution.message})")
    return float(solution.x[2])


def pendulum_dae() -> OptimalControlProblem:
    """A pendulum steered to the bottom of its swing with least effort (Betts 2020, Ex. 10.103): an index-one DAE,
    its algebraic variable ``y5`` (the tension) eliminated, its bounds a path constraint."""
    c = constants(TABLE, "pendulum_dae")
    g, box = c["g"], c["box"]

    def tension(x):
        return (x["y3"] ** 2 + x["y4"] ** 2 - g * x["y2"]) / 2

    return OptimalControlProblem(
        "betts_pendulum_dae",
        states=[
            State("y1", -box, box, initial=c["initial"][0], final=0.0, guess=(1.0, 0.0)),
            State("y2", -box, box, initial=c["initial"][1], guess=-0.5),
            State("y3", -box, box, initial=c["initial"][2], final=0.0, guess=0.0),
            State("y4", -box, box, initial=c["initial"][3], guess=0.0),
        ],
        controls=[Control("u", guess=0.0)],
        dynamics=lambda x, u, t: [
            x["y3"],
            x["y4"],
            -2 * tension(x) * x["y1"] + u["u"] * x["y2"],
            -g - 2 * tension(x) * x["y2"] - u["u"] * x["y1"],
        ],
        tf=c["tf"],
        lagrange=lambda x, u, t: u["u"] ** 2,
        path_constraints=[Constraint("tension", lambda x, u, t: tension(x), *c["y5"])],
        description="Pendulum DAE, minimum effort (Betts 2020, Ex. 10.103)",
    )


def delay() -> OptimalControlProblem:
    """x'(t) = x(t - 1) u(t - 2) by the method of steps, x + u >= 0.3 (Göllmann, Kern & Maurer; Betts 2020,
    Ex. 10.50)."""
    c = constants(TABLE, "delay")
    n = c["steps"]

    def dynamics(x, u, t):
        x_before = [c["x_history"]] + [x[k] for k in range(n - 1)]  # x(t - 1) on each step
        u_before = [c["u_history"]] * 2 + [u[k] for k in range(n - 2)]  # u(t - 2)
        return [x_before[k] * u_before[k] for k in range(n)]

    return OptimalControlProblem(
        "betts_delay",
        states=[State(f"x{k + 1}", initial=c["x_history"] if k == 0 else None, guess=0.5) for k in range(n)],
        controls=[Control(f"u{k + 1}", guess=0.0) for k in range(n)],
        dynamics=dynamics,
        tf=1.0,
        lagrange=lambda x, u, t: ca.sumsqr(x) + ca.sumsqr(u),
        path_constraints=[Constraint("floor", lambda x, u, t: x + u, lower=c["floor"])],
        boundary_constraints=[
            Constraint("continuity", lambda x0, xf, t0, tf: x0[1:] - xf[: n - 1], lower=0.0, upper=0.0)
        ],
        description="Delay equation by the method of steps (Göllmann, Kern & Maurer 2009; Betts 2020, Ex. 10.50)",
    )


def nonconvex_delay() -> OptimalControlProblem:
    """x'(t) = x(t - 0.5)^2 - u(t) by the method of steps, x >= 0.7 (Maurer 2009; Betts 2020, Ex. 10.90)."""
    c = constants(TABLE, "nonconvex_delay")
    n, lag = c["steps"], c["lag"]

    def dynamics(x, u, t):
        return [(c["x_history"] if k < lag else x[k - lag]) ** 2 - u[k] for k in range(n)]

    return OptimalControlProblem(
        "betts_nonconvex_delay",
        states=[
            State(f"x{k + 1}", c["x_min"], initial=c["x_history"] if k == 0 else None, guess=1.0) for k in range(n)
        ],
        controls=[Control(f"u{k + 1}", guess=0.0) for k in range(n)],
        dynamics=dynamics,
        tf=c["step"],
        lagrange=lambda x, u, t: ca.sumsqr(x) + ca.sumsqr(u),
        boundary_constraints=[
            Constraint("continuity", lambda x0, xf, t0, tf: x0[1:] - xf[: n - 1], lower=0.0, upper=0.0)
        ],
        description="Nonconvex delay problem by the method of steps (Maurer 2009; Betts 2020, Ex. 10.90)",
    )


def tuberculosis() -> OptimalControlProblem:
    """Two-strain tuberculosis: case finding and treatment that minimise the resistant strain's latent and infectious
    (Jung, Lenhart & Feng 2002; Betts 2020, Ex. 10.133)."""
    c = constants(TABLE, "tuberculosis")
    N, mu = c["N"], c["mu"]

    b1, b2, bs, k1, k2, r1, r2, p, q = (c[k] for k in ("beta1", "beta2", "beta_star", "k1", "k2", "r1", "r2", "p", "q"))

    def dynamics(x, u, t):
        S, T, L1, I1, L2, I2 = (x[k] for k in ("S", "T", "L1", "I1", "L2", "I2"))
        u1, u2 = u["u1"], u["u2"]
        return [
            mu * N - b1 * S * I1 / N - bs * S * I2 / N - mu * S,
            u1 * r1 * L1 - mu * T + (1 - (1 - u2) * (p + q)) * r2 * I1 - b2 * T * I1 / N - bs * T * I2 / N,
            b1 * S * I1 / N
            - (mu + k1) * L1
            - u1 * r1 * L1
            + (1 - u2) * p * r2 * I1
            + b2 * T * I1 / N
            - bs * L1 * I2 / N,
            k1 * L1 - (mu + c["d1"]) * I1 - r2 * I1,
            (1 - u2) * q * r2 * I1 - (mu + k2) * L2 + bs * (S + L1 + T) * I2 / N,
            k2 * L2 - (mu + c["d2"]) * I2,
        ]

    names = ("S", "T", "L1", "I1", "L2", "I2")
    return OptimalControlProblem(
        "betts_tuberculosis",
        states=[
            State(k, 0.0, N, initial=a * N / 120, guess=a * N / 120, scale=N / 10) for k, a in zip(names, c["initial"])
        ],
        controls=[Control(k, *c["u"], guess=0.5) for k in ("u1", "u2")],
        dynamics=dynamics,
        tf=c["tf"],
        lagrange=lambda x, u, t: x["L2"] + x["I2"] + c["B1"] / 2 * u["u1"] ** 2 + c["B2"] / 2 * u["u2"] ** 2,
        objective_scale=1000.0,
        description="Two-strain tuberculosis (Jung, Lenhart & Feng 2002; Betts 2020, Ex. 10.133)",
    )


register(
    Reference(
        "betts_van_der_pol_state_constraint", "Van der Pol oscillator with a state constraint",
        "Betts 2020, Ex. 10.144 (Sec. 4.14)",
        van_der_pol, ("state-constraint-1",),
        paper=(TABLE, "betts_van_der_pol_state_constraint"), start=(4, 20), kind="discretised",
        mesh="Betts' SOS, its final mesh", agreement=1e-6,
        why="a state constraint of order one, met on an arc: its junctions converge at a low order",
        statement=r"\min \int_0^5 u^2 + y_1^2 + y_2^2\,dt \quad\text{s.t.}\quad \dot y_1 = y_2,\ "
        r"\dot y_2 = (1 - y_1^2)y_2 - y_1 + u,\ y(0) = (1, 0),\ y_2 \ge -0.4",
    ),
    Reference(
        "betts_linear_tangent_steering", "Linear tangent steering, minimum time", "Betts 2020, Ex. 10.73 (Sec. 5.6)",
        linear_tangent_steering, ("free-final-time", "aerospace"),
        paper=(TABLE, "betts_linear_tangent_steering"), quantity="final_time", value=lambda s: float(s.tf),
        closed_form=linear_tangent_steering_time, start=(4, 10), kind="discretised",
        mesh="Betts' SOS, its final mesh",
        statement=r"\min t_f \quad\text{s.t.}\quad \dot x = v_x,\ \dot y = v_y,\ \dot v_x = a\cos u,\ "
        r"\dot v_y = a\sin u,\ y(t_f) = 5,\ v_x(t_f) = 45,\ v_y(t_f) = 0,\ a = 100",
    ),
    Reference(
        "betts_pendulum_dae", "Pendulum as an index-one DAE, minimum effort", "Betts 2020, Ex. 10.103",
        pendulum_dae, ("path-constraint",),
        paper=(TABLE, "betts_pendulum_dae"), start=(4, 20), kind="discretised",
        mesh="Betts' SOS, its final mesh",
        statement=r"\min \int_0^3 u^2\,dt \quad\text{s.t.}\quad \dot y_1 = y_3,\ \dot y_2 = y_4,\ "
        r"\dot y_3 = -2y_5y_1 + uy_2,\ \dot y_4 = -g - 2y_5y_2 - uy_1,\ 0 = y_3^2 + y_4^2 - 2y_5 - gy_2,\ "
        r"-1 \le y_5 \le 15",
    ),
    Reference(
        "betts_delay", "Delay equation by the method of steps", "Göllmann, Kern & Maurer 2009; Betts 2020, Ex. 10.50",
        delay, ("mixed-constraint",),
        paper=(TABLE, "betts_delay"), start=(4, 10), kind="discretised",
        mesh="Betts' SOS, its final mesh",
        statement=r"\min \int_0^6 x^2 + u^2\,dt \quad\text{s.t.}\quad \dot x(t) = x(t-1)\,u(t-2),\ "
        r"x + u \ge 0.3,\ x = 1 \text{ on } [-1, 0],\ u = 0 \text{ on } [-2, 0]",
    ),
    Reference(
        "betts_nonconvex_delay", "Nonconvex delay problem by the method of steps", "Maurer 2009; Betts 2020, Ex. 10.90",
        nonconvex_delay, ("state-constraint-1",),
        paper=(TABLE, "betts_nonconvex_delay"), start=(4, 20), agreement=1e-7,
        why="a state constraint of order one on several steps: its junctions converge at a low order",
        statement=r"\min \int_0^2 x^2 + u^2\,dt \quad\text{s.t.}\quad \dot x(t) = x(t - 0.5)^2 - u(t),\ "
        r"x \ge 0.7,\ x = 1 \text{ on } [-0.5, 0]",
    ),
    Reference(
        "betts_tuberculosis", "Two-strain tuberculosis", "Jung, Lenhart & Feng 2002; Betts 2020, Ex. 10.133 (Sec. 8.17)",
        tuberculosis, ("smooth",),
        paper=(TABLE, "betts_tuberculosis"), start=(4, 10),
        statement=r"\min \int_0^5 L_2 + I_2 + \tfrac{B_1}{2}u_1^2 + \tfrac{B_2}{2}u_2^2\,dt \quad\text{s.t. "
        r"two strains: } S, T, L_1, I_1, L_2, I_2,\ 0.05 \le u_i \le 0.95",
    ),
)  # fmt: skip
