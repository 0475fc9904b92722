"""Small problems with closed-form solutions, shared by the transcription tests."""

import casadi as ca

from ocpkit import Control, OptimalControlProblem, State


def min_energy_double_integrator() -> OptimalControlProblem:
    """min int_0^1 u^2 dt, x1' = x2, x2' = u, (0, 0) -> (1, 0): u = 6 - 12 t, x2 = 6t - 6t^2, J = 12."""
    return OptimalControlProblem(
        "min_energy",
        [State("x1", initial=0.0, final=1.0), State("x2", initial=0.0, final=0.0)],
        [Control("u")],
        lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=1.0,
        lagrange=lambda x, u, t: u[0] ** 2,
    )
