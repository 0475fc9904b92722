"""Cost of mesh refinement: total time to a tolerance against the final mesh's single solve.

    python benchmarks/bench_refinement.py [--repeat 3] [--tolerance 1e-6]

Rows: the hyper-sensitive problem (t_f = 1e4, Radau from 4 nodes x 10 intervals) and the entry landing (Radau from
4 nodes x 10 intervals), refined with solve(mesh_tolerance=...). Columns: mesh iterations, final collocation points,
the estimate, the whole refinement's wall time, the final mesh's own build + solve (from cold, on its own), and their
ratio (issue 12's goal: below 3). Writes ``build/bench/refinement.csv``.
"""

from __future__ import annotations

import time
import warnings

from _harness import ipopt_overrides, parser, report

from ocpkit import Radau
from ocpkit.accuracy import AccuracyWarning

from compendium.paths import build_dir
from compendium.problems import entry_landing, hyper_sensitive

CASES = [("hyper-sensitive, t_f = 1e4", lambda: hyper_sensitive(1e4)), ("entry landing", entry_landing)]


def run(label, make, tolerance, opts):
    problem = make()
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        sol = Radau(problem, 4, 10).solve(mesh_tolerance=tolerance, max_mesh_iterations=25, ipopt_options=opts)
    total = time.perf_counter() - t0
    final = sol.raw["transcription"]
    t1 = time.perf_counter()
    Radau(problem, final.counts.tolist(), mesh=final.mesh.fractions).solve(ipopt_options=opts, error_threshold=None)
    single = time.perf_counter() - t1
    return {
        "problem": label,
        "tolerance": tolerance,
        "mesh_iterations": len(sol.mesh_history),
        "collocation_points": final.n_collocation_points,
        "error_estimate": sol.error_estimate,
        "total_s": total,
        "final_mesh_alone_s": single,
        "ratio": total / single,
    }


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "refinement.csv"))
    ap.add_argument("--tolerance", type=float, default=1e-6)
    args = ap.parse_args()
    opts = ipopt_overrides(args.ipopt)
    rows = []
    for label, make in CASES:
        row = min((run(label, make, args.tolerance, opts) for _ in range(args.repeat)), key=lambda r: r["total_s"])
        rows.append(row)
        print(f"{label}: {row['total_s']:.3f} s in total, {row['ratio']:.1f} x the final mesh alone", flush=True)
    cols = [
        "problem",
        "tolerance",
        "mesh_iterations",
        "collocation_points",
        "error_estimate",
        "total_s",
        "final_mesh_alone_s",
        "ratio",
    ]
    report(
        rows,
        cols,
        args.output,
        f"Mesh refinement to {args.tolerance:g}, best of {args.repeat}",
        {"error_estimate": ".1e", "ratio": ".1f"},
    )


if __name__ == "__main__":
    main()
