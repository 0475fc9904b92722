"""Sweep tasks (notebook 09, benchmarks/bench_sweep.py): one point of a study each, importable by Dask workers.

Each task is a module-level function of keyword arguments returning a dict (see :mod:`compendium.sweep`).
A worker builds a transcription once (per thread: CasADi functions and IPOPT instances must not be shared
between threads, and a cluster's workers may run several) and solves it for every point it is given, with the
point's values as the problem's parameters: no NLP or IPOPT instance is rebuilt. Each point starts from the
default guess, so its result does not depend on which worker ran it or in what order.
"""

from __future__ import annotations

import threading
import warnings

from ocpkit import HLGL, Radau
from ocpkit.accuracy import AccuracyWarning

from ..problems import entry_landing, flat_moon_ascent, linear_tangent_solution
from .entry_landing import landing_summary

_local = threading.local()


def flat_moon_transcription(segments: int) -> HLGL:
    """The flat-moon ascent with its thrust-to-weight ratio as a parameter, built once per thread."""
    return _flat_moon(segments)[0]


def _flat_moon(segments: int):
    """The transcription and its solve loop (:meth:`ocpkit.Transcription.loop`), once per thread."""
    cache = _local.__dict__.setdefault("flat_moon", {})
    if segments not in cache:
        tr = HLGL(flat_moon_ascent(thrust_as_parameter=True), segments)
        cache[segments] = (tr, tr.loop())
    return cache[segments]


def flat_moon_point(thrust_to_weight: float, segments: int = 20) -> dict:
    """Minimum time to orbit at one thrust-to-weight ratio, against the linear-tangent closed form (solved by the
    worker's loop, :meth:`ocpkit.Transcription.loop`: the same result as ``solve`` from the default guess)."""
    sol = _flat_moon(segments)[1]({"thrust_to_weight": thrust_to_weight}).solution
    exact = linear_tangent_solution(thrust_to_weight=thrust_to_weight)
    return {
        "tf_s": sol.tf,
        "tf_exact_s": exact.tf,
        "tf_relative_error": abs(sol.tf / exact.tf - 1),
        "error_estimate": sol.state_error,
        "iterations": sol.iterations,
        "solve_s": sol.solve_s,
    }


def entry_landing_point(speed_m_s: float, flight_path_deg: float, intervals: int = 20, max_iter: int = 500) -> dict:
    """Fuel of the entry landing from one initial speed and flight-path angle (Radau, 4 nodes per interval).

    The initial state fixes the NLP's bounds and boundary conditions, so each point builds its own
    transcription (about 30 ms here); a failed solve raises :class:`ocpkit.SolverError`, recorded by the sweep.
    """
    problem = entry_landing(initial_speed_m_s=speed_m_s, initial_flight_path_deg=flight_path_deg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)  # the estimate is a result column
        sol = Radau(problem, 4, intervals).solve(ipopt_options={"max_iter": max_iter})
    summary = landing_summary(sol)
    return {
        "fuel_kg": summary["fuel_kg"],
        "final_downrange_m": summary["final_downrange_m"],
        "error_estimate": sol.state_error,
        "iterations": sol.iterations,
        "solve_s": sol.solve_s,
    }


def isolated_failures(table, x: str, y: str) -> list[tuple]:
    """Failed points of a grid sweep not connected to the grid's edge through failed neighbours.

    On a grid of ``x`` by ``y`` values, a failure region that reaches the edge is where the problem stops
    being solvable; a failed point surrounded by solved ones is more likely the solver's failure than the
    problem's. Returns the ``(x, y)`` of such points (neighbours: one grid step in ``x`` or ``y``).
    """
    xs, ys = sorted(table[x].unique()), sorted(table[y].unique())
    failed = {(xs.index(a), ys.index(b)) for a, b in zip(table[x][~table.ok], table[y][~table.ok])}
    edge = [p for p in failed if p[0] in (0, len(xs) - 1) or p[1] in (0, len(ys) - 1)]
    reached, stack = set(edge), list(edge)
    while stack:
        i, j = stack.pop()
        for n in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
            if n in failed and n not in reached:
                reached.add(n)
                stack.append(n)
    return sorted((xs[i], ys[j]) for i, j in failed - reached)
