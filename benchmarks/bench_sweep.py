"""Sweeps on Dask: the same sweep on 1 and 2 workers of a LocalCluster (this machine has 2 cores).

    python benchmarks/bench_sweep.py [--points 400]

Two sweeps (``compendium.studies.sweeps``): the flat-moon ascent over ``--points`` thrust-to-weight ratios
(one transcription built per worker, about 14 ms per solve), and the entry landing over a 9 x 8 grid of
initial speeds and flight-path angles (a build per point, 0.05 to 0.5 s per solve, some infeasible). The
cluster is started before the clock (its start-up is its own column); each sweep's wall time runs from
submission to the last result. Speed-up = wall time on 1 worker / on 2. The tables of the two runs must
be equal (t_f and fuel to 1e-9, the same points failed with the same status).
Writes ``build/bench/sweep.csv``.
"""

from __future__ import annotations

import time

import numpy as np
from _harness import parser, report
from distributed import Client, LocalCluster

from compendium.paths import build_dir
from compendium.studies.sweeps import entry_landing_point, flat_moon_point
from compendium.sweep import sweep


def timed(workers: int, task, points):
    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
    client = Client(cluster)
    client.run(lambda: None)  # every worker up
    startup = time.perf_counter() - t0
    t1 = time.perf_counter()
    table = sweep(task, points, client=client, progress=False)
    wall = time.perf_counter() - t1
    client.close()
    cluster.close()
    return table, startup, wall


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "sweep.csv"))
    ap.add_argument("--points", type=int, default=400)
    args = ap.parse_args()
    cases = [
        (
            "flat moon, t_f over thrust-to-weight",
            flat_moon_point,
            "tf_s",
            [{"thrust_to_weight": r} for r in np.linspace(1.5, 6.0, args.points)],
        ),
        (
            "entry landing, fuel over (V0, gamma0)",
            entry_landing_point,
            "fuel_kg",
            [
                {"speed_m_s": v, "flight_path_deg": g}
                for v in np.linspace(200, 360, 9)
                for g in np.linspace(-90, -20, 8)
            ],
        ),
    ]
    rows = []
    for label, task, column, points in cases:
        tables = {}
        for workers in (1, 2):
            table, startup, wall = timed(workers, task, points)
            tables[workers] = table
            rows.append(
                {
                    "sweep": label,
                    "points": len(points),
                    "failed": int((~table.ok).sum()),
                    "workers": workers,
                    "cluster_start_s": startup,
                    "wall_s": wall,
                    "per_point_ms": 1e3 * wall / len(points),
                    "speedup": rows[-1]["wall_s"] / wall if workers == 2 else 1.0,
                }
            )
            print(f"{label}, {workers} worker(s): {wall:.2f} s", flush=True)
        a, b = tables[1], tables[2]
        same = (a.ok == b.ok).all() and (a.status == b.status).all()
        ok = a.ok.to_numpy()
        diff = np.abs(a[column].to_numpy()[ok] / b[column].to_numpy()[ok] - 1)
        if not same or np.max(diff, initial=0.0) > 1e-9:
            raise SystemExit(f"{label}: the 1- and 2-worker sweeps disagree")
    cols = ["sweep", "points", "failed", "workers", "cluster_start_s", "wall_s", "per_point_ms", "speedup"]
    report(rows, cols, args.output, "Sweeps on a LocalCluster", {"per_point_ms": ".1f", "speedup": ".2f"})


if __name__ == "__main__":
    main()
