"""Whole-process cost of one solve: `import ocpkit` and a 20-segment HLGL solve, against plain CasADi.

    python benchmarks/bench_process.py [--repeat 10]

Rows:
- ``import``: ``python -c "import ocpkit"`` against ``python -c "import casadi"``, and ocpkit's cumulative import
  time from ``python -X importtime`` (issue 14's goal: under 0.15 s);
- ``flat_moon`` and ``lunar_ascent``: ``process/ocpkit_solve.py`` (import ocpkit, pose, solve) against
  ``process/casadi_solve.py`` (the same HLGL NLP written in plain CasADi, same IPOPT options and start), whole
  processes (issue 26's goal: within 1.1x). Both must print the same t_f (to 1e-9, relative) and iterations, and t_f
  must equal the compendium's own solve of the problem;
- ``compendium one-liner``: ``python -c "...HLGL(flat_moon_ascent(), 20).solve()..."``, the problem posed by the
  compendium's module from its TOML data and solved with the default error estimate, against the plain CasADi
  flat moon (goal: within 1.5x).

Each time is the median of ``--repeat`` runs (the minimum is in the CSV too), after one warm-up run, with
``PYTHONDONTWRITEBYTECODE`` removed from the environment: as installed (pip writes bytecode at install time), a
process imports compiled modules; compiling ocpkit's sources on every import costs about 45 ms more.
Writes ``build/bench/process.csv``.
"""

from __future__ import annotations

import os
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

from _harness import goal, parser, report

from ocpkit import HLGL

from compendium.paths import build_dir
from compendium.problems import flat_moon_ascent, lunar_ascent

HERE = Path(__file__).resolve().parent
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def wall(cmd: list[str], repeat: int) -> tuple[float, float, str]:
    """Median and minimum wall time of a command over ``repeat`` runs, and its last output."""
    times = []
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=ENV).stdout  # warm-up: bytecode
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=ENV).stdout
        times.append(time.perf_counter() - t0)
    return statistics.median(times), min(times), out


def importtime(module: str, repeat: int) -> float:
    """Median cumulative import time (s) of ``module`` by ``python -X importtime``."""
    values = []
    for _ in range(repeat):
        err = subprocess.run(
            [sys.executable, "-X", "importtime", "-c", f"import {module}"],
            check=True,
            capture_output=True,
            text=True,
            env=ENV,
        ).stderr
        line = [ln for ln in err.splitlines() if re.search(rf"\|\s*{re.escape(module)}$", ln)][-1]
        values.append(int(line.split("|")[1]) * 1e-6)
    return statistics.median(values)


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "process.csv"))
    ap.set_defaults(repeat=10)
    args = ap.parse_args()
    py = sys.executable
    rows = []
    med_o, min_o, _ = wall([py, "-c", "import ocpkit"], args.repeat)
    med_c, min_c, _ = wall([py, "-c", "import casadi"], args.repeat)
    rows.append(
        {
            "case": "import",
            "ocpkit_s": med_o,
            "casadi_s": med_c,
            "ratio": med_o / med_c,
            "ocpkit_min_s": min_o,
            "casadi_min_s": min_c,
            "importtime_ocpkit_s": importtime("ocpkit", args.repeat),
            "importtime_casadi_s": importtime("casadi", args.repeat),
            "goal": "",
        }
    )
    reference = {"flat_moon": flat_moon_ascent, "lunar_ascent": lunar_ascent}
    for case, make in reference.items():
        med_o, min_o, out_o = wall([py, str(HERE / "process" / "ocpkit_solve.py"), case], args.repeat)
        med_c, min_c, out_c = wall([py, str(HERE / "process" / "casadi_solve.py"), case], args.repeat)
        (tf_o, it_o), (tf_c, it_c) = (out.split() for out in (out_o, out_c))
        tf_ref = HLGL(make(), 20).solve(error_threshold=None).tf
        for label, tf in (("plain CasADi", float(tf_c)), ("compendium", tf_ref)):
            if abs(float(tf_o) / tf - 1) > 1e-9:
                raise SystemExit(f"{case}: t_f {tf_o} differs from the {label} solve's {tf}")
        rows.append(
            {
                "case": f"{case}, HLGL 20",
                "ocpkit_s": med_o,
                "casadi_s": med_c,
                "ratio": med_o / med_c,
                "ocpkit_min_s": min_o,
                "casadi_min_s": min_c,
                "iterations": f"{it_o} / {it_c}",
                "goal": goal(med_o / med_c, 1.1),
            }
        )
        print(f"{case}: ocpkit {med_o:.3f} s, plain CasADi {med_c:.3f} s", flush=True)
        if case == "flat_moon":
            flat_moon_casadi = (med_c, min_c)
    one_liner = (
        "from ocpkit import HLGL; from compendium.problems import flat_moon_ascent; "
        "print(HLGL(flat_moon_ascent(), 20).solve().tf)"
    )
    med_o, min_o, out_o = wall([py, "-c", one_liner], args.repeat)
    if abs(float(out_o) / HLGL(flat_moon_ascent(), 20).solve().tf - 1) > 1e-9:
        raise SystemExit(f"compendium one-liner: t_f {out_o} differs from the in-process solve")
    med_c, min_c = flat_moon_casadi
    rows.append(
        {
            "case": "compendium one-liner, flat moon HLGL 20",
            "ocpkit_s": med_o,
            "casadi_s": med_c,
            "ratio": med_o / med_c,
            "ocpkit_min_s": min_o,
            "casadi_min_s": min_c,
            "goal": goal(med_o / med_c, 1.5),
        }
    )
    print(f"compendium one-liner: {med_o:.3f} s", flush=True)
    cols = ["case", "ocpkit_s", "casadi_s", "ratio", "goal", "ocpkit_min_s", "casadi_min_s"]
    df = report(rows, cols, args.output, f"Whole processes, median of {args.repeat}", {"ratio": ".2f"})
    imp = df.iloc[0]
    print(f"\npython -X importtime: ocpkit {imp.importtime_ocpkit_s:.3f} s, casadi {imp.importtime_casadi_s:.3f} s")


if __name__ == "__main__":
    main()
