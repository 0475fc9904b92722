"""Build and solve time of the HLGL lunar ascent versus the number of segments.

    python benchmarks/bench_hlgl.py [--segments 20 200 1000 5000] [--repeat 3] [--ipopt key=value ...]

Each row is the best of ``--repeat`` runs, every run building the NLP from
scratch (transcription, derivative assembly, IPOPT solver) and solving it from
the default guess. Writes ``build/bench/hlgl.csv`` and prints a Markdown table.

Targets on the 2-core reference machine (issue 2): 20 segments end to end under
0.1 s, 1000 under 2 s, 5000 under 15 s, growing about linearly.
"""

from __future__ import annotations

from _harness import best_of, ipopt_overrides, parser, report

from ocpkit import HLGL

from compendium.paths import build_dir
from compendium.problems import lunar_ascent

TARGETS_S = {20: 0.1, 1000: 2.0, 5000: 15.0}


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "hlgl.csv"))
    ap.add_argument("--segments", type=int, nargs="+", default=[20, 200, 1000, 5000])
    args = ap.parse_args()
    opts = ipopt_overrides(args.ipopt)
    problem = lunar_ascent()
    best_of(lambda: HLGL(problem, 20), opts, 1)  # warm-up: imports, plugin loading
    rows = []
    for n in args.segments:
        row = {"segments": n, **best_of(lambda n=n: HLGL(problem, n), opts, args.repeat)}
        row["target_s"] = TARGETS_S.get(n, float("nan"))
        rows.append(row)
        print(f"{n:6d} segments: end to end {row['end_to_end_s']:.3f} s", flush=True)
    cols = ["segments", "nlp_parameters", "build_s", "solve_s", "end_to_end_s", "iterations", "target_s"]
    report(rows, cols, args.output, f"HLGL lunar ascent, best of {args.repeat}")


if __name__ == "__main__":
    main()
