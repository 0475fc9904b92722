"""FATROP against IPOPT + MUMPS on the flat-moon HLGL NLP in FATROP's stage form (issue 26, item 3: measured first).

    python benchmarks/bench_fatrop.py [--segments 100 1000] [--repeat 1]

FATROP (Vanroye et al., KU Leuven 2023; in CasADi's wheel) solves optimal-control NLPs by a Riccati recursion over
stages ``x_{k+1} = F_k(x_k, u_k)``, with stage constraints ``g_k(x_k, u_k)``. ocpkit's HLGL is written here in that
form, one stage per segment: the stage state is the segment's first state node, t_f and the control at the node
(``x_k = [X_k, t_f, U_k]``, 6 entries), the stage variables are the centre and end state nodes and the four other
controls (``u_k = [X_c, X_e, U_a, U_c, U_b, U_e]``, 12), the gap-closing equation is the explicit copy
``x_{k+1} = [X_e, t_f, U_e]`` and the stage constraints are HLGL's eight defects. The same NLP (SX, one function
per row) goes to both solvers with the same start, tolerance 1e-10. Both must reach the same t_f (to 1e-8,
relative) and ocpkit's own HLGL solve of the problem. Writes ``build/bench/fatrop.csv``.

Measured here (2 cores, one run each, ``--segments 100 1000 3000 5000``): FATROP's solve over IPOPT's is 0.64 at
100 segments (0.016 s against 0.025 s; 0.59 in another run), 1.06 at 1000 (12 iterations against 10), 1.18 at 3000 and 1.63 at 5000
(2.54 s against 1.55 s: 0.21 s an iteration against 0.14 s), and CasADi's FATROP interface takes 33 s to build at
3000 stages and 99 s at 5000 (IPOPT's 7 and 11 s on the same SX graph, which ocpkit's blocks build in 0.1 s). FATROP
wins only where a solve already takes milliseconds and loses at scale, where it was wanted; so it is not made a
``solver=`` option of ocpkit's transcriptions, and this script keeps the measurement.
"""

from __future__ import annotations

import time

import casadi as ca
import numpy as np
from _harness import parser, report

from ocpkit import HLGL
from ocpkit.transcription.hlgl import hlgl_segment

from compendium.paths import build_dir
from compendium.problems import flat_moon_ascent, load_problem_data


def stage_form(n: int) -> tuple[dict, dict, list[bool], int]:
    """The flat-moon HLGL NLP on ``n`` segments in FATROP's stage order: ``(nlp, bounds and start, equality, nx)``."""
    k = load_problem_data("flat_moon")
    g0 = k["constants"]["g_m_s2"]
    a = k["constants"]["thrust_to_weight"] * g0
    L, V, T = (k["scaling"][key] for key in ("position_m", "velocity_m_s", "time_s"))
    (u_lo, u_hi), (tf_lo, tf_hi) = k["bounds"]["theta_rad"], k["bounds"]["tf_s"]
    x_end, tf0, u0 = k["guess"]["x_m"][1] / L, k["guess"]["tf_s"] / T, k["guess"]["theta_rad"]
    goal = k["target"]

    def f(x, u):
        return ca.vertcat(x[2] * V * T / L, x[3] * V * T / L, a * ca.cos(u) * T / V, (a * ca.sin(u) - g0) * T / V)

    xs, us = ca.SX.sym("x", 6), ca.SX.sym("u", 12)
    X, tf, U0 = xs[0:4], xs[4], xs[5]
    Xc, Xe, Ua, Uc, Ub, U4 = us[0:4], us[4:8], us[8], us[9], us[10], us[11]
    # HLGL's two defects of the segment (Herman & Conway Eqs. 6-7), as ocpkit's transcription states them
    c1, c2, _, _, _ = hlgl_segment(lambda x, u, t: f(x, u), X, Xc, Xe, [U0, Ua, Uc, Ub, U4], [0.0] * 5, tf / n)
    step = ca.Function("F", [xs, us], [ca.vertcat(Xe, tf, U4)])
    defects = ca.Function("D", [xs, us], [ca.vertcat(c1, c2)])
    inf = np.inf
    target = [None, goal["altitude_m"] / L, goal["vx_m_s"] / V, goal["vy_m_s"] / V]
    states = [ca.SX.sym(f"x{j}", 6) for j in range(n + 1)]
    controls = [ca.SX.sym(f"u{j}", 12) for j in range(n)]
    w, g, lbw, ubw, w0, equality = [], [], [], [], [], []
    for j in range(n + 1):
        s = j / n
        lo, hi = [-inf] * 4 + [tf_lo / T, u_lo], [inf] * 4 + [tf_hi / T, u_hi]
        if j == 0:
            lo[:4] = hi[:4] = [0.0] * 4
        if j == n:
            for i, v in enumerate(target):
                if v is not None:
                    lo[i] = hi[i] = v
        w.append(states[j])
        lbw += lo
        ubw += hi
        w0 += [x_end * s, target[1] * s, target[2] * s, target[3] * s, tf0, u0]
        if j < n:
            sc, se = (j + 0.5) / n, (j + 1) / n
            w.append(controls[j])
            lbw += [-inf] * 8 + [u_lo] * 4
            ubw += [inf] * 8 + [u_hi] * 4
            w0 += [x_end * sc, target[1] * sc, target[2] * sc, target[3] * sc]
            w0 += [x_end * se, target[1] * se, target[2] * se, target[3] * se] + [u0] * 4
            g += [states[j + 1] - step(states[j], controls[j]), defects(states[j], controls[j])]
            equality += [True] * 14
    nlp = {"x": ca.vertcat(*w), "f": states[0][4], "g": ca.vertcat(*g)}
    m = len(equality)
    return nlp, {"x0": w0, "lbx": lbw, "ubx": ubw, "lbg": np.zeros(m), "ubg": np.zeros(m)}, equality, T


def solve(n: int, solver: str) -> dict:
    nlp, args, equality, T = stage_form(n)
    t0 = time.perf_counter()
    if solver == "fatrop":
        opts = {
            "structure_detection": "manual",
            "N": n,
            "nx": [6] * (n + 1),
            "nu": [12] * n + [0],
            "ng": [8] * n + [0],
            "equality": equality,
            "expand": True,
            "print_time": False,
            "fatrop": {"print_level": 0, "tol": 1e-10},
        }
    else:
        ip = {"print_level": 0, "sb": "yes", "tol": 1e-10, "mu_strategy": "adaptive", "mumps_pivot_order": 6}
        opts = {"print_time": False, "ipopt": {**ip, "mumps_permuting_scaling": 0}}
    S = ca.nlpsol(solver, solver, nlp, opts)
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = S(**args)
    elapsed = time.perf_counter() - t0
    st = S.stats()
    return {
        "segments": n,
        "solver": solver,
        "build_s": build,
        "solve_s": elapsed,
        "functions_s": sum(v for key, v in st.items() if key.startswith("t_wall_nlp")),
        "iterations": st.get("iter_count"),
        "status": str(st.get("return_status")) if solver == "ipopt" else ("success" if st.get("success") else "failed"),
        "tf": float(res["f"]) * T,
    }


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "fatrop.csv"))
    ap.add_argument("--segments", type=int, nargs="+", default=[100, 1000])
    ap.set_defaults(repeat=1)
    args = ap.parse_args()
    rows = []
    for n in args.segments:
        pair = [min((solve(n, s) for _ in range(args.repeat)), key=lambda r: r["solve_s"]) for s in ("ipopt", "fatrop")]
        hlgl = HLGL(flat_moon_ascent(), n).solve(error_threshold=None).tf  # the same NLP, ocpkit's layout
        for row in pair:
            if abs(row["tf"] / hlgl - 1) > 1e-8:
                raise SystemExit(f"{n} segments: {row['solver']}'s t_f {row['tf']} differs from ocpkit's HLGL {hlgl}")
        pair[1]["fatrop_over_ipopt"] = pair[1]["solve_s"] / pair[0]["solve_s"]
        rows += pair
        print(f"{n}: IPOPT {pair[0]['solve_s']:.3f} s, FATROP {pair[1]['solve_s']:.3f} s", flush=True)
    cols = [
        "segments",
        "solver",
        "build_s",
        "solve_s",
        "functions_s",
        "iterations",
        "status",
        "tf",
        "fatrop_over_ipopt",
    ]
    report(
        rows,
        cols,
        args.output,
        "Flat-moon HLGL in stage form, IPOPT + MUMPS against FATROP",
        {"tf": ".9f", "fatrop_over_ipopt": ".2f"},
    )


if __name__ == "__main__":
    main()
