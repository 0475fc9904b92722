"""Minimum time: at a strong thrust from a direct Radau solution, down to the weak thrusts by continuation,
the best extremal at each target thrust by restarts, and t_min against the final longitude (sections 1 and 2
of the chain)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from ocpkit import SolverError
from ocpkit.shooting.continuation import GeometricSteps, Schedule, follow

from ...problems.orbit_transfer import (
    STATE_NAMES,
    orbit_transfer_constants,
    orbit_transfer_direct,
    tangential_thrust_guess,
)
from ...progress import continuation_progress, progress
from .systems import COSTATES, TransferSystems

# -- 1. minimum time at a strong thrust ------------------------------------------------------


def minimum_time_start(systems: TransferSystems, thrust_N: float = 60.0, nodes: int = 8, intervals: int = 20):
    """Minimum-time solution at a strong thrust, started from a direct Radau solution.

    The direct problem is initialised with full tangential thrust until the GEO
    semi-latus rectum is reached; its costate estimates (Garg et al.) and final
    time start the indirect shooting. Returns ``(shooting_result, direct_solution)``.
    """
    from ocpkit import Guess, Radau

    tf0, states = tangential_thrust_guess(thrust_N)
    revs = (states(tf0)[5] - orbit_transfer_constants()["initial"]["L"]) / (2 * math.pi)
    pr = orbit_transfer_direct(thrust_N, "time", revolutions_guess=revs, tf_guess=tf0)
    guess = Guess(tf=tf0, states={n: (lambda t, j=j: states(t)[..., j]) for j, n in enumerate(STATE_NAMES)})
    direct = Radau(pr, nodes, intervals).solve(guess, ipopt_options={"max_iter": 1000})
    z0 = np.concatenate([direct.costate_values[0], [direct.tf]])
    result = systems.shooting("time", thrust_N).solve(z0, maxfev=300)
    return result, direct


# -- 2. minimum-time continuation -------------------------------------------------------------


def minimum_time_continuation(
    systems: TransferSystems,
    start,
    start_thrust: float,
    targets,
    *,
    factor: float = 0.8,
    slowest: float = 0.995,
    log=print,
) -> pd.DataFrame:
    """t_min along a decreasing thrust schedule down to ``min(targets)``.

    :func:`~ocpkit.shooting.continuation.follow` with :class:`GeometricSteps` (the
    thrust ratio ``factor``, shrunk on failure, grown back on success, through every
    target). Each step tries two predictors (the last solution with tf scaled by the
    thrust ratio, and a log-log secant through the last two solutions) and keeps the
    converged solution with the smallest tf. Returns one row per solved thrust:
    thrust, t_min, costates, |S|, and whether it is a target.
    """
    targets = sorted({float(t) for t in targets}, reverse=True)

    def predictor(history, Tn):
        T, z = history[-1]
        guesses = [np.concatenate([z[:-1], [z[-1] * T / Tn]])]
        if len(history) >= 2:
            (T1, z1), (T2, z2) = history[-2], history[-1]
            a = math.log(Tn / T2) / math.log(T2 / T1)
            g = z2 + a * (z2 - z1)
            g[-1] = z2[-1] * (z2[-1] / z1[-1]) ** a
            guesses.append(g)
        return guesses

    def solve_at(T, z):
        return systems.shooting("time", T).solve(z, maxfev=150)

    def report(T, r, elapsed):
        if log:
            log(
                f"{T:8.4f} N: t_min = {r.tf:10.4f} h, t_min * Tmax = {T * r.tf:6.1f} N h, |S| = {r.norm:.1e}, "
                f"{elapsed:5.1f} s"
            )

    steps = GeometricSteps(targets[-1], targets=targets, factor=factor, slowest=slowest)
    with continuation_progress("minimum time", "Tmax", report) as tick:
        path = follow(
            solve_at,
            start,
            float(start_thrust),
            steps,
            predictor=predictor,
            choose=lambda results: min(results, key=lambda r: r.tf),
            log=tick,
        )
    rows = [_tmin_row(float(start_thrust), np.asarray(start, dtype=float), np.nan, float(start_thrust) in targets)]
    rows += [_tmin_row(T, r.z, r.norm, any(abs(T - t) < 1e-12 for t in targets)) for T, r in path]
    return pd.DataFrame(rows)


def _tmin_row(T, z, norm, target):
    return {"thrust_N": T, "tmin_h": z[-1], **dict(zip(COSTATES, z[:-1])), "norm_S": norm, "target": bool(target)}


def refine_minimum_time(
    systems: TransferSystems, table: pd.DataFrame, *, maxfev: int = 80, within: float | None = 10.0, log=print
):
    """The best minimum time at each target thrust of ``table``, by restarts from its solutions near in thrust.

    The minimum-time transfer has many extremals (solutions of the shooting
    equations: local minima, and saddles that are maxima of t_min against the final
    longitude), and a continuation can follow one that is not the lowest. At each
    target thrust T, the shooting is restarted from the costates of every row whose
    thrust is within a factor ``within`` of T (at least 1; ``None``: every row), its tf
    scaled by ``T_row / T`` (t_min x Tmax is nearly constant, the costates are not);
    the smallest converged tf is kept. The factor is measured, by replaying the
    published run's restarts from its continuation table (five targets, 22 rows): the
    48 starts from rows more than ten times stronger or weaker converged 10 times, once
    to the best (at 5 N, which three nearer starts reach too), otherwise to nine higher
    extremals no nearer start found, and took 197 s of the restarts' 295 s.

    Returns ``(table, extremals)``: the table with the targets' rows replaced by the
    best solutions (``continuation_tmin_h`` keeps what the continuation found), and one
    row per distinct extremal found at each target (thrust, t_f, final longitude, how
    many starts reached it).
    """
    if within is not None and not within >= 1.0:
        raise ValueError(f"within must be at least 1 (a factor in thrust), or None; got {within!r}")
    table = table.copy()
    table["continuation_tmin_h"] = table.tmin_h
    found = []

    def donors(T: float) -> pd.DataFrame:
        if within is None:
            return table
        ratio = np.maximum(table.thrust_N / T, T / table.thrust_N)
        return table[ratio <= within * (1 + 1e-12)]

    targets = [float(table.at[i, "thrust_N"]) for i in table.index[table.target]]
    bar = progress(total=sum(len(donors(T)) for T in targets), desc="minimum-time restarts", unit="start")
    for i in table.index[table.target]:
        T = float(table.at[i, "thrust_N"])
        shooting = systems.shooting("time", T)
        best = None
        minima: dict[float, list] = {}
        starts = donors(T)
        for _, row in starts.iterrows():
            bar.update()
            z = row[COSTATES + ["tmin_h"]].to_numpy(dtype=float)
            z[-1] *= row.thrust_N / T
            try:
                r = shooting.solve(z, maxfev=maxfev, diagnose=False)  # a start that fails is only skipped
            except SolverError:
                continue
            key = round(r.tf, 4)
            if key not in minima:
                minima[key] = [r, 0]
            minima[key][1] += 1
            if best is None or r.tf < best.tf:
                best = r
        if best is None:
            raise SolverError("minimum-time refinement", f"no start converged at {T:g} N", len(starts), unit="starts")
        for key, (r, count) in sorted(minima.items()):
            found.append(
                {
                    "thrust_N": T,
                    "tmin_h": r.tf,
                    "tmin_x_thrust_Nh": r.tf * T,
                    "final_longitude_rad": float(r.integration.y[5]),
                    "starts": count,
                    "continuation": bool(abs(r.tf - table.at[i, "continuation_tmin_h"]) < 1e-6 * r.tf),
                    "best": key == round(best.tf, 4),
                }
            )
        for name, value in _tmin_row(T, best.z, best.norm, True).items():
            table.at[i, name] = value
        if log:
            log(
                f"{T:g} N: {len(minima)} distinct extremals from {len(starts)} starts; "
                f"t_min = {best.tf:.4f} h (the continuation had {table.at[i, 'continuation_tmin_h']:.4f} h)"
            )
    bar.close()
    return table, pd.DataFrame(found)


def minimum_time_versus_longitude(
    systems: TransferSystems, thrust_N: float, z_time, *, step: float = 0.25, below: float = 8.0, above: float = 20.0
) -> pd.DataFrame:
    """Minimum time with the final longitude fixed, t_min(Lf), around a free-longitude solution.

    From the free-longitude minimum ``z_time`` (costates and tf) at ``thrust_N``, the
    fixed-longitude minimum-time problem is followed in Lf down by ``below`` and up by
    ``above`` radians (or until the continuation fails: too short a longitude is
    infeasible). Local minima of t_min(Lf) are the free-longitude local minima
    (``p_L(tf) = 0``). Returns one row per Lf: ``dL`` (Lf - L0), t_min, p_L(tf).
    """
    L0 = orbit_transfer_constants()["initial"]["L"]
    free = systems.shooting("time", thrust_N)
    Lstar = float(free.integrate(z_time).y[5])
    rows = [{"dL_rad": Lstar - L0, "tmin_h": float(z_time[-1]), "p_L_tf": 0.0}]

    def solve_at(Lf, z):
        r = systems.shooting("time", thrust_N, final="longitude", longitude=Lf).solve(z, maxfev=100)
        rows.append({"dL_rad": Lf - L0, "tmin_h": r.tf, "p_L_tf": float(r.integration.y[7 + 5])})
        return r

    for end in (Lstar - below, Lstar + above):
        n = max(1, int(round(abs(end - Lstar) / step)))
        with continuation_progress(f"t_min(Lf), {thrust_N:g} N", "Lf") as tick:
            try:
                follow(solve_at, z_time, Lstar, Schedule(np.linspace(Lstar, end, n + 1)[1:], max_halvings=2), log=tick)
            except SolverError:
                pass  # the edge of the feasible longitudes, or a fold: the curve stops there
    return pd.DataFrame(rows).sort_values("dL_rad").drop_duplicates("dL_rad").reset_index(drop=True)


def classify_on_scan(dL, scan: pd.DataFrame, width: float = 0.5) -> str:
    """Whether the free-longitude extremal at ``dL`` (Lf - L0) is a minimum or a maximum of t_min(Lf).

    Compares t_min on the scan (:func:`minimum_time_versus_longitude`) at ``dL`` and
    ``width`` radians either side; ``"outside"`` when the scan does not cover them.
    """
    if not (scan.dL_rad.min() <= dL - width and dL + width <= scan.dL_rad.max()):
        return "outside"
    left, mid, right = np.interp([dL - width, dL, dL + width], scan.dL_rad, scan.tmin_h)
    if left > mid and right > mid:
        return "minimum"
    if left < mid and right < mid:
        return "maximum"
    return "neither"


def scan_minima(scan: pd.DataFrame) -> pd.DataFrame:
    """The local minima of t_min(Lf) among the scan's points."""
    t = scan.tmin_h.to_numpy()
    i = [k for k in range(1, len(t) - 1) if t[k] < t[k - 1] and t[k] < t[k + 1]]
    return scan.iloc[i].reset_index(drop=True)
