"""Cost of the whole verdict of a solve (ocpkit.verdict) against the solve itself, on notebook 07's published problems.

    python benchmarks/bench_verdict.py [--repeat 3]

Rows: every case of notebook 07's table of published problems beyond the seeds
(:data:`compendium.studies.beyond_the_seeds.CASES`: the problem on its starting mesh). Each is built and solved with
nothing judged (``solve(error_threshold=None)``: ``solve_s`` is the build and IPOPT's solve, end to end), then judged
as ``solve()`` does by default (``verdict_s``: the whole verdict at 1e-3 and what it says, its messages: the state
estimate, the objective's flight of the control, the path constraints between points, the notes) and with
``verdict="fast"`` (``fast_s``: all but the objective's part). The goal (issue 41): the whole verdict below 20 % of the
solve, ``ratio = verdict_s / solve_s``, on every row; the last row is the sum over the cases. The run with the
fastest solve and verdict of ``--repeat`` each (both times from that run). The verdict's cost is mostly one flight of
the control (CVODES, about 2-5 ms on a small problem), a fixed cost that solves of 20-40 ms do not amortise. Writes
``build/bench/verdict.csv``.
"""

from __future__ import annotations

import time
import warnings

from _harness import goal, parser, report

from ocpkit import SolverError
from ocpkit.accuracy import AccuracyWarning

from compendium.paths import build_dir
from compendium.studies.beyond_the_seeds import CASES

GOAL = 0.20


def timed(case) -> dict:
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        try:
            sol = case.transcription().solve(error_threshold=None)
        except SolverError as exc:
            return {"status": exc.status}
    solve_s = time.perf_counter() - start
    start = time.perf_counter()
    whole = sol.judge(1e-3, "whole")
    messages = whole.messages()
    verdict_s = time.perf_counter() - start
    for cached in (sol, *sol.phases):  # (a solution caches its estimates: the fast verdict computes its own)
        for name in ("accuracy", "interval_errors"):
            cached.__dict__.pop(name, None)
    start = time.perf_counter()
    sol.judge(1e-3, "fast").messages()
    fast_s = time.perf_counter() - start
    return {
        "status": sol.status,
        "solve_s": solve_s,
        "verdict_s": verdict_s,
        "fast_s": fast_s,
        "passed": whole.passed,
        "said": len(messages),
    }


def main() -> None:
    args = parser(__doc__.splitlines()[0], str(build_dir() / "bench" / "verdict.csv")).parse_args()
    rows = []
    for case in CASES:
        runs = [timed(case) for _ in range(args.repeat)]
        best = min(runs, key=lambda r: r.get("solve_s", 0.0) + r.get("verdict_s", 0.0))  # (its solve and verdict)
        row = {"problem": case.problem, "start": case.label, **best}
        if "solve_s" in row:
            row["ratio"] = row["verdict_s"] / row["solve_s"]
            row["goal"] = goal(row["ratio"], GOAL, "")
        rows.append(row)
    solved = [r for r in rows if "solve_s" in r]
    total = {k: sum(r[k] for r in solved) for k in ("solve_s", "verdict_s", "fast_s")}
    total["ratio"] = total["verdict_s"] / total["solve_s"]
    rows.append({"problem": "all cases", "start": "", "status": "", **total, "goal": goal(total["ratio"], GOAL, "")})
    report(
        rows,
        ["problem", "start", "status", "solve_s", "verdict_s", "fast_s", "ratio", "goal", "passed", "said"],
        args.output,
        "The whole verdict against the solve (notebook 07's published problems, each on its starting mesh)",
        {"ratio": ".2f"},
    )


if __name__ == "__main__":
    main()
