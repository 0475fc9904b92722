"""One trajectory type for direct and indirect results, and one failure policy (ocpkit.trajectory)."""

import numpy as np
import pytest

from ocpkit import Radau, SolverError
from ocpkit.nlp import failure_hint
from ocpkit.shooting import Shooting, control_law
from ocpkit.trajectory import Trajectory

from compendium.problems import double_integrator


@pytest.fixture(scope="module")
def energy_pair():
    """The minimum-energy double integrator (cost u^2) solved directly (Radau) and indirectly (shooting)."""
    pr = double_integrator(lam=0.0)
    direct = Radau(pr, nodes=8, intervals=10).solve()
    s = Shooting(pr, control_law(pr, "box", regularized=True), rtol=1e-12, atol=1e-12)
    indirect = s.solve(np.array([0.5, 0.5]))
    return pr, direct, indirect


def test_direct_and_indirect_results_are_the_same_kind_of_object(energy_pair):
    pr, direct, indirect = energy_pair
    for tr in (direct, indirect.trajectory):
        assert isinstance(tr, Trajectory)
        df = tr.to_dataframe(n=51, costates=True)
        assert list(df.columns) == ["t", "x1", "x2", "u", "lambda_x1", "lambda_x2"]
        assert tr.breakpoints[0] == tr.t0 and tr.breakpoints[-1] == tr.tf


def test_the_two_methods_agree_on_the_same_solution(energy_pair):
    pr, direct, indirect = energy_pair
    d = direct.difference(indirect.trajectory)
    assert d["states"] < 1e-6 and d["controls"] < 1e-5 and d["tf"] == 0.0
    t = np.linspace(0.0, 3.0, 31)
    lam_d, lam_i = direct.costate(t), indirect.trajectory.costate(t)
    assert np.abs(lam_d - lam_i).max() < 1e-5 * np.abs(lam_i).max()


def test_a_shooting_trajectory_re_integrates_to_its_own_states(energy_pair):
    _, _, indirect = energy_pair
    rei = indirect.trajectory.reintegrate(rtol=1e-12, atol=1e-12)
    assert rei.max_error < 1e-9


def test_bang_bang_shooting_trajectory_has_its_switchings_as_breakpoints():
    pr = double_integrator(lam=1.0)
    s = Shooting(pr, control_law(pr, "box"), rtol=1e-12, atol=1e-12)
    tr = s.solve(np.array([0.9, 1.5])).trajectory
    assert tr.breakpoints.size == 4  # t0, two switchings, tf
    u = tr.control(np.array([0.2, 1.5, 2.8]))[:, 0]
    assert np.allclose(u, [-1.0, 0.0, 1.0])
    assert tr.reintegrate().max_error < 1e-8


def test_a_failed_transcription_raises_with_its_last_iterate_or_returns_it(energy_pair):
    pr, _, _ = energy_pair
    tr = Radau(pr, nodes=8, intervals=10)
    with pytest.raises(SolverError, match="Maximum_Iterations_Exceeded") as err:
        tr.solve(ipopt_options={"max_iter": 2})
    assert err.value.result is not None and not err.value.result.converged
    assert "raise_on_failure=False" in str(err.value)
    last = tr.solve(ipopt_options={"max_iter": 2}, raise_on_failure=False)
    assert not last.converged and last.status == "Maximum_Iterations_Exceeded" and last.iterations == 2
    assert "allow_acceptable=True" in failure_hint("Solved_To_Acceptable_Level")


def test_a_failed_shooting_raises_with_its_last_iterate():
    pr = double_integrator(lam=1.0)
    s = Shooting(pr, control_law(pr, "box"), rtol=1e-10, atol=1e-10)
    with pytest.raises(SolverError, match="raise_on_failure=False") as err:
        s.solve(np.array([0.9, 1.5]), maxfev=2)
    assert err.value.result is not None and not err.value.result.converged
