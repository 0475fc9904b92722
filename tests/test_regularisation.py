"""The control penalty (ocpkit.regularisation), the thrust variation (ocpkit.analysis.total_variation) and the
Goddard rocket it is shown on."""

import casadi as ca
import numpy as np
import pytest

from ocpkit import HLGL, Control, OptimalControlProblem, Radau, State
from ocpkit.analysis import total_variation
from ocpkit.regularisation import penalise_control

from compendium.problems import goddard_rocket


def minimum_energy():
    return OptimalControlProblem(
        "min_energy",
        states=[State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        controls=[Control("u", scale=2.0)],
        dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=1.0,
        lagrange=lambda x, u, t: u[0] ** 2 / 2,
    )


def test_the_penalty_adds_weight_times_the_scaled_control_squared():
    """u = 6 - 12 t whatever the weight (the penalty is proportional to the cost): J = 12 (1/2 + w / 4)."""
    w = 0.3
    sol = HLGL(penalise_control(minimum_energy(), w), 10).solve()
    assert sol.objective == pytest.approx(12.0 * (0.5 + w / 4), rel=1e-9)
    t = np.linspace(0, 1, 11)
    assert np.allclose(sol.control(t)[:, 0], 6 - 12 * t, atol=1e-8)


def test_the_penalty_names_bad_input():
    with pytest.raises(ValueError, match="non-negative"):
        penalise_control(minimum_energy(), -1.0)
    with pytest.raises(ValueError, match="some of \\['u'\\]"):
        penalise_control(minimum_energy(), 1.0, controls=["w"])


def test_total_variation_of_a_linear_control():
    sol = HLGL(minimum_energy(), 10).solve()
    assert total_variation(sol, "u") == pytest.approx(12.0, rel=1e-9)


def test_goddard_thrust_chatters_without_the_penalty_and_not_with_it():
    """Measured: HLGL 80 segments, variation 159 without a penalty, 4.7 with 1e-3; altitude 1.0128366."""
    bare = HLGL(goddard_rocket(), 80).solve(error_threshold=None)
    smooth = HLGL(penalise_control(goddard_rocket(), 1e-3), 80).solve(error_threshold=None)
    assert total_variation(bare, "T") > 50
    assert total_variation(smooth, "T") < 6
    for sol in (bare, smooth):
        assert sol.state(sol.tf)[0] == pytest.approx(1.01283, abs=1e-5)  # COPS 3.0


def test_goddard_refined_meets_the_tolerance_and_the_published_altitude():
    sol = Radau(goddard_rocket(), 4, 10).solve(mesh_tolerance=1e-6)
    assert sol.state_error <= 1e-6
    assert -sol.objective == pytest.approx(1.01283, abs=1e-5)
    assert sol.state(sol.tf)[2] == pytest.approx(0.6, abs=1e-9)  # the final mass
