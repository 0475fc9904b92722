"""Desai & Conway's iteration claim under quasi-Newton NLP solvers: Tables 1-2's rows, four solvers.

    python benchmarks/bench_quasi_newton.py

The lunar ascent's four rows (standard 20 and two-to-one 10/20; standard 40 and four-to-one 10/40), from the data
file's guess, under IPOPT with the exact Hessian, IPOPT with L-BFGS, SciPy's SLSQP (dense SQP, BFGS) and CasADi's
``sqpmethod`` with a BFGS Hessian and qpOASES (dense active-set QPs; about a minute for the 486-variable row,
which is why notebook 02 runs the first three only). Every solve must reach the exact-Hessian optimum (t_f to
1e-6, relative). Writes ``build/bench/quasi_newton.csv``.
"""

from __future__ import annotations

import os
import sys
import time
from contextlib import contextmanager

import casadi as ca
import numpy as np
from _harness import parser, report

from ocpkit import HLGL, MultiRateHLGL

from compendium.paper import paper_table
from compendium.paths import build_dir
from compendium.problems import lunar_ascent
from compendium.studies.two_timescale import QUASI_NEWTON_SOLVERS, solve_with

SQP = "sqpmethod, BFGS Hessian"


@contextmanager
def quiet_stdout():
    """qpOASES prints its banner from C to file descriptor 1."""
    sys.stdout.flush()
    saved = os.dup(1)
    with open(os.devnull, "w") as devnull:
        os.dup2(devnull.fileno(), 1)
        try:
            yield
        finally:
            os.dup2(saved, 1)
            os.close(saved)


def solve_sqpmethod(tr) -> tuple[int, float, float, str]:
    lbw, ubw, lbg, ubg = tr.nlp_bounds()
    nlp = tr.nlp
    options = {
        "hessian_approximation": "limited-memory",
        "qpsol": "qpoases",
        "qpsol_options": {"printLevel": "none", "error_on_fail": False},
        "print_header": False,
        "print_iteration": False,
        "print_status": False,
        "print_time": False,
        "max_iter": 2000,
        "tol_pr": 1e-8,
        "tol_du": 1e-8,
        "error_on_fail": False,
    }
    with quiet_stdout():
        solver = ca.nlpsol("sqp", "sqpmethod", {"x": nlp.w, "f": nlp.f, "g": nlp.g}, options)
        t = time.perf_counter()
        res = solver(x0=tr.initial_point(), lbx=lbw, ubx=ubw, lbg=lbg, ubg=ubg)
        elapsed = time.perf_counter() - t
    stats = solver.stats()
    tf = tr.global_values(np.asarray(res["x"]).ravel())["tf"]
    return int(stats["iter_count"]), elapsed, tf, stats["return_status"]


def main() -> None:
    ap = parser(__doc__.split("\n")[0], str(build_dir() / "bench" / "quasi_newton.csv"))
    args = ap.parse_args()
    problem = lunar_ascent()
    rows_spec = [
        ("table1", "standard", "20", lambda: HLGL(problem, 20)),
        ("table1", "two_to_one", "10/20", lambda: MultiRateHLGL(problem, 10, ratio=2, fast=["U", "V"])),
        ("table2", "standard", "40", lambda: HLGL(problem, 40)),
        ("table2", "four_to_one", "10/40", lambda: MultiRateHLGL(problem, 10, ratio=4, fast=["V"])),
    ]
    papers = {name: paper_table(name).set_index("scheme").iterations for name in ("table1", "table2")}
    rows = []
    for table, scheme, segments, make in rows_spec:
        exact_tf = None
        for solver in (*QUASI_NEWTON_SOLVERS, SQP):
            if solver == SQP:
                iterations, solve_s, tf, status = solve_sqpmethod(make())
            else:
                sol = solve_with(make(), solver, 1e-13)
                iterations, solve_s, tf, status = sol.iterations, sol.solve_s, sol.tf, sol.status
            exact_tf = tf if exact_tf is None else exact_tf
            if abs(tf / exact_tf - 1) > 1e-6:
                raise SystemExit(f"{table} {scheme} {solver}: t_f {tf} is not the NLP's optimum {exact_tf}")
            rows.append(
                {
                    "table": table,
                    "scheme": scheme,
                    "segments": segments,
                    "solver": solver,
                    "iterations": iterations,
                    "paper_iterations": int(papers[table][scheme]),
                    "solve_s": solve_s,
                    "status": status,
                }
            )
            print(f"{table} {scheme} {solver}: {iterations} iterations, {solve_s:.2f} s", flush=True)
    cols = ["table", "scheme", "segments", "solver", "iterations", "paper_iterations", "solve_s"]
    report(rows, cols, args.output, "Iterations of Tables 1-2's rows by NLP solver")


if __name__ == "__main__":
    main()
