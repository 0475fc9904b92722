"""The chain of solves with its caches: minimum times and energy costates read from the published record or
computed, the energy solution as shooting unknowns, and the L1 runs beside the slides'."""

from __future__ import annotations

import time

import numpy as np
import pandas as pd

from ...problems.orbit_transfer import orbit_transfer_constants
from .cache import CACHE_FORMAT, read_cache
from .energy import energy_longitude_continuation, energy_longitude_start, energy_start, energy_time_continuation
from .minimum_time import minimum_time_continuation, minimum_time_start, refine_minimum_time
from .systems import COSTATES, TransferSystems, fuel_kg

#: A slides run counts as converged when its |S| is at most this: the slides call the
#: none/fd runs at 5 and 1 N (3.6e-6, 7.5e-6) and detection at 0.2 N (1.5e-6) solutions,
#: and the runs at 9.4e-3 and above "poor solutions" (slides 8, 12, 16).
SLIDES_CONVERGED = 1e-5


def minimum_times(
    systems: TransferSystems, thrusts, *, recompute: bool = False, start_thrust: float = 60.0, outputs=None, log=print
):
    """t_min at every thrust of ``thrusts``: ``(table, minima)``, from the cache or computed.

    Computed: :func:`minimum_time_start` at ``start_thrust``,
    :func:`minimum_time_continuation` through the targets, :func:`refine_minimum_time`.
    The cache (``orbit_transfer_tmin``, ``orbit_transfer_tmin_minima``) serves when it
    holds every thrust asked for; what is computed is written to ``outputs``
    (:class:`compendium.outputs.Outputs`) when given.
    """
    thrusts = [float(t) for t in thrusts]
    table = None if recompute else read_cache("orbit_transfer_tmin")
    minima = None if recompute else read_cache("orbit_transfer_tmin_minima")
    if (
        table is not None
        and minima is not None
        and "continuation_tmin_h" in table
        and all(np.isclose(table.thrust_N[table.target], t).any() for t in thrusts)
    ):
        log("minimum times from the cache data/derived/orbit_transfer_tmin*.csv (recompute=True to rebuild)")
        return table, minima
    t0 = time.perf_counter()
    start, direct = minimum_time_start(systems, start_thrust)
    log(
        f"{start_thrust:g} N: direct Radau t_f = {direct.tf:.3f} h; indirect shooting from its costate estimates: "
        f"t_min = {start.tf:.4f} h, |S| = {start.norm:.1e}"
    )
    table = minimum_time_continuation(systems, start.z, start_thrust, thrusts, log=log)
    table, minima = refine_minimum_time(systems, table, log=log)
    if outputs is not None:
        outputs.table(table, "orbit_transfer_tmin", float_format=CACHE_FORMAT)
        outputs.table(minima, "orbit_transfer_tmin_minima", float_format=CACHE_FORMAT)
    log(f"minimum time: {time.perf_counter() - t0:.0f} s")
    return table, minima


def _energy_row(reading, T, r):
    return {
        "reading": reading,
        "thrust_N": T,
        "tf_h": r.tf,
        "Lf_rad": float(r.integration.y[5]),
        "energy_fuel_kg": fuel_kg(r),
        **dict(zip(COSTATES, r.z[:7])),
        "norm_S": r.norm,
    }


def energy_solutions(
    systems: TransferSystems,
    tmin_table: pd.DataFrame,
    thrusts,
    *,
    recompute: bool = False,
    tf_factor: float | None = None,
    outputs=None,
    log=print,
) -> pd.DataFrame:
    """Energy-problem costates at every thrust of ``thrusts`` for both readings, from the cache or computed.

    ``"time"``: tf = ``tf_factor`` t_min, from scaled minimum-time costates at the
    largest thrust, then by continuation on the thrust along the t_min table.
    ``"longitude"``: from the fixed-time solution at the largest thrust, released to a
    free tf and followed in the final longitude to Lf(Tmax), then on the thrust with Lf
    moving with it (:func:`energy_longitude_continuation`). One row per reading and
    thrust (tf, final longitude, energy fuel, costates, |S|); cached as ``orbit_transfer_energy``
    (written to ``outputs`` when computed and given).
    """
    thrusts = sorted({float(t) for t in thrusts}, reverse=True)
    factor = orbit_transfer_constants()["final_time_factor"] if tf_factor is None else float(tf_factor)
    tmin = tmin_table.set_index("thrust_N").tmin_h
    table = None if recompute else read_cache("orbit_transfer_energy")
    if table is not None and "reading" in table:
        ok = True
        for T in thrusts:
            rows = table[np.isclose(table.thrust_N, T)]
            time_rows = rows[rows.reading == "time"]
            ok &= (rows.reading == "longitude").any() and np.isclose(
                time_rows.tf_h, factor * tmin[np.isclose(tmin.index, T)].iloc[0]
            ).any()
        if ok:
            log("energy-problem costates from the cache data/derived/orbit_transfer_energy.csv")
            return table
    t0 = time.perf_counter()
    top = thrusts[0]
    sched = [(T, factor * t) for T, t in tmin.items() if T <= top * (1 + 1e-12)]
    first = tmin_table[np.isclose(tmin_table.thrust_N, top)].iloc[0]
    e0 = energy_start(systems, top, factor * first.tmin_h, first[COSTATES].to_numpy(dtype=float))
    timed = {top: e0, **energy_time_continuation(systems, e0.z, sched)}
    log(f"energy problem, fixed tf = {factor:g} t_min: {len(timed)} thrusts, {time.perf_counter() - t0:.0f} s")
    e_long = energy_longitude_start(systems, top, e0)
    longitude = {top: e_long, **energy_longitude_continuation(systems, e_long.z, top, thrusts)}
    log(f"energy problem, fixed final longitude: {time.perf_counter() - t0:.0f} s")
    rows = [_energy_row("longitude", T, longitude[T]) for T in thrusts]
    rows += [_energy_row("time", T, timed[T]) for T in thrusts]
    table = pd.DataFrame(rows)
    if outputs is not None:
        outputs.table(table, "orbit_transfer_energy", float_format=CACHE_FORMAT)
    return table


def energy_start_vector(energy: pd.DataFrame, reading: str, thrust_N: float) -> np.ndarray:
    """The shooting unknowns of an energy solution: costates, and tf for the longitude reading."""
    row = energy[(energy.reading == reading) & np.isclose(energy.thrust_N, thrust_N)].iloc[0]
    z = row[COSTATES].to_numpy(dtype=float)
    return np.concatenate([z, [row.tf_h]]) if reading == "longitude" else z


def versus_slides(runs: pd.DataFrame, slides: pd.DataFrame) -> pd.DataFrame:
    """Every run of ``runs`` (one solver) beside the slides' values for the same thrust, treatment and Jacobian.

    Fuel and switchings describe the extremal, so each converged run is also judged
    against the slides' converged detection run at its thrust (``fuel_ref``,
    ``switchings_ref``); steps against the slides' run of the same treatment.
    """
    ref = slides[(slides.detection == "detection") & (slides.jacobian == "fd")].set_index("thrust_N")
    sl = slides.set_index(["thrust_N", "detection", "jacobian"])
    rows = []
    for r in runs.itertuples():
        key = (r.thrust_N, r.detection, r.jacobian)
        s = sl.loc[key] if key in sl.index else None
        rf = ref.loc[r.thrust_N] if r.thrust_N in ref.index else None
        ref_ok = rf is not None and rf.norm_S <= SLIDES_CONVERGED

        def get(name, s=s):
            return s[name] if s is not None else np.nan

        rows.append(
            {
                "thrust_N": r.thrust_N,
                "detection": r.detection,
                "jacobian": r.jacobian,
                "converged": r.converged,
                "fuel_kg": r.fuel_kg,
                "fuel_kg_slides": get("objective_kg"),
                "fuel_ref_kg": rf.objective_kg if ref_ok else np.nan,
                "norm_S": r.norm_S,
                "norm_S_slides": get("norm_S"),
                "n_S": r.n_S,
                "n_S_slides": get("n_S"),
                "n_jac": r.n_jac,
                "n_jac_slides": get("n_jac"),
                "cpu_s": r.cpu_s,
                "cpu_s_slides": get("cpu_s"),
                "switchings": r.switchings,
                "switchings_ref": rf.switchings if ref_ok else np.nan,
                "steps": r.steps,
                "steps_slides": get("steps"),
                "rejected_pct": r.rejected_pct,
            }
        )
    return pd.DataFrame(rows)
