"""From a slider move to the redrawn curves: the explorer's latency (issue 25).

    python benchmarks/bench_explorer.py [--repeat 3]

For the lunar ascent (HLGL 20, the thrust-to-weight ratio ``a`` as its parameter) and the entry landing (Radau
10 x 20, its initial speed as the parameter: ``entry_landing(constants_as_parameters=True)``) a slider is dragged
in steps of a slider's width (``steps`` = 100 of its range, as the explorer's sliders have), then jumps across the
range at random. Each move is split into the solve (from the nearest solved value:
``compendium.explorer.ExploreSession``), the data (sampling the histories) and the redraw (the figure rendered by
Agg, which is what ipympl does when the front end asks for the new image); the debounce, the messages to the front
end and the image's encoding and transfer are not counted (tests/test_explorer_lab.py measures a move in Lab, end to
end). Issue 25's goal: median under 0.1 s and 95th percentile under 0.3 s. Writes ``build/bench/explorer.csv``.
"""

from __future__ import annotations

import time

import numpy as np
from _harness import parser, report
from matplotlib.backends.backend_agg import FigureCanvasAgg

from ocpkit import HLGL, Radau

from compendium.explorer import explore
from compendium.paths import build_dir
from compendium.problems import entry_landing, lunar_ascent

MEDIAN_S, P95_S = 0.1, 0.3


def moves(explorer, name, values) -> list[dict]:
    """Each value solved, sampled and drawn as the explorer does after a slider move; the times of each part."""
    canvas = FigureCanvasAgg(explorer.figure)
    out = []
    for v in values:
        t0 = time.perf_counter()
        outcome, data = explorer._solve({name: float(v)})
        t1 = time.perf_counter()
        explorer._draw((outcome, data))
        canvas.draw()
        t2 = time.perf_counter()
        out.append(
            {
                "value": float(v),
                "solved": outcome.solved,
                "iterations": outcome.iterations,
                "solve_s": outcome.solve_s,
                "data_s": t1 - t0 - outcome.solve_s,
                "redraw_s": t2 - t1,
                "total_s": t2 - t0,
            }
        )
    return out


def cases():
    """``(problem, make explorer, parameter, drag values, range)``."""
    yield (
        "lunar ascent, HLGL 20",
        lambda: explore(HLGL(lunar_ascent(thrust_as_parameter=True), 20), {"a": (1.0, 5.0)}, ["Y", "U", "V", "theta"]),
        "a",
        np.arange(3.0, 2.0, -0.04).tolist() + np.arange(2.0, 4.0, 0.04).tolist(),
        (1.0, 5.0),
    )
    yield (
        "entry landing, Radau 10 x 20",
        lambda: explore(
            Radau(entry_landing(constants_as_parameters=True), 10, 20),
            {"initial_speed_m_s": (200.0, 400.0)},
            ["r", "V", "gamma", "u_T"],
        ),
        "initial_speed_m_s",
        np.arange(280.0, 240.0, -2.0).tolist() + np.arange(240.0, 320.0, 2.0).tolist(),
        (200.0, 400.0),
    )


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "explorer.csv"))
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    summary = []
    for problem, make, name, drag, (lo, hi) in cases():
        rows = []
        for _ in range(args.repeat):
            explorer = make()
            jumps = rng.uniform(lo, hi, size=20).tolist()
            for kind, values in (("drag", drag), ("jump", jumps)):
                rows += [{"move": kind, **row} for row in moves(explorer, name, values)]
            explorer.close()
        for kind in ("drag", "jump", "all"):
            sel = [r for r in rows if kind == "all" or r["move"] == kind]
            total = np.array([r["total_s"] for r in sel])
            summary.append(
                {
                    "problem": problem,
                    "moves": kind,
                    "count": len(sel),
                    "failed": sum(not r["solved"] for r in sel),
                    "solve_s": float(np.median([r["solve_s"] for r in sel])),
                    "data_s": float(np.median([r["data_s"] for r in sel])),
                    "redraw_s": float(np.median([r["redraw_s"] for r in sel])),
                    "median_s": float(np.median(total)),
                    "p95_s": float(np.percentile(total, 95)),
                    "iterations": float(np.median([r["iterations"] for r in sel])),
                }
            )
    df = report(summary, list(summary[0]), args.output, "A slider move to the redrawn figure (median of moves)")
    for problem, every in df[df.moves == "all"].set_index("problem").iterrows():
        verdict = "met" if every.median_s < MEDIAN_S and every.p95_s < P95_S else "NOT met"
        print(
            f"goal, {problem}: median under {MEDIAN_S:g} s and 95th percentile under {P95_S:g} s: "
            f"{every.median_s:.3f} s and {every.p95_s:.3f} s, {verdict}"
        )


if __name__ == "__main__":
    main()
