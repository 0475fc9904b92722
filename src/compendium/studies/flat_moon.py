"""Flat-moon studies (notebook 00): transcriptions against the exact linear-tangent solution."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ocpkit import HLGL

from ..problems.flat_moon import LinearTangentSolution, flat_moon_ascent, linear_tangent_solution


def compare_with_exact(solution, exact: LinearTangentSolution, n: int = 4001) -> dict:
    """Errors of a transcribed solution against the exact one, on a common normalised time grid.

    Both trajectories are sampled at ``s = t / tf`` in [0, 1] (each with its own
    tf), so that a final-time error does not masquerade as a state error.
    """
    s = np.linspace(0.0, 1.0, n)
    th = solution.control(s * solution.tf)[:, 0]
    x = solution.state(s * solution.tf)
    xe = exact.state(s * exact.tf)
    err = np.abs(x - xe).max(axis=0)
    return {
        "tf_s": solution.tf,
        "tf_error_s": solution.tf - exact.tf,
        "max_theta_error_deg": float(np.degrees(np.abs(th - exact.theta(s * exact.tf)).max())),
        "max_position_error_m": float(err[:2].max()),
        "max_velocity_error_m_s": float(err[2:].max()),
    }


def convergence_study(segments, ipopt_options: dict | None = None):
    """HLGL on the flat-moon ascent for each number of segments, against the exact solution.

    Returns a DataFrame with one row per mesh: sizes, IPOPT iterations, errors
    in tf, theta and the states, and the re-integration error (m).
    """
    exact = linear_tangent_solution()
    problem = flat_moon_ascent()
    rows = []
    for n in segments:
        tr = HLGL(problem, int(n))
        sol = tr.solve(ipopt_options=ipopt_options)
        row = {"segments": int(n), "nlp_parameters": sol.decision_variables, "iterations": sol.iterations}
        row.update(compare_with_exact(sol, exact))
        rei = sol.reintegrate()
        row["max_reintegration_error_m"] = max(rei.max_error_by_state["x"], rei.max_error_by_state["y"])
        row["build_s"], row["solve_s"] = sol.build_s, sol.solve_s
        rows.append(row)
    return pd.DataFrame(rows)


def compare_costates(solution, exact: LinearTangentSolution) -> dict:
    """Largest error of each costate estimate against the exact (linear-in-time) costates.

    Errors are taken at the estimate's own points, mapped to the exact solution
    by normalised time, and divided by the largest magnitude of the exact costate
    vector (lambda_x is identically zero, so a per-component ratio would not exist).
    """
    if solution.costate_values is None:
        raise ValueError(f"{solution.transcription} provides no costate estimates")
    s = (solution.costate_times - solution.t0) / (solution.tf - solution.t0)
    lam_exact = exact.costate(s * exact.tf)
    scale = np.abs(lam_exact).max()
    err = np.abs(solution.costate_values - lam_exact).max(axis=0) / scale
    names = ["lambda_x", "lambda_y", "lambda_vx", "lambda_vy"]
    return dict(zip(names, err.tolist())) | {"max": float(err.max())}
