"""Build and solve time of the HLGL lunar ascent versus the number of segments.

    python benchmarks/bench_hlgl.py [--segments 20 200 1000 5000] [--repeat 3] [--ipopt key=value ...]

Each row is the best of ``--repeat`` runs, every run building the NLP from
scratch (transcription, derivative assembly, IPOPT solver) and solving it from
the default guess. Writes ``build/bench/hlgl.csv`` and prints a Markdown table.

Targets on the 2-core reference machine (issue 2): 20 segments end to end under
0.1 s, 1000 under 2 s, 5000 under 15 s, growing about linearly.
"""

from __future__ import annotations

import argparse
import ast
import os
import platform
import time

import casadi
import pandas as pd

from ocpkit import HLGL
from ocpkit.paths import build_dir
from ocpkit.problems import lunar_ascent
from ocpkit.tables import markdown_table

TARGETS_S = {20: 0.1, 1000: 2.0, 5000: 15.0}


def run_once(segments: int, ipopt_options: dict) -> dict:
    t0 = time.perf_counter()
    tr = HLGL(lunar_ascent(), segments)
    tr.solver(ipopt_options)
    sol = tr.solve(ipopt_options=ipopt_options)
    total = time.perf_counter() - t0
    return {
        "segments": segments,
        "nlp_parameters": sol.nlp_parameters,
        "defect_equations": sol.defect_equations,
        "build_s": tr.build_s,
        "solve_s": sol.solve_s,
        "end_to_end_s": total,
        "iterations": sol.iterations,
        "tf": sol.tf,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--segments", type=int, nargs="+", default=[20, 200, 1000, 5000])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ipopt", nargs="*", default=[], metavar="KEY=VALUE", help="IPOPT option overrides")
    ap.add_argument("--output", default=str(build_dir() / "bench" / "hlgl.csv"))
    args = ap.parse_args()
    if args.repeat < 1:
        ap.error("--repeat must be at least 1")
    opts = {}
    for kv in args.ipopt:
        key, _, value = kv.partition("=")
        try:
            opts[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            opts[key] = value

    run_once(20, opts)  # warm-up: imports, CasADi plugin loading
    rows = []
    for n in args.segments:
        runs = [run_once(n, opts) for _ in range(args.repeat)]
        best = min(runs, key=lambda r: r["end_to_end_s"])
        best["target_s"] = TARGETS_S.get(n, float("nan"))
        rows.append(best)
        print(f"{n:6d} segments: build {best['build_s']:.3f} s, solve {best['solve_s']:.3f} s, "
              f"end to end {best['end_to_end_s']:.3f} s, {best['iterations']} iterations", flush=True)
    df = pd.DataFrame(rows)
    os.makedirs(os.path.dirname(args.output), exist_ok=True)
    df.to_csv(args.output, index=False)
    print()
    print(f"HLGL lunar ascent, best of {args.repeat}; casadi {casadi.__version__}, "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores")
    print()
    cols = ["segments", "nlp_parameters", "build_s", "solve_s", "end_to_end_s", "iterations", "target_s"]
    print(markdown_table(df[cols], {c: ".3f" for c in ("build_s", "solve_s", "end_to_end_s", "target_s")}))
    print(f"\nwritten {args.output}")


if __name__ == "__main__":
    main()
