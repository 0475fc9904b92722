"""A knot that moves with the junction: the hang glider's bound arc as a phase with free ends, refined.

    python benchmarks/bench_moving_knot.py [--scheme hlgl|radau] [--repeat 2] [--tolerance TOL]

Issue 46's refinement rows (the hang glider from HLGL 50 to 1e-6, ``--scheme hlgl``, and from Radau 4 x 50 to 1e-7,
``--scheme radau``; the whole refinement over a cold solve of its final mesh) spend most of their time on the meshes
between the first and the last. One reading was that they narrow the lift coefficient's junctions with its bound,
which the first mesh does not place; if so, a knot whose time is a variable of the NLP, so that the corner always
lies on a knot, would remove them. This benchmark tests that reading, against the fixed-knot refinement
(``solve(mesh_tolerance=...)``) in the same run:

1. the first mesh (HLGL 50, or Radau 4 x 50) is solved as the refinement solves it;
2. the widest arc of its lift coefficient on the bound (within a thousandth of the control's range, the
   refinement's band) gives two junction times, ``t1`` and ``t2``;
3. the problem is cut there into three linked phases (:meth:`ocpkit.Program.from_phases`): the first keeps the
   initial conditions and ends at a free ``t1``, the second starts at a free ``t1`` and lasts a free duration, the
   third starts at a free ``t2`` and keeps the final conditions and the Mayer term; the first mesh's 50 intervals
   are shared by the phases' durations (rounded, at least 3 each); the junctions are free in the final time's box,
   or within one or two first-mesh intervals of where the first mesh put them (a trust region); the middle phase
   holds the control on its bound (it must then lie within the arc, its ends free to stop short of the arc's), or,
   in a last variant, leaves it free;
4. that program is refined to the tolerance from the first mesh's solution (one guess of the whole horizon: each
   phase its own window of it), and its final mesh is solved again cold, from the problem's own guess as a function
   of time with the junctions at the first mesh's.

Columns: the variant, its outcome, mesh iterations (after the first mesh's own solve, for the moving knots), the
final mesh's points, the objective, the junctions (seconds and fractions of the final time), each mesh's points,
estimate and IPOPT iterations, the whole time (the first mesh included), the final mesh alone (its time, IPOPT's
iterations, status and objective), the ratio of the two (the row's measure), and the whole time over the fixed-knot
final mesh's cold solve (the row's measure with one denominator for every variant). Writes
``build/bench/moving_knot.csv`` (``moving_knot_radau.csv`` for ``--scheme radau``).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from _harness import parser, report, sibling

from ocpkit import HLGL, Duration, FreeFinalTime, FreeInitialTime, Guess, Program, Radau, SolverError
from ocpkit.accuracy import AccuracyWarning
from ocpkit.program.solve import refinement_ipopt_options

from compendium.paths import build_dir
from compendium.problems import hang_glider

#: the first mesh's intervals (the refinement rows' HLGL 50 and Radau 4 x 50)
FIRST = 50


@dataclass(frozen=True)
class Row:
    """How a row's scheme makes its first mesh, a phase's mesh of ``n`` intervals, and a fresh copy of a mesh."""

    first: Callable[[Any], Any]
    on: Callable[[Any, int], Any]
    same: Callable[[Any, Any], Any]


#: the two refinement rows' schemes, by ``--scheme``
SCHEMES = {
    "hlgl": Row(lambda p: HLGL(p, FIRST), lambda p, n: HLGL(p, n), lambda p, s: HLGL(p, mesh=s.mesh.fractions)),
    "radau": Row(
        lambda p: Radau(p, 4, FIRST),
        lambda p, n: Radau(p, 4, n),
        lambda p, s: Radau(p, s.counts.tolist(), mesh=s.mesh.fractions),
    ),
}
#: the band of the control's range that counts as on its bound (the refinement's)
ON_BOUND = 1e-3
#: the variants: the junctions' window in first-mesh intervals either side of the first mesh's (None: the final
#: time's box), and whether the middle phase holds the control on its bound (without it nothing ties a knot to the
#: junction)
VARIANTS = ((None, True), (2.0, True), (1.0, True), (1.0, False))


def bound_arc(solution, control, samples: int = 20001) -> tuple[float, float]:
    """The widest arc of ``control`` (the first control) on its upper bound, ``(t1, t2)``, sampled on ``samples``
    times."""
    t = np.linspace(solution.t0, solution.tf, samples)
    u = np.asarray(solution.control(t), dtype=float).reshape(samples, -1)[:, 0]
    on = np.r_[False, u >= control.upper - ON_BOUND * (control.upper - control.lower), False]
    edges = np.flatnonzero(np.diff(on.astype(int)))
    starts, ends = edges[0::2], edges[1::2] - 1
    if not starts.size:
        raise SystemExit("the first mesh's control never reaches its bound: no junction to move")
    k = int(np.argmax(ends - starts))
    return float(t[starts[k]]), float(t[ends[k]])


def three_phases(problem, t1: float, t2: float, tf: float, window: float | None, on_arc: bool = True):
    """The problem cut at ``t1`` and ``t2`` into three phases with free junction times (within ``window`` seconds of
    them where given, else anywhere in the final time's box); ``on_arc``: the middle phase's control held on its
    upper bound (the arc's structure prescribed). The final time keeps its box, except in the box variant, where the
    last phase's duration is bounded by the box's width (the final time up to twice the box's end: it does not bind
    here)."""
    box = problem.tf
    lo, hi, scale = box.lower, box.upper, box.scale

    def piece(k: int, t0, tf_end):
        first, last = k == 0, k == 2
        states = [
            replace(s, initial=s.initial if first else None, final=s.final if last else None) for s in problem.states
        ]
        changes = {"name": f"{problem.name}_{k}", "states": states, "t0": t0, "tf": tf_end}
        if k == 1 and on_arc:
            changes["controls"] = [replace(c, lower=c.upper, guess=c.upper) for c in problem.controls]
        if not last:
            changes["mayer"] = None
        return problem.replace(**changes)

    arc = t2 - t1
    if window is None:
        return [
            piece(0, 0.0, FreeFinalTime(lo, hi, t1, scale=scale)),
            piece(1, FreeInitialTime(lo, hi, t1, scale=scale), Duration(1e-3, hi - lo, arc, scale=scale)),
            piece(2, FreeInitialTime(lo, hi, t2, scale=scale), Duration(1e-3, hi - lo, tf - t2, scale=scale)),
        ]
    return [
        piece(0, 0.0, FreeFinalTime(t1 - window, t1 + window, t1, scale=scale)),
        piece(
            1,
            FreeInitialTime(t1 - window, t1 + window, t1, scale=scale),
            Duration(max(arc - 2 * window, 1e-3), arc + 2 * window, arc, scale=scale),
        ),
        piece(
            2,
            FreeInitialTime(t2 - window, t2 + window, t2, scale=scale),
            FreeFinalTime(max(lo, t2 + window + 1e-3), hi, tf, scale=scale),
        ),
    ]


def intervals(t1: float, t2: float, tf: float) -> list[int]:
    """The first mesh's intervals shared by the three phases' durations (at least 3 each)."""
    return [max(3, round(FIRST * d / tf)) for d in (t1, t2 - t1, tf - t2)]


def problem_guess(problem) -> Guess:
    """The problem's own guess as one guess of the whole horizon, its states and controls functions of time (each
    phase of a cut problem then takes its window of it, as the uncut problem's solve does)."""
    horizon = problem.tf.guess - problem.t0

    def along(variable):
        return lambda t: variable.guess_at((np.asarray(t, dtype=float) - problem.t0) / horizon)

    return Guess(
        tf=problem.tf.guess,
        states={v.name: along(v) for v in problem.states},
        controls={c.name: along(c) for c in problem.controls},
    )


def moving(scheme: str, tolerance: float, window_intervals: float | None, on_arc: bool) -> dict:
    """One moving-knot variant (the module docstring's steps): the first mesh, the cut at its widest bound arc, the
    refinement of the three phases, and their final mesh solved cold."""
    problem = hang_glider()
    start = time.perf_counter()
    first = (
        SCHEMES[scheme]
        .first(problem)
        .solve(ipopt_options=refinement_ipopt_options(None, tolerance), error_threshold=None)
    )
    t1, t2 = bound_arc(first, problem.controls[0])
    window = None if window_intervals is None else window_intervals * first.tf / FIRST
    pieces = three_phases(problem, t1, t2, first.tf, window, on_arc)
    program = Program.from_phases([SCHEMES[scheme].on(p, n) for p, n in zip(pieces, intervals(t1, t2, first.tf))])
    label = "junctions free in the box"
    if window is not None:
        label = f"junctions within {window_intervals:g} interval{'s' if window_intervals != 1 else ''}"
    label += "" if on_arc else ", the arc's control free"
    try:
        sol = program.solve(first, mesh_tolerance=tolerance, max_mesh_iterations=25)
    except SolverError as exc:
        return {"variant": label, "outcome": f"failed: {exc.status}", "first_junctions_s": f"{t1:.3f}, {t2:.3f}"}
    total = time.perf_counter() - start
    again = three_phases(hang_glider(), t1, t2, first.tf, window, on_arc)
    alone_from = time.perf_counter()
    try:
        alone = Program.from_phases(
            [SCHEMES[scheme].same(p, ph.scheme) for p, ph in zip(again, sol.program.phases)]
        ).solve(problem_guess(problem), ipopt_options=refinement_ipopt_options(None, tolerance), error_threshold=None)
        alone_status, alone_iterations, alone_objective = alone.status, alone.iterations, alone.objective
    except SolverError as exc:
        alone_status, alone_iterations, alone_objective = exc.status, exc.iterations, float("nan")
    alone_s = time.perf_counter() - alone_from
    tf = sol.phase(2).tf
    junctions = [sol.phase(0).tf, sol.phase(2).t0]
    history = sol.mesh_history
    return {
        "variant": label,
        "outcome": sol.refinement_outcome,
        "mesh_iterations": len(history),
        "collocation_points": sol.program.n_collocation_points,
        "objective": sol.objective,
        "first_junctions_s": f"{t1:.3f}, {t2:.3f}",
        "junctions": ", ".join(f"{t:.3f} s ({t / tf:.5f})" for t in junctions),
        "meshes": _path(history),
        "total_s": total,
        "final_mesh_alone_s": alone_s,
        "final_mesh_alone_iterations": alone_iterations,
        "final_mesh_alone_status": alone_status,
        "final_mesh_alone_objective": alone_objective,
        "ratio": total / alone_s,
    }


def fixed(scheme: str, tolerance: float) -> dict:
    """The fixed-knot refinement from the first mesh, and its final mesh solved cold from the problem's guess."""
    problem = hang_glider()
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        sol = SCHEMES[scheme].first(problem).solve(mesh_tolerance=tolerance, max_mesh_iterations=25)
    total = time.perf_counter() - start
    alone_from = time.perf_counter()
    alone = (
        SCHEMES[scheme]
        .same(hang_glider(), sol.program.scheme)
        .solve(ipopt_options=refinement_ipopt_options(None, tolerance), error_threshold=None)
    )
    alone_s = time.perf_counter() - alone_from
    return {
        "variant": "fixed knots (solve(mesh_tolerance=...))",
        "outcome": sol.refinement_outcome,
        "mesh_iterations": len(sol.mesh_history),
        "collocation_points": sol.program.n_collocation_points,
        "objective": sol.objective,
        "meshes": _path(sol.mesh_history),
        "total_s": total,
        "final_mesh_alone_s": alone_s,
        "final_mesh_alone_iterations": alone.iterations,
        "final_mesh_alone_status": alone.status,
        "final_mesh_alone_objective": alone.objective,
        "ratio": total / alone_s,
    }


def _path(history) -> str:
    """Each mesh's points, state estimate and IPOPT iterations: ``100: 4.9e-02 (44)``."""
    return "; ".join(f"{h.collocation_points}: {h.error_estimate:.1e} ({h.ipopt_iterations})" for h in history)


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "moving_knot.csv"))
    ap.add_argument("--tolerance", type=float, default=None, help="default: the row's, 1e-6 (HLGL), 1e-7 (Radau)")
    ap.add_argument("--scheme", choices=sorted(SCHEMES), default="hlgl")
    ap.set_defaults(output=None)
    ap.set_defaults(repeat=2)
    args = ap.parse_args()
    tolerance = args.tolerance or {"hlgl": 1e-6, "radau": 1e-7}[args.scheme]
    default = str(build_dir() / "bench" / "moving_knot.csv")
    output = args.output or (default if args.scheme == "hlgl" else sibling(default, args.scheme))
    fixed(args.scheme, tolerance)  # warm-up: imports, the compiled blocks' libraries
    moving(args.scheme, tolerance, *VARIANTS[-2])
    rows = []
    for make in [
        lambda: fixed(args.scheme, tolerance),
        *[lambda v=v: moving(args.scheme, tolerance, *v) for v in VARIANTS],
    ]:
        runs = [make() for _ in range(args.repeat)]
        row = min(runs, key=lambda r: r.get("total_s", float("inf")))
        rows.append(row)
        print(f"{row['variant']}: {row['outcome']}, {row.get('total_s', float('nan')):.3f} s", flush=True)
    baseline = rows[0]["final_mesh_alone_s"]
    for row in rows:
        if "total_s" in row:
            row["over_fixed_alone"] = row["total_s"] / baseline
    cols = [
        "variant",
        "outcome",
        "mesh_iterations",
        "collocation_points",
        "objective",
        "first_junctions_s",
        "junctions",
        "meshes",
        "total_s",
        "final_mesh_alone_s",
        "final_mesh_alone_iterations",
        "final_mesh_alone_status",
        "final_mesh_alone_objective",
        "ratio",
        "over_fixed_alone",
    ]
    for row in rows:
        for c in cols:
            row.setdefault(c, "")
    report(
        rows,
        cols,
        output,
        f"The hang glider from {SCHEMES[args.scheme].first(hang_glider()).label} to {tolerance:g}, fixed and moving "
        f"knots, best of {args.repeat}",
        {"objective": ".6f", "final_mesh_alone_objective": ".6f", "ratio": ".1f", "over_fixed_alone": ".1f"},
    )


if __name__ == "__main__":
    main()
