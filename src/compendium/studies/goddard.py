"""The Goddard rocket's singular arc (notebook 07): chattering of the thrust on uniform meshes, refinement,
and the control penalty of :mod:`ocpkit.regularisation`."""

from __future__ import annotations

import warnings

import pandas as pd

from ocpkit import HLGL, Radau, Solution
from ocpkit.accuracy import AccuracyWarning
from ocpkit.analysis import total_variation
from ocpkit.regularisation import penalise_control

from ..problems.goddard import goddard_rocket


def goddard_row(solution, scheme: str, weight: float, mesh: str) -> dict:
    """One row of the study: the final altitude (of the unpenalised dynamics, a state), accuracy, thrust variation."""
    return {
        "scheme": scheme,
        "mesh": mesh,
        "weight": weight,
        "collocation_points": solution.program.n_collocation_points if isinstance(solution, Solution) else None,
        "final_altitude": float(solution.state(solution.tf)[0]),
        "tf": solution.tf,
        "error_estimate": solution.state_error,
        "thrust_variation": total_variation(solution, "T"),
        "mesh_iterations": len(solution.mesh_history) if solution.mesh_history else None,
    }


def uniform_meshes(segments, weights) -> tuple[pd.DataFrame, dict]:
    """HLGL on ``segments`` uniform segments, without (weight 0) and with each penalty ``weights``.

    Returns the table and the solutions by ``(weight, segments)``.
    """
    rows, solutions = [], {}
    for weight in [0.0, *weights]:
        problem = goddard_rocket() if weight == 0 else penalise_control(goddard_rocket(), weight)
        for n in segments:
            tr = HLGL(problem, n)
            sol = solutions[weight, n] = tr.solve(error_threshold=None)
            row = goddard_row(sol, "HLGL", weight, f"uniform {n}")
            row["collocation_points"] = tr.n_collocation_points
            rows.append(row)
    return pd.DataFrame(rows), solutions


def refined(weight: float, tolerance: float, start=(4, 10), max_mesh_iterations: int = 25):
    """Radau refined to ``tolerance`` (ph rule, cuts at switches) from ``start`` (nodes, intervals)."""
    problem = goddard_rocket() if weight == 0 else penalise_control(goddard_rocket(), weight)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)  # whether the tolerance is met is in the history
        return Radau(problem, *start).solve(mesh_tolerance=tolerance, max_mesh_iterations=max_mesh_iterations)
