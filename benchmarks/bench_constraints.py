"""Build and solve time with path and boundary constraints and with phases, beside the unconstrained problems.

    python benchmarks/bench_constraints.py [--repeat 3]

Rows: the entry landing (Radau, 10 nodes x 40 intervals, downrange free) without and with the sensed-acceleration
limit (2.6 g0, a mixed path constraint at 401 points); Bryson-Denham (HLGL 30 segments, Radau 4 x 30) with the
state constraint x <= 1/9; the four-phase Delta III launch (4 x Radau 8 x 4, linked, with a path equality, an
altitude limit and an orbit boundary constraint). The constraints are blocks like the defects, so build and solve
times should grow with the NLP's size, not faster. Writes ``build/bench/constraints.csv``.
"""

from __future__ import annotations

import time

from _harness import best_of, ipopt_overrides, parser, report

from ocpkit import HLGL, Link, Program, Radau

from compendium.paths import build_dir
from compendium.problems import bryson_denham, delta3_guesses, delta3_mass_drops, delta3_phases
from compendium.problems.entry_landing import entry_landing


def delta3(opts):
    t0 = time.perf_counter()
    drops = delta3_mass_drops()
    phases = delta3_phases()
    mp = Program.from_phases(
        [Radau(p, 8, 4) for p in phases], [Link(k, k + 1, jumps={"m": drops[k]}) for k in range(3)]
    )
    sol = mp.solve(delta3_guesses(), ipopt_options={"tol": 1e-8, **opts})
    return {
        "problem": "Delta III, 4 phases",
        "nlp_parameters": sol.decision_variables,
        "constraints": sol.constraints,
        "jacobian_nnz": mp.nlp.nnz_jacobian,
        "hessian_nnz": mp.nlp.nnz_hessian,
        "build_s": mp.build_s,
        "solve_s": sol.solve_s,
        "end_to_end_s": time.perf_counter() - t0,
        "iterations": sol.iterations,
    }


CASES = [
    ("entry landing, Radau 10 x 40", lambda: Radau(entry_landing(), 10, 40)),
    ("entry landing + sensed g <= 2.6", lambda: Radau(entry_landing(max_sensed_g=2.6), 10, 40)),
    ("Bryson-Denham x <= 1/9, HLGL 30", lambda: HLGL(bryson_denham(), 30)),
    ("Bryson-Denham x <= 1/9, Radau 4 x 30", lambda: Radau(bryson_denham(), 4, 30)),
]


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "constraints.csv"))
    args = ap.parse_args()
    opts = ipopt_overrides(args.ipopt)
    best_of(CASES[2][1], opts, 1)  # warm-up
    rows = []
    for label, make in CASES:
        row = {"problem": label, **best_of(make, opts, args.repeat)}
        rows.append(row)
        print(f"{label}: end to end {row['end_to_end_s']:.3f} s", flush=True)
    row = min((delta3(opts) for _ in range(args.repeat)), key=lambda r: r["end_to_end_s"])
    rows.append(row)
    print(f"{row['problem']}: end to end {row['end_to_end_s']:.3f} s", flush=True)
    cols = [
        "problem",
        "nlp_parameters",
        "constraints",
        "jacobian_nnz",
        "hessian_nnz",
        "build_s",
        "solve_s",
        "end_to_end_s",
        "iterations",
    ]
    report(rows, cols, args.output, f"Constraints and phases, best of {args.repeat}")


if __name__ == "__main__":
    main()
