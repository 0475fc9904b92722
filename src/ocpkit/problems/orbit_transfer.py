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

from ..problem import Control, FreeFinalTime, OptimalControlProblem, State
from ._data import load_problem_data

STATE_NAMES = ("P", "ex", "ey", "hx", "hy", "L", "m")


def orbit_transfer_constants() -> dict:
    d = load_problem_data("orbit_transfer")
    return {
        **d["constants"],
        "initial": dict(d["initial"]),
        "final": dict(d["final"]),
        "thrusts_N": list(d["transfer"]["thrusts_N"]),
        "final_time_factor": d["transfer"]["final_time_factor"],
    }


def thrust_units(thrust_N: float) -> float:
    """A thrust in newtons, in kg Mm / h^2."""
    return float(thrust_N) * orbit_transfer_constants()["newton_to_kg_Mm_h2"]


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


def orbit_transfer(thrust_N: float = 5.0, lam: float = 1.0, tf: float | None = None,
                   objective: str = "fuel") -> OptimalControlProblem:
    """The transfer with thrust ``thrust_N`` (parameter ``Tmax`` in kg Mm/h^2).

    ``objective="fuel"``: minimise ``int lam |u| + (1 - lam) |u|^2 dt`` over the fixed
    ``tf`` (hours). ``objective="time"``: minimise tf (free) with ``|u| <= 1``.
    """
    c = orbit_transfer_constants()
    if objective not in ("fuel", "time"):
        raise ValueError(f"objective must be 'fuel' or 'time', got {objective!r}")
    if not (thrust_N > 0 and math.isfinite(thrust_N)):
        raise ValueError(f"thrust_N must be positive, got {thrust_N!r}")
    mu, beta = c["mu_Mm3_h2"], c["beta"]

    def dynamics(x, u, t, Pm):
        F0, F1, F2, F3 = equinoctial_fields(x, mu)
        acc = Pm["Tmax"] / x[6]
        xdot = [F0[i] + acc * (u[0] * F1[i] + u[1] * F2[i] + u[2] * F3[i]) for i in range(6)]
        return ca.vertcat(*xdot, -beta * Pm["Tmax"] * ca.norm_2(u))

    ini, fin = c["initial"], c["final"]
    states = [State(n, initial=ini[n], final=fin.get(n)) for n in STATE_NAMES]
    controls = [Control(f"u{i}", -1.0, 1.0) for i in (1, 2, 3)]
    params = {"Tmax": thrust_units(thrust_N), "lam": lam}
    if objective == "fuel":
        if tf is None or not tf > 0:
            raise ValueError("the fuel problem needs a fixed final time tf (hours)")
        return OptimalControlProblem(
            "orbit_transfer_fuel", states, controls, dynamics, tf=float(tf),
            lagrange=lambda x, u, t, Pm: Pm["lam"] * ca.norm_2(u) + (1 - Pm["lam"]) * ca.sumsqr(u),
            parameters=params, description=f"GTO-GEO minimum fuel, {thrust_N} N, tf = {tf} h",
        )
    return OptimalControlProblem(
        "orbit_transfer_time", states, controls, dynamics, tf=FreeFinalTime(1.0, 1e5, 100.0),
        mayer=lambda x0, xf, t0, tff, Pm: tff, lagrange=lambda x, u, t, Pm: 0 * ca.norm_2(u),
        parameters=params, description=f"GTO-GEO minimum time, {thrust_N} N",
    )
