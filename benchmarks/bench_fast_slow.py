"""The attitude ascent (notebook 08): build and solve times of every design against standard HLGL.

    python benchmarks/bench_fast_slow.py [--repeat 3] [--large 1000] [--publish]

Part 1: the designs, ratios and fine meshes of notebook 08's defaults (``compendium.studies.fast_slow``), best of
``--repeat``. ``--publish`` also writes the table to ``data/benchmarks/fast_slow.csv``, the measured times the
notebook's error-versus-time figure reads (the errors are computed by the notebook; the times are this
machine's). Part 2: the two designs that reach the standard's accuracy with fewer NLP parameters (attitude fast at
M = 2, positions slow at M = 4), at ``--large`` coarse segments, against standard HLGL on the same fine mesh. Writes ``build/bench/fast_slow.csv`` and ``build/bench/fast_slow_large.csv``.
"""

from __future__ import annotations

import os
import platform

import casadi
from _harness import best_of, ipopt_overrides, parser, report

from compendium.paths import build_dir, repo_root
from compendium.problems import attitude_ascent, load_problem_data
from compendium.studies.fast_slow import DESIGNS, MEASURED_TIMES, STANDARD, transcription

#: notebook 08's defaults (its parameters cell): the meshes, ratios and IPOPT tolerance timed for the published figure
FINE_SEGMENTS = [40, 80, 160, 320]
NOTEBOOK_TOL = 1e-12
RATIOS = [2, 4, 8]
COLUMNS = [
    "design",
    "ratio",
    "fine_segments",
    "nlp_parameters",
    "jacobian_nnz",
    "hessian_nnz",
    "build_s",
    "solve_s",
    "functions_s",
    "end_to_end_s",
    "iterations",
]


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "fast_slow.csv"))
    ap.add_argument("--large", type=int, default=1000, help="coarse segments of part 2")
    ap.add_argument("--publish", action="store_true", help=f"also write part 1 to {MEASURED_TIMES}")
    args = ap.parse_args()
    opts = {"tol": NOTEBOOK_TOL} | ipopt_overrides(args.ipopt)
    pr = attitude_ascent()
    runs = [(STANDARD, 1)] + [(d, m) for d in DESIGNS for m in RATIOS]
    best_of(lambda: transcription(pr, STANDARD, 40), opts, 1)  # warm-up
    rows = []
    for fine in FINE_SEGMENTS:
        for design, ratio in runs:
            row = {"design": design, "ratio": ratio, "fine_segments": fine}
            row |= best_of(lambda d=design, f=fine, m=ratio: transcription(pr, d, f, m), opts, args.repeat)
            rows.append(row)
            print(f"{design:34s} M={ratio} fine {fine:4d}: end to end {row['end_to_end_s']:.3f} s", flush=True)
    machine = f"casadi {casadi.__version__}, {platform.machine()}, {os.cpu_count()} cores"
    df = report(rows, COLUMNS, args.output, f"Attitude ascent: designs against standard HLGL, best of {args.repeat}")
    if args.publish:
        target = repo_root() / MEASURED_TIMES
        target.parent.mkdir(parents=True, exist_ok=True)
        weight = load_problem_data("attitude_ascent")["attitude"]["effort_weight"]
        df = df.assign(effort_weight=weight, ipopt_tol=opts["tol"], machine=machine, repeat=args.repeat)
        df.to_csv(target, index=False, float_format="%.4g")
        print(f"published {target.relative_to(repo_root())}")

    large = []
    for design, ratio in (("Galerkin, attitude fast", 2), ("Galerkin, positions slow", 4)):
        fine = args.large * ratio
        for name, m in ((STANDARD, 1), (design, ratio)):
            row = {"design": name, "ratio": m, "fine_segments": fine}
            row |= best_of(lambda d=name, f=fine, r=m: transcription(pr, d, f, r), opts, args.repeat)
            large.append(row)
            print(f"{name:34s} M={m} fine {fine:5d}: end to end {row['end_to_end_s']:.3f} s", flush=True)
    out = os.path.join(os.path.dirname(args.output), "fast_slow_large.csv")
    report(large, COLUMNS, out, f"Attitude ascent at {args.large} coarse segments, best of {args.repeat}")


if __name__ == "__main__":
    main()
