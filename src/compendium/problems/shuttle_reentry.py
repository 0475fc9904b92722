"""Space shuttle reentry, maximum crossrange (Betts 2010, Example 6.1; constants in
``data/problems/shuttle_reentry.toml``, which states the equations).

Six states in English units (altitude ``h`` in ft, longitude ``phi``, latitude ``theta``, speed ``v`` in ft/s,
flight-path angle ``gamma``, azimuth ``psi``), two controls (angle of attack ``alpha``, bank angle ``beta``), a
free final time of about 2000 s; maximise ``theta(t_f)``. With ``heating_limit``, the aerodynamic heating rate
``q`` (BTU/ft^2/s) is held below it as a path constraint: Betts' second variant at 70.

Two statements of the same problem: ``scaled=True``, scaled by hand as Dymos' example scales it (altitude in units
of 1e5 ft, speed of 1e4 ft/s, duration of 1000 s, the heating rate of its limit, the cost in degrees); and
``scaled=False``, the problem as a user first writes it, every variable in its own unit (altitudes of 1e5 ft next to
angles of 1e-2 rad), which IPOPT solves in 646 iterations on Radau 4 x 40 (219 under MUMPS's QAMD ordering) where the
hand-scaled statement takes 25 and the same statement through :func:`ocpkit.autoscale` 59 (notebook 07).
"""

from __future__ import annotations

import math

import casadi as ca

from ocpkit import Constraint, Control, FreeFinalTime, OptimalControlProblem, State

from ._data import load_problem_data

DEG = math.pi / 180.0


def shuttle_reentry_constants() -> dict:
    return load_problem_data("shuttle_reentry")


def heating_rate(sqrt_rho, v, alpha_deg, c):
    """``q = 17700 sqrt(rho) (1e-4 v)^3.07 (c0 + c1 alpha + c2 alpha^2 + c3 alpha^3)`` (BTU/ft^2/s), alpha in degrees;
    on CasADi symbols (the path constraint) or numpy arrays (:func:`shuttle_heating`)."""
    q0, q1, q2, q3 = c
    return 17700.0 * sqrt_rho * (1e-4 * v) ** 3.07 * (q0 + q1 * alpha_deg + q2 * alpha_deg**2 + q3 * alpha_deg**3)


def shuttle_reentry(heating_limit: float | None = None, scaled: bool = True) -> OptimalControlProblem:
    """The problem (module docstring); ``heating_limit``: None, or the limit of ``q`` (Betts: 70)."""
    d = shuttle_reentry_constants()
    c, bc, box, guess, sc = d["constants"], d["boundary"], d["bounds"], d["guess"], d["scales"]
    mass = c["weight_lb"] / c["g0"]
    a0, a1 = c["a"]
    b0, b1, b2 = c["b"]

    def atmosphere(x):
        return c["rho0"] * ca.exp(-x[0] / c["h_r"])

    def heating(x, u, t):
        return heating_rate(ca.sqrt(atmosphere(x)), x[3], u[0] / DEG, c["c"])

    def dynamics(x, u, t):
        h, _, theta, v, gamma, psi = (x[i] for i in range(6))
        alpha, beta = u[0] / DEG, u[1]
        r = c["Re"] + h
        g = c["mu"] / r**2
        pressure = 0.5 * atmosphere(x) * v**2 * c["S"]
        lift, drag = pressure * (a0 + a1 * alpha), pressure * (b0 + b1 * alpha + b2 * alpha**2)
        return ca.vertcat(
            v * ca.sin(gamma),
            v * ca.cos(gamma) * ca.sin(psi) / (r * ca.cos(theta)),
            v * ca.cos(gamma) * ca.cos(psi) / r,
            -drag / mass - g * ca.sin(gamma),
            lift * ca.cos(beta) / (mass * v) + ca.cos(gamma) * (v / r - g / v),
            lift * ca.sin(beta) / (mass * v * ca.cos(gamma))
            + v * ca.cos(gamma) * ca.sin(psi) * ca.sin(theta) / (r * ca.cos(theta)),
        )

    h0, phi0, theta0, v0, gamma0, psi0 = bc["initial"]
    s = {"h": sc["h"], "v": sc["v"], "tf": sc["tf"]} if scaled else {"h": 1.0, "v": 1.0, "tf": 1.0}
    states = [
        State("h", 0.0, initial=h0, final=bc["h_f"], scale=s["h"], guess=(h0, bc["h_f"])),
        State("phi", initial=phi0 * DEG, guess=(phi0 * DEG, guess["theta_f"])),
        State(
            "theta",
            -box["theta_deg"] * DEG,
            box["theta_deg"] * DEG,
            initial=theta0 * DEG,
            guess=(theta0 * DEG, guess["theta_f"]),
        ),  # fmt: skip
        State("v", box["v_min"], initial=v0, final=bc["v_f"], scale=s["v"], guess=(v0, bc["v_f"])),
        State(
            "gamma",
            -box["gamma_deg"] * DEG,
            box["gamma_deg"] * DEG,
            initial=gamma0 * DEG,
            final=bc["gamma_f_deg"] * DEG,
            guess=(gamma0 * DEG, bc["gamma_f_deg"] * DEG),
        ),  # fmt: skip
        State("psi", initial=psi0 * DEG, guess=(psi0 * DEG, guess["psi_f_deg"] * DEG)),
    ]
    controls = [
        Control("alpha", *(v * DEG for v in box["alpha_deg"]), guess=guess["alpha_deg"] * DEG),
        Control("beta", *(v * DEG for v in box["beta_deg"]), guess=guess["beta_deg"] * DEG),
    ]
    path = []
    if heating_limit is not None:
        path.append(
            Constraint("heating", heating, upper=float(heating_limit), scale=float(heating_limit) if scaled else 1.0)
        )
    name = "shuttle_reentry" if heating_limit is None else "shuttle_reentry_heating"
    return OptimalControlProblem(
        name,
        states=states,
        controls=controls,
        dynamics=dynamics,
        tf=FreeFinalTime(*box["tf"], guess["tf"], scale=s["tf"]),
        mayer=(lambda x0, xf, t0, tf: -xf[2] / DEG) if scaled else (lambda x0, xf, t0, tf: -xf[2]),
        path_constraints=path,
        description="Space shuttle reentry, maximum crossrange (Betts 2010, Ex. 6.1)"
        + ("" if heating_limit is None else f", heating rate at most {heating_limit:g}"),
    )


def shuttle_heating(solution, t):
    """The heating rate q (BTU/ft^2/s) along a solution at times ``t``."""
    import numpy as np

    d = shuttle_reentry_constants()["constants"]
    X, U = solution.state(t), solution.control(t)
    rho = d["rho0"] * np.exp(-X[..., 0] / d["h_r"])
    return heating_rate(np.sqrt(rho), X[..., 3], U[..., 0] / DEG, d["c"])


__all__ = ["shuttle_heating", "shuttle_reentry", "shuttle_reentry_constants"]
