"""Pseudo-arclength continuation (ocpkit.shooting.continuation) on a fold with a closed form."""

import numpy as np
import pytest

from ocpkit.shooting.continuation import arclength


class Fold:
    """S(z, theta) = z^2 + theta - 1: two branches z = +-sqrt(1 - theta) meeting at the fold theta = 1."""

    class problem:
        name = "fold"
        parameters = {"theta": 0.5}
        parameter_values = np.array([0.5])

    def residual(self, z, P):
        return np.array([z[0] ** 2 + P[0] - 1.0])

    def jacobian_matrix(self, z, P):
        return self.residual(z, P), np.array([[2 * z[0]]])

    def solve(self, z, P):
        from types import SimpleNamespace

        z = np.array(z, dtype=float)
        for _ in range(50):
            z = z - self.residual(z, P) / (2 * z[0])
        return SimpleNamespace(z=z, tf=float(z[0]))


def test_arclength_follows_the_path_around_the_fold():
    path = arclength(Fold(), [np.sqrt(0.5)], "theta", 0.5, 2.0, targets=[0.75], log=False, h0=0.05, hmax=0.1,
                     max_steps=40)
    theta = np.array(path.values)
    z = np.array([v[0] for v in path.z])
    assert np.abs(z**2 + theta - 1).max() < 1e-9, "every point on the curve"
    assert len(path.turning_points) == 1
    assert theta[path.turning_points[0]] == pytest.approx(1.0, abs=2e-3)
    assert z[-1] < 0, "continued onto the other branch"
    crossings = sorted(r.z[0] for r in path.targets[0.75])
    assert crossings == pytest.approx([-0.5, 0.5], abs=1e-12)
    assert path.best(0.75).z[0] == pytest.approx(-0.5)


def test_stop_at_turn_stops_just_past_the_fold():
    path = arclength(Fold(), [np.sqrt(0.5)], "theta", 0.5, 2.0, log=False, h0=0.05, hmax=0.1, stop_at_turn=True)
    assert "folded back" in path.message
    assert 0.9 < path.values[-1] < 1.0


def test_arclength_rejects_a_start_that_is_not_a_solution():
    with pytest.raises(ValueError, match="does not solve"):
        arclength(Fold(), [0.1], "theta", 0.5, 2.0, log=False)
    with pytest.raises(KeyError, match="no parameter"):
        arclength(Fold(), [np.sqrt(0.5)], "kappa", 0.5, 2.0, log=False)


def test_targets_are_found_under_the_callers_values_in_log_mode():
    """exp(log(0.35)) is not 0.35 in floating point; the refined target must still be found as 0.35."""

    class PositiveFold(Fold):
        class problem:
            name = "fold"
            parameters = {"theta": 0.3}
            parameter_values = np.array([0.3])

    path = arclength(PositiveFold(), [np.sqrt(0.7)], "theta", 0.3, 2.0, targets=[0.35, 0.5], log=True, max_steps=60)
    assert path.best(0.35).z[0] ** 2 + 0.35 - 1 == pytest.approx(0.0, abs=1e-12)
    assert set(path.targets) == {0.35, 0.5}
