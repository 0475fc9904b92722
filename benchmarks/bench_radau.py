"""Build and solve time of the Radau (LGR) entry-landing problem.

    python benchmarks/bench_radau.py [--repeat 3]

Rows: global collocation with 60 and 100 nodes (the post's N = 100; target under
1 s end to end on the 2-core reference machine, issue 4) and multi-interval
meshes of 10 nodes per interval (20 intervals: the issue's scaling row; 80).
Writes ``build/bench/radau.csv``.
"""

from __future__ import annotations

from _harness import best_of, ipopt_overrides, parser, report

from ocpkit import Radau

from compendium.paths import build_dir
from compendium.problems import entry_landing

MESHES = [(60, 1, float("nan")), (100, 1, 1.0), (10, 20, float("nan")), (10, 80, float("nan"))]


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "radau.csv"))
    args = ap.parse_args()
    opts = ipopt_overrides(args.ipopt)
    problem = entry_landing()
    best_of(lambda: Radau(problem, 10, 2), opts, 1)  # warm-up
    rows = []
    for n, k, target in MESHES:
        row = {
            "nodes": n,
            "intervals": k,
            **best_of(lambda n=n, k=k: Radau(problem, n, k), opts, args.repeat),
            "target_s": target,
        }
        rows.append(row)
        print(f"{n:4d} nodes x {k:3d} intervals: end to end {row['end_to_end_s']:.3f} s", flush=True)
    cols = ["nodes", "intervals", "nlp_parameters", "build_s", "solve_s", "end_to_end_s", "iterations", "target_s"]
    report(rows, cols, args.output, f"Radau entry-landing, best of {args.repeat}")


if __name__ == "__main__":
    main()
