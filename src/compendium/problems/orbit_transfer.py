"""Minimum-fuel low-thrust GTO to GEO transfer in equinoctial elements (Martinon & Gergaud's test case).

Constants and the documented reading in ``data/problems/orbit_transfer.toml``.
Parameters ``Tmax`` (kg Mm / h^2) and ``lam`` (cost ``lam |u| + (1 - lam) |u|^2``)
stay symbolic, so one compiled system serves a whole thrust or homotopy
continuation; ``objective="time"`` gives the minimum-time problem instead.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ocpkit import Control, FreeFinalTime, OptimalControlProblem, State

from ._data import load_problem_data

STATE_NAMES = ("P", "ex", "ey", "hx", "hy", "L", "m")


def orbit_transfer_constants() -> dict:
    d = load_problem_data("orbit_transfer")
    tr = d["transfer"]
    return {
        **d["constants"],
        "initial": dict(d["initial"]),
        "final": dict(d["final"]),
        "thrusts_N": list(tr["thrusts_N"]),
        "final_condition": tr["final"],
        "minimum_longitude_rad_N": tr["minimum_longitude_rad_N"],
        "longitude_multiplier": tr["longitude_multiplier"],
        "minimum_time_h_N": tr["minimum_time_h_N"],
        "final_time_factor": tr["final_time_factor"],
    }


def thrust_units(thrust_N: float) -> float:
    """A thrust in newtons, in kg Mm / h^2."""
    return float(thrust_N) * orbit_transfer_constants()["newton_to_kg_Mm_h2"]


def minimum_longitude(thrust_N: float) -> float:
    """The authors' estimate of the minimum transfer longitude (rad): ``L0 + 267.54 / Tmax``."""
    c = orbit_transfer_constants()
    return c["initial"]["L"] + c["minimum_longitude_rad_N"] / _positive_thrust(thrust_N)


def final_longitude(thrust_N: float, multiplier: float | None = None) -> float:
    """The fixed final longitude of the slides' reading: ``L0 + c (Lf_min - L0)`` (rad)."""
    c = orbit_transfer_constants()
    m = c["longitude_multiplier"] if multiplier is None else float(multiplier)
    if not (m > 0 and math.isfinite(m)):
        raise ValueError(f"the longitude multiplier must be positive, got {multiplier!r}")
    L0 = c["initial"]["L"]
    return L0 + m * (minimum_longitude(thrust_N) - L0)


def minimum_time_estimate(thrust_N: float) -> float:
    """The authors' rough estimate of the minimum transfer time (h): ``850 / Tmax``."""
    return orbit_transfer_constants()["minimum_time_h_N"] / _positive_thrust(thrust_N)


def _positive_thrust(thrust_N) -> float:
    if not (isinstance(thrust_N, (int, float, np.floating)) and thrust_N > 0 and math.isfinite(thrust_N)):
        raise ValueError(f"thrust_N must be a positive number of newtons, got {thrust_N!r}")
    return float(thrust_N)


def equinoctial_fields(x, mu):
    """F0, F1, F2, F3 (6 entries each) at x = (P, ex, ey, hx, hy, L); CasADi or numpy."""
    lib = ca if isinstance(x, (ca.SX, ca.MX)) else np
    P, ex, ey, hx, hy, L = (x[i] for i in range(6))
    cL, sL = lib.cos(L), lib.sin(L)
    pdm = lib.sqrt(P / mu)
    w = 1 + ex * cL + ey * sL
    Z = hx * sL - hy * cL
    C = 1 + hx**2 + hy**2
    zero = 0 * P
    F0 = [zero, zero, zero, zero, zero, w**2 / (P * pdm)]
    F1 = [zero, pdm * sL, -pdm * cL, zero, zero, zero]
    F2 = [2 * P * pdm / w, pdm * (cL + (ex + cL) / w), pdm * (sL + (ey + sL) / w), zero, zero, zero]
    F3 = [zero, -pdm * Z * ey / w, pdm * Z * ex / w, pdm * C * cL / (2 * w), pdm * C * sL / (2 * w), pdm * Z / w]
    return F0, F1, F2, F3


FINAL_CONDITIONS = ("longitude", "time", "free")


def orbit_transfer(
    thrust_N: float = 5.0,
    lam: float = 1.0,
    *,
    final: str | None = None,
    tf: float | None = None,
    longitude: float | None = None,
    multiplier: float | None = None,
    objective: str = "fuel",
) -> OptimalControlProblem:
    """The transfer with thrust ``thrust_N`` (parameter ``Tmax`` in kg Mm/h^2).

    Beyond the GEO elements (P, ex, ey, hx, hy), the final condition is one of
    (``data/problems/orbit_transfer.toml`` gives the readings and their evidence):

    * ``final="longitude"`` (the slides' problem; default for the fuel objective): the
      final longitude is fixed, ``L(tf) = longitude``, default
      ``L0 + c (Lf_min - L0)`` (:func:`final_longitude`, ``c = multiplier``), and tf is
      free: the shooting adds the transversality condition ``H(tf) = 0``. ``tf`` is then
      only the guess of the free final time.
    * ``final="time"``: tf fixed (``tf`` hours, required), L free.
    * ``final="free"`` (minimum time only; its default): tf minimised, L free.

    ``objective="fuel"``: minimise ``int lam |u| + (1 - lam) |u|^2 dt`` (``lam = 0``: the
    energy problem, ``lam = 1``: minimum fuel). ``objective="time"``: minimise tf with
    ``|u| <= 1`` (``final`` ``"free"`` or ``"longitude"``).
    """
    c = orbit_transfer_constants()
    if objective not in ("fuel", "time"):
        raise ValueError(f"objective must be 'fuel' or 'time', got {objective!r}")
    _positive_thrust(thrust_N)
    if final is None:
        final = c["final_condition"] if objective == "fuel" else "free"
    allowed = ("longitude", "time") if objective == "fuel" else ("free", "longitude")
    if final not in allowed:
        raise ValueError(f"final must be one of {allowed} for the {objective} objective, got {final!r}")
    if not (isinstance(lam, (int, float, np.floating)) and 0.0 <= lam <= 1.0):
        raise ValueError(f"lam must lie in [0, 1], got {lam!r}")
    mu, beta = c["mu_Mm3_h2"], c["beta"]

    def dynamics(x, u, t, Pm):
        F0, F1, F2, F3 = equinoctial_fields(x, mu)
        acc = Pm["Tmax"] / x[6]
        xdot = [F0[i] + acc * (u[0] * F1[i] + u[1] * F2[i] + u[2] * F3[i]) for i in range(6)]
        return ca.vertcat(*xdot, -beta * Pm["Tmax"] * ca.norm_2(u))

    ini, fin = dict(c["initial"]), dict(c["final"])
    what = ""
    if final == "longitude":
        Lf = final_longitude(thrust_N, multiplier) if longitude is None else float(longitude)
        if not (math.isfinite(Lf) and Lf > ini["L"]):
            raise ValueError(f"the final longitude must exceed L0 = {ini['L']}, got {longitude!r}")
        fin["L"] = Lf
        what = f", L(tf) = {Lf:.6g} rad"
    states = [State(n, initial=ini[n], final=fin.get(n)) for n in STATE_NAMES]
    controls = [Control(f"u{i}", -1.0, 1.0) for i in (1, 2, 3)]
    params = {"Tmax": thrust_units(thrust_N), "lam": lam}
    guess = minimum_time_estimate(thrust_N)
    if objective == "time":
        return OptimalControlProblem(
            "orbit_transfer_time",
            states,
            controls,
            dynamics,
            tf=FreeFinalTime(1e-3, 1e6, guess),
            mayer=lambda x0, xf, t0, tff, Pm: tff,
            lagrange=lambda x, u, t, Pm: 0 * ca.norm_2(u),
            parameters=params,
            description=f"GTO-GEO minimum time, {thrust_N} N{what}",
        )
    if final == "time":
        if tf is None or not tf > 0:
            raise ValueError("the fixed-time reading (final='time') needs the final time tf (hours)")
        tf_spec, what = float(tf), f", tf = {tf} h"
    else:
        g = guess * 1.2 if tf is None else float(tf)
        if not g > 0:
            raise ValueError(f"the final-time guess must be positive, got {tf!r}")
        tf_spec = FreeFinalTime(1e-3, 1e6, g)
    return OptimalControlProblem(
        "orbit_transfer_fuel",
        states,
        controls,
        dynamics,
        tf=tf_spec,
        lagrange=lambda x, u, t, Pm: Pm["lam"] * ca.norm_2(u) + (1 - Pm["lam"]) * ca.sumsqr(u),
        parameters=params,
        description=f"GTO-GEO minimum fuel (lambda = {lam}), {thrust_N} N{what}",
    )


def equinoctial_to_cartesian(x, mu):
    """Position and velocity (Mm, Mm/h) from equinoctial elements (P, ex, ey, hx, hy, L).

    Walker, Ireland & Owens (1985) modified equinoctial elements with p = P,
    f = ex, g = ey, h = hx, k = hy; works on numpy arrays and CasADi symbols.
    """
    lib = ca if isinstance(x, (ca.SX, ca.MX)) else np
    P, f, g, h, k, L = (x[i] for i in range(6))
    cL, sL = lib.cos(L), lib.sin(L)
    alpha2 = h * h - k * k
    s2 = 1 + h * h + k * k
    w = 1 + f * cL + g * sL
    r = P / w
    sq = lib.sqrt(mu / P)
    pos = [
        r / s2 * (cL + alpha2 * cL + 2 * h * k * sL),
        r / s2 * (sL - alpha2 * sL + 2 * h * k * cL),
        2 * r / s2 * (h * sL - k * cL),
    ]
    vel = [
        -sq / s2 * (sL + alpha2 * sL - 2 * h * k * cL + g - 2 * f * h * k + alpha2 * g),
        -sq / s2 * (-cL + alpha2 * cL + 2 * h * k * sL - f + 2 * g * h * k + alpha2 * f),
        2 * sq / s2 * (h * cL + k * sL + f * h + g * k),
    ]
    return pos, vel


def orbit_transfer_direct(
    thrust_N: float,
    objective: str = "time",
    tf: float | None = None,
    revolutions_guess: float = 1.0,
    tf_guess: float = 15.0,
    *,
    multiplier: float | None = None,
) -> OptimalControlProblem:
    """A form of the transfer for direct transcriptions: the thrust direction as two angles.

    ``u = rho (cos(beta) cos(alpha), cos(beta) sin(alpha), sin(beta))`` (radial, orthoradial,
    normal), so ``|u| <= 1`` needs no path constraint and the cost ``|u| = rho`` is smooth.
    ``objective="time"``: full thrust (rho = 1), minimise tf. ``objective="energy"``: controls
    (rho, alpha, beta), rho in [0, 1], minimise the integral of rho^2 over the fixed ``tf``.
    ``objective="fuel"``: the slides' problem of :func:`orbit_transfer` (the integral of rho, the
    final longitude ``final_longitude(thrust_N, multiplier)`` fixed, tf free, guessed at 1.2 t_min),
    started from the straight line between the orbits. The state costates are those of
    :func:`orbit_transfer` (the parameterisation changes only the controls), which lets a
    direct solution start the shooting.
    """
    c = orbit_transfer_constants()
    mu, beta_ = c["mu_Mm3_h2"], c["beta"]
    Tmax = thrust_units(thrust_N)
    if objective not in ("time", "energy", "fuel"):
        raise ValueError(f"objective must be 'time', 'energy' or 'fuel', got {objective!r}")
    energy = objective in ("energy", "fuel")

    def dynamics(x, u, t):
        rho, a, b = (u[0], u[1], u[2]) if energy else (1.0, u[0], u[1])
        d = [ca.cos(b) * ca.cos(a), ca.cos(b) * ca.sin(a), ca.sin(b)]
        F0, F1, F2, F3 = equinoctial_fields(x, mu)
        acc = Tmax * rho / x[6]
        xdot = [F0[i] + acc * (d[0] * F1[i] + d[1] * F2[i] + d[2] * F3[i]) for i in range(6)]
        return ca.vertcat(*xdot, -beta_ * Tmax * rho)

    ini, fin = c["initial"], dict(c["final"])
    L_end = ini["L"] + 2 * math.pi * revolutions_guess
    if objective == "fuel":
        L_end = fin["L"] = final_longitude(thrust_N, multiplier)
    scales = {"P": 10.0, "ex": 1.0, "ey": 1.0, "hx": 0.1, "hy": 0.1, "L": max(math.pi, L_end), "m": 100.0}
    shifts = {"m": 1400.0}
    states = [
        State(
            n,
            initial=ini[n],
            final=fin.get(n),
            scale=scales[n],
            shift=shifts.get(n, 0.0),
            lower=0.5 if n == "P" else -math.inf,
            guess=(ini[n], L_end) if n == "L" else ((ini[n], fin[n]) if objective == "fuel" and n in fin else None),
        )
        for n in STATE_NAMES
    ]
    angles = [
        Control("alpha", -2 * math.pi, 2 * math.pi, guess=math.pi / 2),
        Control("beta", -math.pi / 2, math.pi / 2),
    ]
    if objective == "fuel":
        g = 1.2 * minimum_time_estimate(thrust_N)
        alpha = Control("alpha", -2 * math.pi, 2 * math.pi, guess=math.pi / 2, period=2 * math.pi)
        return OptimalControlProblem(
            "orbit_transfer_fuel_direct",
            states,
            [Control("rho", 0.0, 1.0, guess=0.5), alpha, angles[1]],
            dynamics,
            tf=FreeFinalTime(0.3 * g, 3 * g, g, scale=g),
            lagrange=lambda x, u, t: u[0],
            objective_scale=g,
            description=f"GTO-GEO minimum fuel (direct form), {thrust_N} N, L(tf) = {L_end:.6g} rad",
        )
    if energy:
        if tf is None:
            raise ValueError("the energy problem needs a fixed final time tf (hours)")
        return OptimalControlProblem(
            "orbit_transfer_energy_direct",
            states,
            [Control("rho", 0.0, 1.0, guess=0.5), *angles],
            dynamics,
            tf=float(tf),
            lagrange=lambda x, u, t: u[0] ** 2,
            objective_scale=max(float(tf), 1.0),
            description=f"GTO-GEO energy problem (direct form), {thrust_N} N, tf = {tf} h",
        )
    return OptimalControlProblem(
        "orbit_transfer_time_direct",
        states,
        angles,
        dynamics,
        tf=FreeFinalTime(0.1 * tf_guess, 10 * tf_guess, tf_guess, scale=tf_guess),
        mayer=lambda x0, xf, t0, tff: tff,
        objective_scale=tf_guess,
        description=f"GTO-GEO minimum time (direct form), {thrust_N} N",
    )


def tangential_thrust_guess(thrust_N: float):
    """Trajectory with full tangential thrust until P reaches the GEO value: (tf, states as a function of time)."""
    from scipy.integrate import solve_ivp

    c = orbit_transfer_constants()
    pr = orbit_transfer(thrust_N, final="time", tf=1.0)
    x0 = [c["initial"][n] for n in STATE_NAMES]

    def rhs(t, x):
        return np.asarray(pr.dynamics(x, [0.0, 1.0, 0.0], t)).ravel()

    def reached(t, x):
        return x[0] - c["final"]["P"]

    reached.terminal = True
    sol = solve_ivp(rhs, (0, 1e6), x0, events=reached, rtol=1e-9, atol=1e-9, dense_output=True)
    tf = float(sol.t[-1])
    return tf, (lambda t: sol.sol(np.asarray(t, dtype=float)).T)
