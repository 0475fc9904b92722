"""Cost per integration step of the 14-dimensional Hamiltonian system of the orbit transfer.

    python benchmarks/bench_shooting.py [--hours 200] [--repeat 5]

The minimum-fuel GTO-GEO transfer (7 states, 7 costates, plus the running cost) with
its bang-bang law, from a costate that switches the thrust a few dozen times:

* the compiled Dormand-Prince integrator (ocpkit.shooting, C) with no detection,
  detection and correction, without and with the 7 variational columns;
* a plain Python Dormand-Prince loop calling the CasADi flow function once per
  stage (what a numpy-per-stage implementation costs), on a few hundred steps.

Writes ``build/bench/shooting.csv``. The next issue integrates ~30 000 steps per
shooting evaluation.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import pandas as pd

from ocpkit.shooting import CompiledSystem, HamiltonianSystem, control_law

from compendium.paths import build_dir
from compendium.problems import orbit_transfer
from compendium.problems.orbit_transfer import STATE_NAMES, orbit_transfer_constants
from compendium.tables import markdown_table

A = [
    [],
    [0.2],
    [3 / 40, 9 / 40],
    [44 / 45, -56 / 15, 32 / 9],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
]
B = [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84]


def python_steps(flow, y0, h, steps, P):
    """Fixed-step Dormand-Prince in Python, one CasADi call per stage (no error control: a lower bound)."""
    y = np.array(y0, dtype=float)
    for _ in range(steps):
        k = []
        for i in range(6):
            yi = y + h * sum(a * kj for a, kj in zip(A[i], k)) if i else y
            k.append(np.asarray(flow(yi, 1.0, P)).ravel())
        y = y + h * sum(b * kj for b, kj in zip(B, k))
    return y


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hours", type=float, default=200.0)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--output", default=str(build_dir() / "bench" / "shooting.csv"))
    args = ap.parse_args()
    problem = orbit_transfer(5.0, lam=1.0, final="time", tf=args.hours)
    t = time.perf_counter()
    system = HamiltonianSystem(problem, control_law(problem, "ball"))
    compiled = CompiledSystem(system)
    build = time.perf_counter() - t
    P = problem.parameter_values
    initial = orbit_transfer_constants()["initial"]
    x0 = [initial[name] for name in STATE_NAMES]
    y0 = np.concatenate([x0, 300 * np.array([0.02, 0.1, 0.05, 0.1, 0.05, 0, 0]), [0]])
    Psi0 = np.zeros((system.n, system.n_variational))
    Psi0[7:14] = np.eye(7)
    rows = []
    for variational in (False, True):
        for detection in ("none", "detection", "correction"):
            best, res = float("inf"), None
            for _ in range(args.repeat):
                t = time.perf_counter()
                res = compiled.integrate(
                    y0, 0.0, args.hours, switching=detection, record=False, Psi0=Psi0 if variational else None
                )
                best = min(best, time.perf_counter() - t)
            rows.append(
                {
                    "implementation": "compiled C",
                    "detection": detection,
                    "variational_columns": system.n_variational if variational else 0,
                    "steps": res.steps,
                    "switchings": res.switchings,
                    "rhs_evaluations": res.rhs_evaluations,
                    "wall_s": best,
                    "us_per_step": 1e6 * best / res.steps,
                }
            )
    n_py = 300
    t = time.perf_counter()
    python_steps(system.flow, y0, 0.05, n_py, P)
    wall = time.perf_counter() - t
    rows.append(
        {
            "implementation": "Python loop, CasADi call per stage",
            "detection": "-",
            "variational_columns": 0,
            "steps": n_py,
            "switchings": 0,
            "rhs_evaluations": 6 * n_py,
            "wall_s": wall,
            "us_per_step": 1e6 * wall / n_py,
        }
    )
    df = pd.DataFrame(rows)
    os.makedirs(os.path.dirname(args.output), exist_ok=True)
    df.to_csv(args.output, index=False)
    print(
        f"orbit transfer Hamiltonian system (n = {system.n}), {args.hours} h, best of {args.repeat}; "
        f"codegen and compilation {build:.2f} s (cached afterwards)\n"
    )
    print(markdown_table(df, {"wall_s": ".4f", "us_per_step": ".2f"}))
    compiled_plain = df[(df.implementation == "compiled C") & (df.variational_columns == 0)].us_per_step.max()
    print(
        f"\nper step, the Python loop (no error control, no switching logic) costs "
        f"{df.us_per_step.iloc[-1] / compiled_plain:.0f} times the compiled integrator"
    )
    print(f"written {args.output}")


if __name__ == "__main__":
    main()
