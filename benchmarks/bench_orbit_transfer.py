"""CPU time and |S| of the L1 orbit-transfer shooting, correction + variational Jacobian, against the slides.

    python benchmarks/bench_orbit_transfer.py [--repeat 1] [--thrusts 5 1 0.5 0.2 0.1] [--solvers hybr newton]

As the slides: the slides' reading (final longitude fixed, final time free), shooting
for lambda = 1 started from the energy-problem costates (cached in
data/derived/orbit_transfer_energy.csv by notebook 05), Dormand-Prince tolerances
1e-8, MINPACK hybrid (the slides' solver) and damped Newton. CPU is process time
(one core). Writes build/bench/orbit_transfer.csv. Goal (issue 9): converged, CPU and
|S| at or below the slides'.
"""

from __future__ import annotations

import argparse
import os

import numpy as np
import pandas as pd

from compendium.paper import paper_table
from compendium.paths import build_dir
from compendium.problems.orbit_transfer import orbit_transfer_constants
from compendium.studies import orbit_transfer as study
from compendium.tables import markdown_table


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument(
        "--thrusts",
        type=float,
        nargs="+",
        default=orbit_transfer_constants()["thrusts_N"],
        help="default: the slides' thrusts (data/problems/orbit_transfer.toml)",
    )
    ap.add_argument("--solvers", nargs="+", default=["hybr", "newton"])
    ap.add_argument("--output", default=str(build_dir() / "bench" / "orbit_transfer.csv"))
    args = ap.parse_args()
    energy = study.read_cache("orbit_transfer_energy")
    if energy is None or "reading" not in energy:
        raise SystemExit("no cached energy costates: run notebook 05 (make reproduce) first")
    slides = paper_table("switching_detection")
    systems = study.TransferSystems()
    rows = []
    for T in args.thrusts:
        if not ((energy.reading == "longitude") & np.isclose(energy.thrust_N, T)).any():
            print(f"{T:g} N: not in the cache, skipped")
            continue
        z = study.energy_start_vector(energy, "longitude", T)
        s = systems.shooting("fuel", T, switching="correction", jacobian="variational", tol=1e-8)
        sl = slides[
            np.isclose(slides.thrust_N, T) & (slides.detection == "correction") & (slides.jacobian == "variational")
        ].iloc[0]
        for solver in args.solvers:
            best = None
            for _ in range(args.repeat):
                r = s.solve(z, solver=solver, maxfev=300, raise_on_failure=False)
                best = r if best is None or r.cpu_s < best.cpu_s else best
            rows.append(
                {
                    "thrust_N": T,
                    "solver": solver,
                    "converged": best.converged,
                    "norm_S": best.norm,
                    "norm_S_slides": sl.norm_S,
                    "cpu_s": best.cpu_s,
                    "cpu_s_slides": sl.cpu_s,
                    "n_S": best.evaluations,
                    "n_jac": best.iterations,
                    "fuel_kg": study.fuel_kg(best),
                    "switchings": best.integration.switchings,
                    "goal_met": study.goal_met(best.converged, best.norm, sl, best.cpu_s),
                }
            )
            print(
                f"{T:g} N, {solver}: |S| = {best.norm:.1e} (slides {sl.norm_S:.1e}), "
                f"CPU {best.cpu_s:.2f} s (slides {sl.cpu_s:g} s)",
                flush=True,
            )
    df = pd.DataFrame(rows)
    os.makedirs(os.path.dirname(args.output), exist_ok=True)
    df.to_csv(args.output, index=False)
    print()
    print(
        markdown_table(
            df, {"norm_S": ".1e", "norm_S_slides": ".1e", "cpu_s": ".2f", "cpu_s_slides": ".0f", "fuel_kg": ".2f"}
        )
    )
    print(f"\nwritten {args.output}")


if __name__ == "__main__":
    main()
