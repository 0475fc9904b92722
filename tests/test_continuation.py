"""Continuation (ocpkit.shooting.continuation): pseudo-arclength on a fold with a closed form, natural-parameter steps."""

import numpy as np
import pytest

from ocpkit import Outcome, SolverError
from ocpkit.shooting.continuation import ContinuationPath, GeometricSteps, Schedule, Toward, arclength, follow


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

    def solve(self, z, P, *, tol=1e-8):
        from types import SimpleNamespace

        self.tols = [*getattr(self, "tols", []), tol]  # the refinement solves to the continuation's tol
        z = np.array(z, dtype=float)
        for _ in range(50):
            z = z - self.residual(z, P) / (2 * z[0])
        return SimpleNamespace(z=z, tf=float(z[0]))


def test_arclength_follows_the_path_around_the_fold():
    fold = Fold()
    path = arclength(
        fold, [np.sqrt(0.5)], "theta", 0.5, 2.0, targets=[0.75], log=False, h0=0.05, hmax=0.1, max_steps=40
    )
    assert fold.tols == [1e-9, 1e-9], "each crossing refined to the continuation's tol"
    assert path.status is Outcome.MAX_ITERATIONS and not path.converged and path.iterations == len(path.values) - 1
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
    assert "folded back" in path.detail and path.status is Outcome.FOLD and not path.converged
    assert 0.9 < path.values[-1] < 1.0
    with pytest.raises(SolverError, match="pseudo-arclength continuation failed with status 'fold'") as info:
        arclength(
            Fold(), [np.sqrt(0.5)], "theta", 0.5, 2.0, log=False, hmax=0.1, stop_at_turn=True, raise_on_failure=True
        )
    assert info.value.outcome is Outcome.FOLD and info.value.result.values[-1] == path.values[-1]


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


class _Result:
    def __init__(self, z):
        self.z = z


def _near(v, z):  # converges only from within 0.3 of the value
    if abs(v - z[0]) > 0.3:
        raise SolverError("toy", "too far")
    return _Result(np.array([v]))


def test_follow_halves_a_failing_step_and_names_where_it_gives_up():
    path = follow(_near, np.array([0.0]), 0.0, Schedule([1.0]))
    assert isinstance(path, ContinuationPath) and path.converged and path.status is Outcome.CONVERGED
    assert [v for v, _ in path] == [0.25, 0.5, 0.75, 1.0] == path.values and len(path) == path.iterations == 4
    assert path[-1][1] is path.results[-1] and path.failures == 3 and path.start == 0.0
    with pytest.raises(SolverError, match="failed at") as info:
        follow(_near, np.array([0.0]), 0.0, Schedule([10.0], max_halvings=3))
    assert info.value.outcome is Outcome.STEP_TOO_SMALL
    partial = follow(_near, np.array([0.0]), 0.0, Schedule([10.0], max_halvings=3), raise_on_failure=False)
    assert not partial.converged and partial.status is Outcome.STEP_TOO_SMALL and "failed at" in partial.detail
    assert partial.values == [] and partial.failures == 4


def test_a_result_that_says_it_failed_is_a_failed_step():
    class Unconverged(_Result):
        converged, status, detail, iterations = False, Outcome.STALLED, "stuck", 3

    seen = []

    def solve_at(v, z):
        seen.append(v)
        return _Result(np.array([v])) if v <= 0.5 else Unconverged(np.array([v]))

    path = follow(solve_at, np.array([0.0]), 0.0, Schedule([0.5, 1.0], max_halvings=1), raise_on_failure=False)
    assert path.values == [0.5] and seen == [0.5, 1.0, 0.75] and path.status is Outcome.STEP_TOO_SMALL
    assert "stuck" in path.detail


def test_the_first_of_several_starts_that_solves_and_a_cancellation():
    tried = []

    def solve_at(v, start):
        tried.append(start)
        return _near(v, np.array([start]))

    path = follow(
        solve_at, np.array([0.0]), 0.0, Schedule([1.0]), predictor=lambda h, v: [0.0, 0.8, 0.9], choose="first"
    )
    assert tried == [0.0, 0.8] and path.values == [1.0]
    calls = []
    path = follow(
        lambda v, z: calls.append(v) or _near(v, z),
        np.array([0.0]),
        0.0,
        Schedule([0.2, 0.4, 0.6]),
        cancelled=lambda: len(calls) >= 2,
        remember=lambda v, r: calls.append(("remembered", v)),
    )
    assert path.status is Outcome.CANCELLED and not path.converged and path.values == [0.2]
    assert calls == [0.2, ("remembered", 0.2)]


def test_toward_steps_halfway_then_aims_at_the_target_again():
    """The explorer's rule: the target; then halfway, halved on failure; from each point solved, the target."""

    def near(v, z):  # converges only within 0.3 (in the plane's norm) of the last point
        if np.linalg.norm(v - z) > 0.3:
            raise SolverError("toy", "too far")
        return _Result(np.array(v))

    seen = []
    path = follow(
        lambda v, z: seen.append(tuple(np.round(v, 6))) or near(v, z),
        np.zeros(2),
        np.zeros(2),
        Toward([0.6, 0.0], halvings=3),
        predictor=lambda h, v: h[-1].result.z if h[-1].result is not None else h[-1][1],
        first=_Result(np.zeros(2)),
    )
    assert seen == [(0.6, 0.0), (0.3, 0.0), (0.6, 0.0)] and path.converged
    assert np.array_equal(path.values[-1], [0.6, 0.0])
    failed = follow(
        near, None, np.zeros(2), Toward([5.0, 0.0], halvings=2), first=_Result(np.zeros(2)), raise_on_failure=False
    )
    assert failed.status is Outcome.STEP_TOO_SMALL and "target not reached" in failed.detail


def test_geometric_steps_shrink_on_failure_grow_back_and_hit_every_target():
    def near_in_ratio(v, z):  # converges only for a ratio above 0.75 to the last value
        if v / z[0] < 0.75:
            raise SolverError("toy", "too far")
        return _Result(np.array([v]))

    steps = GeometricSteps(0.05, targets=[0.5, 0.2], factor=0.6)  # 0.6 fails, 0.8 works
    path = follow(near_in_ratio, np.array([1.0]), 1.0, steps)
    values = [v for v, _ in path]
    assert values[-1] == 0.05 and 0.5 in values and 0.2 in values
    ratios = np.array(values[1:]) / np.array(values[:-1])
    assert np.all(ratios >= 0.75) and np.all(ratios < 1)


def test_several_predictors_and_a_choice():
    path = follow(
        lambda v, z: _Result(np.array([v, z[0]])),
        np.array([0.0]),
        0.0,
        Schedule([1.0]),
        predictor=lambda h, v: [h[-1][1][:1], h[-1][1][:1] + 0.1],
        choose=lambda rs: max(rs, key=lambda r: r.z[1]),
    )
    assert path[0][1].z[1] == pytest.approx(0.1)
