"""A knot that moves with the junction: the hang glider's bound arc as a phase with free ends, refined to 1e-6.

    python benchmarks/bench_moving_knot.py [--repeat 2] [--tolerance 1e-6]

Issue 46's refinement row (the hang glider from HLGL 50 to 1e-6, the whole refinement over a cold solve of its final
mesh) is held by the lift coefficient's junctions with its bound: the first mesh does not place them, so the meshes
between narrow them (``docs/benchmarks.md``). The alternative is to make each junction a knot whose time is a variable
of the NLP, so that the corner always lies on a knot. This benchmark measures it, against the fixed-knot refinement
(``solve(mesh_tolerance=...)``) in the same run:

1. the first mesh (HLGL 50) is solved as the refinement solves it;
2. the widest arc of its lift coefficient on the bound (within a thousandth of the control's range, as the
   refinement's band) gives two junction times, ``t1`` and ``t2``;
3. the problem is cut there into three linked phases (:meth:`ocpkit.Program.from_phases`): the first keeps the initial
   conditions and ends at a free ``t1``, the second starts at a free ``t1`` and lasts a free duration, the third
   starts at a free ``t2`` and keeps the final conditions and the Mayer term; their 50 intervals are shared by the
   phases' durations; the junctions are free in the final time's box, or within one or two first-mesh intervals of
   where the first mesh put them (a trust region); the middle phase holds the control on its bound (the arc's
   structure prescribed: its ends are then the junctions), or, in a last variant, leaves it free;
4. that program is refined to the tolerance from the first mesh's solution (each phase from it), and its final mesh
   is solved again cold, from the problem's guess with the same junction guesses (a user who knew the junctions).

Columns: the variant, its outcome, mesh iterations, the final mesh's points, the objective, the whole time (the first
mesh included), the final mesh alone (its time, IPOPT's iterations and objective), and the ratio of the two (the row's
measure). Writes ``build/bench/moving_knot.csv``.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import replace

import numpy as np
from _harness import parser, report

from ocpkit import HLGL, Duration, FreeFinalTime, FreeInitialTime, Program, SolverError
from ocpkit.accuracy import AccuracyWarning
from ocpkit.program.solve import refinement_ipopt_options

from compendium.paths import build_dir
from compendium.problems import hang_glider

#: the first mesh's intervals (the refinement row's HLGL 50)
FIRST = 50
#: the band of the control's range that counts as on its bound (the refinement's)
ON_BOUND = 1e-3
#: the variants: the junctions' window in first-mesh intervals either side of the first mesh's (0: the final time's
#: box), and whether the middle phase holds the control on its bound (without it nothing ties a knot to the junction)
VARIANTS = ((0.0, True), (2.0, True), (1.0, True), (1.0, False))


def bound_arc(solution, upper: float, samples: int = 20001) -> tuple[float, float]:
    """The widest arc of the control on its upper bound, ``(t1, t2)``, sampled on ``samples`` times."""
    t = np.linspace(solution.t0, solution.tf, samples)
    u = np.asarray(solution.control(t), dtype=float).reshape(samples, -1)[:, 0]
    on = np.r_[False, u >= upper * (1 - ON_BOUND), False]
    edges = np.flatnonzero(np.diff(on.astype(int)))
    starts, ends = edges[0::2], edges[1::2] - 1
    if not starts.size:
        raise SystemExit("the first mesh's control never reaches its bound: no junction to move")
    k = int(np.argmax(ends - starts))
    return float(t[starts[k]]), float(t[ends[k]])


def three_phases(problem, t1: float, t2: float, tf: float, window: float | None, on_arc: bool = True):
    """The problem cut at ``t1`` and ``t2`` into three phases with free junction times (within ``window`` seconds of
    them where given, else anywhere in the final time's box); ``on_arc``: the middle phase's control held on its
    upper bound (the arc's structure prescribed, so that its ends are the junctions)."""
    lo, hi = problem.tf.lower, problem.tf.upper

    def near(t: float, kind):
        if window is None:
            return kind(lo if kind is FreeFinalTime else 0.0, hi, t, scale=problem.tf.scale)
        return kind(t - window, t + window, t, scale=problem.tf.scale)

    def piece(k: int, first: bool, last: bool, t0, tf_end):
        states = [
            replace(s, initial=s.initial if first else None, final=s.final if last else None) for s in problem.states
        ]
        changes = {"name": f"{problem.name}_{k}", "states": states, "t0": t0, "tf": tf_end}
        if k == 1 and on_arc:  # the arc's control held on its bound: the junctions are then the arc's ends
            changes["controls"] = [replace(c, lower=c.upper, guess=c.upper) for c in problem.controls]
        if not last:
            changes["mayer"] = None
        return problem.replace(**changes)

    arc = t2 - t1
    if window is None:
        middle, rest = (
            Duration(1e-3, hi, arc, scale=problem.tf.scale),
            Duration(1e-3, hi, tf - t2, scale=problem.tf.scale),
        )
    else:
        middle = Duration(max(arc - 2 * window, 1e-3), arc + 2 * window, arc, scale=problem.tf.scale)
        rest = Duration(max(lo - t2 - window, 1e-3), hi, tf - t2, scale=problem.tf.scale)
    return [
        piece(0, True, False, 0.0, near(t1, FreeFinalTime)),
        piece(1, False, False, near(t1, FreeInitialTime), middle),
        piece(2, False, True, near(t2, FreeInitialTime), rest),
    ]


def intervals(t1: float, t2: float, tf: float) -> list[int]:
    """The first mesh's intervals shared by the three phases' durations (at least 3 each)."""
    return [max(3, round(FIRST * d / tf)) for d in (t1, t2 - t1, tf - t2)]


def moving(tolerance: float, window_intervals: float, on_arc: bool) -> dict:
    problem = hang_glider()
    t0 = time.perf_counter()
    first = HLGL(problem, FIRST).solve(ipopt_options=refinement_ipopt_options(None, tolerance), error_threshold=None)
    t1, t2 = bound_arc(first, problem.controls[0].upper)
    window = None if window_intervals == 0 else window_intervals * first.tf / FIRST
    pieces = three_phases(problem, t1, t2, first.tf, window, on_arc)
    program = Program.from_phases([HLGL(p, n) for p, n in zip(pieces, intervals(t1, t2, first.tf))])
    label = "junctions free in the box" if window is None else f"junctions within {window_intervals:g} intervals"
    label += "" if on_arc else ", the arc's control free"
    try:
        sol = program.solve(guess=[first] * 3, mesh_tolerance=tolerance, max_mesh_iterations=25)
    except SolverError as exc:
        return {"variant": label, "outcome": f"failed: {exc.status}", "first_junctions_s": f"{t1:.2f}, {t2:.2f}"}
    total = time.perf_counter() - t0
    fractions = [phase.scheme.mesh.fractions for phase in sol.program.phases]
    again = three_phases(hang_glider(), t1, t2, first.tf, window, on_arc)
    t_alone = time.perf_counter()
    try:
        alone = Program.from_phases([HLGL(p, mesh=f) for p, f in zip(again, fractions)]).solve(
            ipopt_options=refinement_ipopt_options(None, tolerance), error_threshold=None
        )
        alone_status, alone_iterations, alone_objective = alone.status, alone.iterations, alone.objective
    except SolverError as exc:
        alone_status, alone_iterations, alone_objective = exc.status, exc.iterations, float("nan")
    alone_s = time.perf_counter() - t_alone
    junctions = [sol.phase(0).tf, sol.phase(2).t0]
    history = sol.mesh_history
    return {
        "variant": label,
        "outcome": sol.refinement_outcome,
        "mesh_iterations": len(history),
        "collocation_points": sol.program.n_collocation_points,
        "objective": sol.objective,
        "first_junctions_s": f"{t1:.2f}, {t2:.2f}",
        "junctions_s": ", ".join(f"{t:.2f}" for t in junctions),
        "meshes": _path(history),
        "first_solve_iterations": history[0].ipopt_iterations,
        "first_solve_estimate": history[0].error_estimate,
        "total_s": total,
        "final_mesh_alone_s": alone_s,
        "final_mesh_alone_iterations": alone_iterations,
        "final_mesh_alone_objective": alone_objective,
        "final_mesh_alone_status": alone_status,
        "ratio": total / alone_s,
    }


def fixed(tolerance: float) -> dict:
    problem = hang_glider()
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        sol = HLGL(problem, FIRST).solve(mesh_tolerance=tolerance, max_mesh_iterations=25)
    total = time.perf_counter() - t0
    mesh = sol.program.scheme.mesh.fractions
    t_alone = time.perf_counter()
    alone = HLGL(hang_glider(), mesh=mesh).solve(
        ipopt_options=refinement_ipopt_options(None, tolerance), error_threshold=None
    )
    alone_s = time.perf_counter() - t_alone
    return {
        "variant": "fixed knots (solve(mesh_tolerance=...))",
        "outcome": sol.refinement_outcome,
        "mesh_iterations": len(sol.mesh_history),
        "collocation_points": sol.program.n_collocation_points,
        "objective": sol.objective,
        "meshes": _path(sol.mesh_history),
        "first_solve_iterations": sol.mesh_history[0].ipopt_iterations,
        "first_solve_estimate": sol.mesh_history[0].error_estimate,
        "total_s": total,
        "final_mesh_alone_s": alone_s,
        "final_mesh_alone_iterations": alone.iterations,
        "final_mesh_alone_objective": alone.objective,
        "final_mesh_alone_status": alone.status,
        "ratio": total / alone_s,
    }


def _path(history) -> str:
    """Each mesh's points, state estimate and IPOPT iterations: ``100: 4.9e-02 (44)``."""
    return "; ".join(f"{h.collocation_points}: {h.error_estimate:.1e} ({h.ipopt_iterations})" for h in history)


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "moving_knot.csv"))
    ap.add_argument("--tolerance", type=float, default=1e-6)
    ap.set_defaults(repeat=2)
    args = ap.parse_args()
    fixed(args.tolerance)  # warm-up: imports, the compiled blocks' libraries
    rows = []
    for make in [lambda: fixed(args.tolerance), *[lambda v=v: moving(args.tolerance, *v) for v in VARIANTS]]:
        runs = [make() for _ in range(args.repeat)]
        row = min(runs, key=lambda r: r.get("total_s", float("inf")))
        rows.append(row)
        print(f"{row['variant']}: {row['outcome']}, {row.get('total_s', float('nan')):.3f} s", flush=True)
    cols = [
        "variant",
        "outcome",
        "mesh_iterations",
        "collocation_points",
        "objective",
        "first_junctions_s",
        "junctions_s",
        "meshes",
        "first_solve_iterations",
        "first_solve_estimate",
        "total_s",
        "final_mesh_alone_s",
        "final_mesh_alone_iterations",
        "final_mesh_alone_objective",
        "ratio",
    ]
    for row in rows:
        for c in cols:
            row.setdefault(c, "")
    report(
        rows,
        cols,
        args.output,
        f"The hang glider from HLGL {FIRST} to {args.tolerance:g}, fixed and moving knots, best of {args.repeat}",
        {
            "objective": ".6f",
            "final_mesh_alone_objective": ".6f",
            "first_solve_estimate": ".1e",
            "ratio": ".1f",
        },
    )


if __name__ == "__main__":
    main()
