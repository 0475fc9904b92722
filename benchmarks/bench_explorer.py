"""From a slider move to the redrawn curves: the explorer's latency (issue 25).

    python benchmarks/bench_explorer.py [--repeat 3]

The GTO-GEO transfer (notebook 05: the slides' L1 extremal followed along the thrust by shooting continuation,
``compendium.studies.orbit_transfer.thrust_family``) is dragged from 5 N down to 1 N and up to 10 N in slider steps
(0.09 N); issue 25's goal is a step under 1 s (median and 95th percentile). The two-timescale explorer of notebook
02 (``coupling_explorer``: a drop-down per choice, each combination built when first chosen) is timed over a tour of
its choices: no goal, printed for the record.

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
STEP_S = 1.0  # a thrust step of the transfer


def moves(explorer, name, values) -> list[dict]:
    """Each value solved, sampled and drawn as the explorer does after a slider move; the times of each part.
    ``values``: of the parameter ``name``, or dicts of values (``name`` None)."""
    canvas = FigureCanvasAgg(explorer.figure)
    out = []
    for v in values:
        t0 = time.perf_counter()
        outcome, data = explorer._solve(v if name is None else {name: float(v)})
        t1 = time.perf_counter()
        explorer._draw((outcome, data))
        canvas.draw()
        t2 = time.perf_counter()
        out.append(
            {
                "value": str(v) if name is None else float(v),
                "solved": outcome.solved,
                "iterations": outcome.iterations,
                "solve_s": outcome.solve_s,
                "data_s": t1 - t0 - outcome.solve_s,
                "redraw_s": t2 - t1,
                "total_s": t2 - t0,
            }
        )
    return out


def transfer_explorer():
    """Notebook 05's explorer: the slides' 5 N transfer from the published energy costates."""
    from compendium.explorer import History
    from compendium.problems.orbit_transfer import final_longitude
    from compendium.studies import orbit_transfer as study

    systems = study.TransferSystems()
    shooting = systems.shooting("fuel", 5.0, final="longitude", longitude=final_longitude(5.0), tol=1e-8)
    first = study.solve_robustly(
        shooting, study.energy_start_vector(study.read_cache("orbit_transfer_energy"), "longitude", 5.0), maxfev=300
    )
    return explore(
        study.thrust_family(systems, first, 5.0),
        {"thrust_N": (1.0, 10.0)},
        [History("m"), History("|u|", function=study.thrust_magnitude, samples=4000)],
    )


def two_timescale_explorer():
    """Notebook 02's explorer with its published choices (reference HLGL 200, IPOPT tolerance 1e-13)."""
    from compendium.studies.two_timescale import coupling_explorer

    problem = lunar_ascent()
    reference = HLGL(problem, 200).solve(ipopt_options={"tol": 1e-13})
    partitions = {"U, V fast": ["U", "V"], "V fast": ["V"], "every state fast": ["X", "Y", "U", "V"]}
    return coupling_explorer(
        problem,
        reference,
        segments=[5, 10, 20, 40],
        ratios=[1, 2, 3, 4, 8],
        couplings=["coarse", "fine", "quadrature", "galerkin"],
        partitions=partitions,
        default={"N": 10, "M": 2, "coupling": "coarse", "fast": ["U", "V"]},
        ipopt_options={"tol": 1e-13},
    )


TOUR = [
    {"M": 4},
    {"coupling": "galerkin"},
    {"coupling": "galerkin", "M": 4},
    {"coupling": "fine", "M": 4},
    {"fast": "V fast"},
    {"fast": "every state fast"},
    {"N": 20},
    {"N": 20, "coupling": "galerkin"},
    {"N": 40, "M": 8},
    {},
]


def cases():
    """``(problem, make explorer, parameter, drag values, range or the random jumps' count, goals)``; goals
    ``(median, 95th percentile)`` in seconds, or None."""
    yield (
        "lunar ascent, HLGL 20",
        lambda: explore(HLGL(lunar_ascent(thrust_as_parameter=True), 20), {"a": (1.0, 5.0)}, ["Y", "U", "V", "theta"]),
        "a",
        np.arange(3.0, 2.0, -0.04).tolist() + np.arange(2.0, 4.0, 0.04).tolist(),
        (1.0, 5.0),
        (MEDIAN_S, P95_S),
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
        (MEDIAN_S, P95_S),
    )
    yield (
        "GTO-GEO transfer, thrust by shooting continuation",
        transfer_explorer,
        "thrust_N",
        np.round(np.r_[np.arange(5.0, 1.0 - 1e-9, -0.09), np.arange(1.0, 10.0 + 1e-9, 0.09)], 10).tolist(),
        None,
        (STEP_S, STEP_S),
    )
    yield ("two-timescale, a tour of the choices", two_timescale_explorer, None, TOUR, None, None)


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "explorer.csv"))
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    summary = []
    goals = {}
    for problem, make, name, drag, span, goal in cases():
        rows = []
        goals[problem] = goal
        for _ in range(args.repeat):
            explorer = make()
            jumps = [] if span is None else rng.uniform(*span, size=20).tolist()
            for kind, values in (("drag" if name else "choice", drag), ("jump", jumps)):
                rows += [{"move": kind, **row} for row in moves(explorer, name, values)]
            explorer.close()
        for kind in ("drag", "choice", "jump", "all"):
            sel = [r for r in rows if kind == "all" or r["move"] == kind]
            if not sel:
                continue
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
                    "max_s": float(total.max()),
                    "iterations": float(np.median([r["iterations"] for r in sel])),
                }
            )
    df = report(summary, list(summary[0]), args.output, "A slider move to the redrawn figure (median of moves)")
    for problem, every in df[df.moves == "all"].set_index("problem").iterrows():
        if goals[problem] is None:
            continue
        median, p95 = goals[problem]
        verdict = "met" if every.median_s < median and every.p95_s < p95 else "NOT met"
        print(
            f"goal, {problem}: median under {median:g} s and 95th percentile under {p95:g} s: "
            f"{every.median_s:.3f} s and {every.p95_s:.3f} s, {verdict}"
        )


if __name__ == "__main__":
    main()
