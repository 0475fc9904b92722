"""The energy problem (lambda = 0): its start from scaled minimum-time costates, its continuations in the final
time, the final longitude and the thrust, and the longitude multiplier's calibration (section 3 of the
chain)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from ocpkit import SolverError
from ocpkit.shooting import ShootingResult
from ocpkit.shooting.continuation import Schedule, follow, geometric_midpoint

from ...problems.orbit_transfer import final_longitude, orbit_transfer_constants
from ...progress import continuation_progress, progress
from .continuation import solve_robustly, thrust_schedule
from .systems import TransferSystems, fuel_kg


def energy_start(systems: TransferSystems, thrust_N: float, tf: float, p0_time, scales=(1e-2, 3e-3, 3e-2, 1e-3, 0.1)):
    """Energy solution with fixed ``tf`` at one thrust from scaled minimum-time costates (the first scale that works)."""
    shooting = systems.shooting("energy", thrust_N, final="time", tf=tf)
    for c in scales:
        try:
            return shooting.solve(c * np.asarray(p0_time, dtype=float), maxfev=300)
        except SolverError:
            continue
    raise SolverError("energy start", f"no scale in {scales} converged at {thrust_N} N", len(scales), unit="starts")


def energy_time_continuation(systems: TransferSystems, start, schedule, *, log=None) -> dict:
    """Fixed-time energy solutions along ``schedule`` = [(thrust, tf), ...] from ``start`` (costates at schedule[0]).

    Returns ``{thrust: ShootingResult}`` for every schedule point after the first.
    """
    tf_of = dict(schedule)

    def solve_at(T, z):
        tf = tf_of.get(T)
        if tf is None:  # an inserted thrust: tf interpolated log-log between its neighbours
            tf = float(
                np.exp(np.interp(-math.log(T), [-math.log(a) for a, _ in schedule], [math.log(b) for _, b in schedule]))
            )
        return solve_robustly(systems.shooting("energy", T, final="time", tf=tf), z)

    with continuation_progress("energy, fixed tf", "Tmax", log) as tick:
        path = follow(
            solve_at,
            start,
            schedule[0][0],
            Schedule([T for T, _ in schedule[1:]], midpoint=geometric_midpoint),
            log=tick,
        )
    return {T: r for T, r in path if T in tf_of}


def energy_longitude_start(
    systems: TransferSystems,
    thrust_N: float,
    energy_time: ShootingResult,
    *,
    multiplier: float | None = None,
    steps: int = 10,
    log=None,
) -> ShootingResult:
    """The slides' energy problem (fixed final longitude, free tf) at one thrust.

    From a fixed-time energy solution, whose final longitude is L_a: released to a
    free tf at Lf = L_a, then followed in Lf to the target ``Lf(Tmax, multiplier)``.
    """
    L_a = float(energy_time.integration.y[5])
    target = final_longitude(thrust_N, multiplier)
    z0 = np.concatenate([energy_time.z, [energy_time.tf]])

    def solve_at(Lf, z):
        return solve_robustly(systems.shooting("energy", thrust_N, final="longitude", longitude=Lf), z)

    first = solve_at(L_a, z0)
    with continuation_progress(f"energy, {thrust_N:g} N", "Lf", log) as tick:
        path = follow(solve_at, first.z, L_a, Schedule(np.linspace(L_a, target, steps + 1)[1:]), log=tick)
    return path[-1][1]


def energy_longitude_continuation(
    systems: TransferSystems,
    start,
    start_thrust: float,
    targets,
    *,
    multiplier: float | None = None,
    factor: float = 0.8,
    log=None,
) -> dict:
    """The slides' energy problem along a decreasing thrust schedule, Lf = Lf(Tmax) moving with the thrust.

    ``start``: costates and tf at ``start_thrust``. The final time is predicted by
    the thrust ratio (t_f x Tmax is nearly constant). Returns ``{thrust: ShootingResult}``
    at every target below the start.
    """

    def solve_at(T, z):
        s = systems.shooting("energy", T, final="longitude", longitude=final_longitude(T, multiplier))
        return solve_robustly(s, z)

    def predictor(history, Tb):
        Ta, z = history[-1]
        return np.concatenate([z[:-1], [z[-1] * Ta / Tb]])  # tf x Tmax nearly constant

    with continuation_progress("energy, fixed Lf(Tmax)", "Tmax", log) as tick:
        path = follow(
            solve_at,
            start,
            start_thrust,
            Schedule(thrust_schedule(start_thrust, targets, factor), midpoint=geometric_midpoint),
            predictor=predictor,
            log=tick,
        )
    wanted = {float(t) for t in targets}
    return {T: r for T, r in path if any(abs(T - t) < 1e-12 for t in wanted)}


def calibrate_multiplier(
    systems: TransferSystems, thrust_N: float, z_energy, multipliers, *, rtol: float = 1e-8
) -> pd.DataFrame:
    """The slides' transfer for several longitude multipliers c at one thrust.

    From the energy solution ``z_energy`` (costates and tf) at the reading's Lf, the
    energy problem is followed in Lf to each ``Lf(c)``, and the L1 shooting
    (correction, variational Jacobian) started from it. Returns one row per c:
    Lf, tf, fuel, switchings, steps, |S|.
    """
    c0 = orbit_transfer_constants()["longitude_multiplier"]
    L_start = final_longitude(thrust_N, c0)
    rows = []
    for c in progress(multipliers, desc=f"calibration, {thrust_N:g} N", unit="c"):

        def solve_at(Lf, z):
            return solve_robustly(systems.shooting("energy", thrust_N, final="longitude", longitude=Lf), z)

        Lf = final_longitude(thrust_N, c)
        n = max(1, int(math.ceil(abs(Lf - L_start) / 2.0)))  # steps of about 2 rad
        z = follow(solve_at, z_energy, L_start, Schedule(np.linspace(L_start, Lf, n + 1)[1:]))[-1][1].z
        s = systems.shooting("fuel", thrust_N, final="longitude", longitude=Lf, tol=rtol)
        r = solve_robustly(s, z, maxfev=300)
        rows.append(
            {
                "multiplier": c,
                "thrust_N": thrust_N,
                "Lf_minus_L0_rad": Lf - orbit_transfer_constants()["initial"]["L"],
                "tf_h": r.tf,
                "fuel_kg": fuel_kg(r),
                "switchings": r.integration.switchings,
                "steps": r.integration.steps,
                "norm_S": r.norm,
            }
        )
    return pd.DataFrame(rows)
