"""Reference-collection problems from COPS 3.0 (Dolan, Moré & Munson, "Benchmarking Optimization Software with
COPS 3.0", Argonne ANL/MCS-TM-273, 2004): its control and parameter-estimation problems not among the seeds.
Constants in ``data/problems/collection_cops.toml``; published values (the report's, at its own meshes) in
``data/paper/collection_cops.csv``."""

from __future__ import annotations

import math

import casadi as ca

from ocpkit import Control, FreeFinalTime, FreeParameter, OptimalControlProblem, Program, State

from ..cops_gasoil import least_squares
from . import Reference, constants, register

TABLE = "collection_cops"


def robot_arm() -> OptimalControlProblem:
    """Move a robot arm (length rho, angles theta, phi) between two rests in minimum time (COPS 3.0, robot arm)."""
    c = constants(TABLE, "robot")
    L, u, rho, pi = c["L"], c["u_max"], c["rho"], c["pi"]  # pi as COPS' AMPL model rounds it, 3.14159
    theta_f, phi = c["theta_final_over_pi"] * pi, c["phi_over_pi"] * pi

    def dynamics(x, u, t):  # the moments of inertia about theta and phi
        inertia = ((L - x["rho"]) ** 3 + x["rho"] ** 3) / 3
        return [
            x["rho_dot"],
            x["theta_dot"],
            x["phi_dot"],
            u["u_rho"] / L,
            u["u_theta"] / (inertia * ca.sin(x["phi"]) ** 2),
            u["u_phi"] / inertia,
        ]

    return OptimalControlProblem(
        "cops_robot_arm",
        states=[
            State("rho", 0.0, L, initial=rho, final=rho, guess=rho),
            State("theta", -pi, pi, initial=0.0, final=theta_f, guess=(0.0, theta_f)),
            State("phi", 0.0, pi, initial=phi, final=phi, guess=phi),
            State("rho_dot", initial=0.0, final=0.0, guess=0.0),
            State("theta_dot", initial=0.0, final=0.0, guess=0.2),
            State("phi_dot", initial=0.0, final=0.0, guess=0.0),
        ],
        controls=[Control(f"u_{n}", -u, u, guess=0.0) for n in ("rho", "theta", "phi")],
        dynamics=dynamics,
        tf=FreeFinalTime(0.1, 100.0, c["tf_guess"]),
        mayer=lambda x0, xf, t0, tf: tf,
        description="Robot arm (COPS 3.0)",
    )


def particle_steering() -> OptimalControlProblem:
    """Steer a particle by the direction u of a thrust a to a height, speed and level flight in minimum time
    (COPS 3.0, particle steering: the linear tangent law)."""
    c = constants(TABLE, "steering")
    a, u_max = c["a"], c["u_max_over_pi"] * math.pi
    y, vx, vy = c["final"]
    return OptimalControlProblem(
        "cops_particle_steering",
        states=[
            State("x", initial=0.0, guess=0.0),
            State("y", initial=0.0, final=y, guess=(0.0, y)),
            State("vx", initial=0.0, final=vx, guess=(0.0, vx)),
            State("vy", initial=0.0, final=vy, guess=0.0),
        ],
        controls=[Control("u", -u_max, u_max, guess=0.0)],
        dynamics=lambda x, u, t: [x["vx"], x["vy"], a * ca.cos(u["u"]), a * ca.sin(u["u"])],
        tf=FreeFinalTime(0.01, 10.0, c["tf_guess"]),
        mayer=lambda x0, xf, t0, tf: tf,
        description="Particle steering (COPS 3.0)",
    )


def _measurements(c: dict, names: list[str]):
    """The table ``t, *names`` of a problem's measurements ``tau``, ``z`` (for :func:`least_squares`)."""
    import pandas as pd

    return pd.DataFrame([[t, *z] for t, z in zip(c["tau"], c["z"])], columns=["t", *names])


def _fit(problem: OptimalControlProblem, c: dict, scheme, **options) -> Program:
    """``problem`` cut at its measurement times, with the least-squares cost at them (as :func:`gasoil_fit`)."""
    data = _measurements(c, [s.name for s in problem.states])
    return Program.split(problem, data.t.to_numpy(), scheme, cost=least_squares(data), **options)


def pinene_fit(scheme) -> Program:
    """Fit the five rate constants of alpha-pinene's isomerization to eight measurements (COPS 3.0, pinene)."""
    c = constants(TABLE, "pinene")
    first, last = c["initial"], c["z"][-1]

    def dynamics(x, u, t, p):
        y, k = x, [p[f"theta{i}"] for i in range(1, 6)]  # y1 alpha-pinene, y2 dipentene, ..., y5
        return [
            -(k[0] + k[1]) * y[0],
            k[0] * y[0],
            k[1] * y[0] - (k[2] + k[3]) * y[2] + k[4] * y[4],
            k[2] * y[2],
            k[3] * y[2] - k[4] * y[4],
        ]

    problem = OptimalControlProblem(
        "cops_pinene",
        states=[State(f"y{i}", initial=a, guess=(a, b), scale=100.0) for i, (a, b) in enumerate(zip(first, last), 1)],
        controls=[],
        dynamics=dynamics,
        t0=0.0,
        tf=c["tau"][-1],
        free_parameters=[FreeParameter(f"theta{i}", 0.0, 1.0, guess=1e-4, scale=1e-4) for i in range(1, 6)],
    )
    return _fit(problem, c, scheme)


def methanol_fit(scheme) -> Program:
    """Fit the five rate constants of the conversion of methanol to hydrocarbons to 17 measurements (COPS 3.0,
    methanol to hydrocarbons)."""
    c = constants(TABLE, "methanol")
    first, last = c["initial"], c["z"][-1]

    def dynamics(x, u, t, p):
        y1, y2, k = x[0], x[1], [p[f"theta{i}"] for i in range(1, 6)]
        d = (k[1] + k[4]) * y1 + y2
        return [
            -(2 * k[1] - k[0] * y2 / d + k[2] + k[3]) * y1,
            k[0] * y1 * (k[1] * y1 - y2) / d + k[2] * y1,
            k[0] * y1 * (y2 + k[4] * y1) / d + k[3] * y1,
        ]

    problem = OptimalControlProblem(
        "cops_methanol",
        states=[State(f"y{i}", initial=a, guess=(a, b)) for i, (a, b) in enumerate(zip(first, last), 1)],
        controls=[],
        dynamics=dynamics,
        t0=0.0,
        tf=c["tau"][-1],
        free_parameters=[FreeParameter(f"theta{i}", 0.0, 100.0, guess=1.0) for i in range(1, 6)],
    )
    return _fit(problem, c, scheme)


def marine_fit(scheme) -> Program:
    """Fit the growth and mortality rates of eight stages of a marine population, and its initial state, to 21
    counts (COPS 3.0, marine population dynamics)."""
    c = constants(TABLE, "marine")
    first, last, n = c["z"][0], c["z"][-1], len(c["z"][0])

    def dynamics(x, u, t, p):
        g, m = [p[f"g{s}"] for s in range(1, n)], [p[f"m{s}"] for s in range(1, n + 1)]
        inflow = [0.0] + [g[s - 1] * x[s - 1] for s in range(1, n)]
        return [inflow[s] - (m[s] + (g[s] if s < n - 1 else 0.0)) * x[s] for s in range(n)]

    problem = OptimalControlProblem(
        "cops_marine",
        states=[State(f"y{s}", 0.0, guess=(a, b), scale=1e4) for s, (a, b) in enumerate(zip(first, last), 1)],
        controls=[],
        dynamics=dynamics,
        t0=0.0,
        tf=c["tau"][-1],
        free_parameters=[FreeParameter(f"g{s}", 0.0, 10.0, guess=0.5) for s in range(1, n)]
        + [FreeParameter(f"m{s}", 0.0, 10.0, guess=0.1) for s in range(1, n + 1)],
    )
    return _fit(problem, c, scheme, objective_scale=1e7)


def _tf(solution) -> float:
    return float(solution.tf)


register(
    Reference(
        "cops_robot_arm", "Robot arm, minimum time", "COPS 3.0 (Dolan, Moré & Munson 2004), robot arm",
        robot_arm, ("bang-bang", "free-final-time"),
        paper=(TABLE, "cops_robot_arm"), quantity="final_time_nh800", value=_tf,
        kind="discretised", mesh="COPS nh = 800, trapezoidal", start=(4, 20),
        statement=r"\begin{aligned}&\min t_f\quad L\ddot\rho = u_\rho,\ I_\theta\ddot\theta = u_\theta,\ I_\phi\ddot\phi = u_\phi,\ |u| \le 1,\\"
        r"&I_\phi = \tfrac13\big((L-\rho)^3 + \rho^3\big),\ I_\theta = I_\phi\sin^2\phi,\ "
        r"(\rho, \theta, \phi): (4.5, 0, \tfrac\pi4) \to (4.5, \tfrac{2\pi}3, \tfrac\pi4) \text{ at rest},\ "
        r"\pi \approx 3.14159\end{aligned}",
    ),
    Reference(
        "cops_particle_steering", "Particle steering, minimum time", "COPS 3.0 (Dolan, Moré & Munson 2004), "
        "particle steering", particle_steering, ("smooth", "free-final-time"),
        paper=(TABLE, "cops_particle_steering"), quantity="final_time_nh800", value=_tf,
        kind="discretised", mesh="COPS nh = 800, trapezoidal", start=(4, 10), fast=True,
        statement=r"\min t_f\quad \ddot x = a\cos u,\ \ddot y = a\sin u,\ |u| \le \tfrac\pi2,\ "
        r"(y, \dot x, \dot y)(t_f) = (5, 45, 0),\ a = 100",
    ),
    Reference(
        "cops_pinene", "Isomerization of alpha-pinene", "COPS 3.0 (Dolan, Moré & Munson 2004), alpha-pinene",
        None, ("parameter-estimation",),
        paper=(TABLE, "cops_pinene"), program=pinene_fit, kind="discretised",
        mesh="COPS nh = 100, 200, 400, collocation at 3 Gauss points",
        statement=r"\begin{aligned}&\min_{\theta \ge 0} \sum_{j=1}^{8} \|y(\tau_j) - z_j\|^2,\quad "
        r"\dot y_1 = -(\theta_1 + \theta_2) y_1,\ \dot y_2 = \theta_1 y_1,\\"
        r"&\dot y_3 = \theta_2 y_1 - (\theta_3 + \theta_4) y_3 + \theta_5 y_5,\ \dot y_4 = \theta_3 y_3,\ "
        r"\dot y_5 = \theta_4 y_3 - \theta_5 y_5,\ y(0) = (100, 0, 0, 0, 0)\end{aligned}",
    ),
    Reference(
        "cops_methanol", "Methanol to hydrocarbons", "COPS 3.0 (Dolan, Moré & Munson 2004), methanol to hydrocarbons",
        None, ("parameter-estimation",),
        paper=(TABLE, "cops_methanol"), program=methanol_fit, kind="discretised",
        mesh="COPS nh = 100, 200, 400, collocation at 3 Gauss points",
        statement=r"\begin{aligned}&\min_{\theta \ge 0} \sum_{j=1}^{17} \|y(\tau_j) - z_j\|^2,\quad "
        r"d = (\theta_2 + \theta_5) y_1 + y_2,\ \dot y_1 = -\Big(2\theta_2 - \frac{\theta_1 y_2}{d} + \theta_3 + "
        r"\theta_4\Big) y_1,\\&\dot y_2 = \frac{\theta_1 y_1 (\theta_2 y_1 - y_2)}{d} + \theta_3 y_1,\ "
        r"\dot y_3 = \frac{\theta_1 y_1 (y_2 + \theta_5 y_1)}{d} + \theta_4 y_1,\ y(0) = (1, 0, 0)\end{aligned}",
    ),
    Reference(
        "cops_marine", "Marine population dynamics", "COPS 3.0 (Dolan, Moré & Munson 2004), marine population dynamics",
        None, ("parameter-estimation",),
        paper=(TABLE, "cops_marine"), quantity="objective_nh400", program=marine_fit, kind="discretised",
        mesh="COPS nh = 400, collocation at 1 Gauss point (the midpoint)",
        statement=r"\begin{aligned}&\min_{g, m \ge 0,\ y(0)} \sum_{j=1}^{21} \|y(\tau_j) - z_j\|^2,\quad "
        r"\dot y_1 = -(m_1 + g_1) y_1,\\&\dot y_s = g_{s-1} y_{s-1} - (m_s + g_s) y_s\ (s = 2..7),\ "
        r"\dot y_8 = g_7 y_7 - m_8 y_8\end{aligned}",
    ),
)  # fmt: skip
