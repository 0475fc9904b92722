"""Two-timescale versus standard HLGL on the lunar ascent: build and solve time.

    python benchmarks/bench_multirate.py [--repeat 3] [--large 1000]

Rows: the paper's Case 1 (10/20, U and V fast) and Case 2 (10/40, V fast) with
their standard meshes, and large Case 2 layouts (``--large`` coarse segments,
M = 4 and 8) against the standard mesh that resolves the same fast dynamics (M
times as many segments for every state). ``functions_s`` is the part of the
solve spent in the NLP's functions and derivatives, the rest IPOPT's own work
(mostly the KKT factorisations, which follow the nonzeros). Writes
``build/bench/multirate.csv``.
"""

from __future__ import annotations

from _harness import best_of, ipopt_overrides, parser, report

from ocpkit import HLGL, MultiRateHLGL

from compendium.paths import build_dir
from compendium.problems import lunar_ascent


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "multirate.csv"))
    ap.add_argument("--large", type=int, default=1000, help="coarse segments of the large M = 4 case")
    args = ap.parse_args()
    opts = ipopt_overrides(args.ipopt)
    pr = lunar_ascent()
    cases = [
        ("standard", "20", lambda: HLGL(pr, 20)),
        ("two_to_one (U, V fast)", "10/20", lambda: MultiRateHLGL(pr, 10, ratio=2, fast=["U", "V"])),
        ("standard", "40", lambda: HLGL(pr, 40)),
        ("four_to_one (V fast)", "10/40", lambda: MultiRateHLGL(pr, 10, ratio=4, fast=["V"])),
        ("standard", f"{4 * args.large}", lambda: HLGL(pr, 4 * args.large)),
        (
            "four_to_one (V fast)",
            f"{args.large}/{4 * args.large}",
            lambda: MultiRateHLGL(pr, args.large, ratio=4, fast=["V"]),
        ),
        ("standard", f"{8 * args.large}", lambda: HLGL(pr, 8 * args.large)),
        (
            "eight_to_one (V fast)",
            f"{args.large}/{8 * args.large}",
            lambda: MultiRateHLGL(pr, args.large, ratio=8, fast=["V"]),
        ),
    ]
    best_of(cases[0][2], opts, 1)  # warm-up
    rows = []
    for scheme, segments, make in cases:
        row = {"scheme": scheme, "segments": segments, **best_of(make, opts, args.repeat)}
        rows.append(row)
        print(f"{scheme:24s} {segments:>10s}: end to end {row['end_to_end_s']:.3f} s", flush=True)
    cols = [
        "scheme",
        "segments",
        "nlp_parameters",
        "defect_equations",
        "jacobian_nnz",
        "hessian_nnz",
        "hessian_instructions",
        "build_s",
        "solve_s",
        "functions_s",
        "end_to_end_s",
        "iterations",
    ]
    report(rows, cols, args.output, f"Standard vs two-timescale HLGL, lunar ascent, best of {args.repeat}")


if __name__ == "__main__":
    main()
