"""The flat-moon ascent on HLGL 5000 segments end to end, and its linear algebra against every solver available.

    python benchmarks/bench_scale.py [--segments 5000] [--repeat 2]

Issue 26's goals at scale, on one NLP (the flat moon, HLGL, ``--segments``), best of ``--repeat`` runs each:

- **end to end** (build of the NLP and IPOPT instance, solve from the default guess, the Solution): at most 1.5 s;
- **linear algebra** (IPOPT's time less its function evaluations, ``solve_s - functions_s``) with ocpkit's default
  (MUMPS, QAMD ordering) against each linear solver CasADi's IPOPT loads here: MUMPS with its AMF, AMD, PORD and
  automatic orderings, and SPRAL (HSL's MA27/57/86/97 and Pardiso need libraries casadi's wheel does not ship);
  the default within 1.15x of the fastest. Every solve must end on the default's t_f (to 1e-9, relative).

Writes ``build/bench/scale.csv``.
"""

from __future__ import annotations

from _harness import best_of, goal, parser, report

from ocpkit import HLGL

from compendium.paths import build_dir
from compendium.problems import flat_moon_ascent

SOLVERS = {
    "mumps (QAMD, ocpkit's default)": {},
    "mumps (AMF)": {"mumps_pivot_order": 2},
    "mumps (AMD)": {"mumps_pivot_order": 0},
    "mumps (PORD)": {"mumps_pivot_order": 4},
    "mumps (automatic)": {"mumps_pivot_order": 7},
    "spral": {"linear_solver": "spral"},
}
GOAL_END_TO_END_S = 1.5
GOAL_LINEAR_ALGEBRA = 1.15


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "scale.csv"))
    ap.add_argument("--segments", type=int, default=5000)
    ap.set_defaults(repeat=2)
    args = ap.parse_args()
    problem = flat_moon_ascent()
    best_of(lambda: HLGL(problem, 20), {}, 1)  # warm-up: imports, plugins
    rows = []
    for label, options in SOLVERS.items():
        try:
            row = best_of(lambda: HLGL(problem, args.segments), options, args.repeat)
        except Exception as exc:  # noqa: BLE001 - a solver that does not load or fails is a row saying so
            rows.append({"linear_solver": label, "status": f"{type(exc).__name__}: {str(exc)[:80]}"})
            print(f"{label}: {rows[-1]['status']}", flush=True)
            continue
        row["linear_algebra_s"] = row["solve_s"] - row["functions_s"]
        rows.append({"linear_solver": label, "status": "ok", **row})
        print(f"{label}: end to end {row['end_to_end_s']:.3f} s, linear algebra {row['linear_algebra_s']:.3f} s")
    default = rows[0]
    if default["status"] != "ok":
        raise SystemExit(f"the default solve failed: {default['status']}")
    for row in rows[1:]:
        if row["status"] == "ok" and abs(row["tf"] / default["tf"] - 1) > 1e-9:
            raise SystemExit(f"{row['linear_solver']}: t_f {row['tf']} differs from the default's {default['tf']}")
    fastest = min(r["linear_algebra_s"] for r in rows if r["status"] == "ok")
    for row in rows:
        if row["status"] == "ok":
            row["over_fastest"] = row["linear_algebra_s"] / fastest
    default["goal"] = (
        f"end to end {goal(default['end_to_end_s'], GOAL_END_TO_END_S, ' s')}; "
        f"linear algebra {goal(default['over_fastest'], GOAL_LINEAR_ALGEBRA)}"
    )
    cols = ["linear_solver", "status", "build_s", "solve_s", "functions_s", "linear_algebra_s", "over_fastest"]
    cols += ["end_to_end_s", "iterations", "goal"]
    for row in rows:
        for c in cols:
            row.setdefault(c, "")
    report(rows, cols, args.output, f"Flat moon, HLGL {args.segments}, best of {args.repeat}", {"over_fastest": ".2f"})


if __name__ == "__main__":
    main()
