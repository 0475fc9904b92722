"""Multiple shooting of the switching engine (ocpkit.shooting.multiple): closed forms and its exact Jacobian."""

import numpy as np
import pytest
from test_structure import race  # minimum time, rest to rest over a unit distance: t_f = 2, the switch at 1

from ocpkit.shooting import Shooting, control_law
from ocpkit.shooting.multiple import MultipleShooting

from compendium.problems import double_integrator, double_integrator_solution, harmonic_oscillator


def central_differences(ms, Z, h=1e-6):
    D = np.empty((Z.size, Z.size))
    for j in range(Z.size):
        e = np.zeros(Z.size)
        e[j] = h * max(1.0, abs(Z[j]))
        D[:, j] = (ms.evaluate(Z + e, jacobian=False)[0] - ms.evaluate(Z - e, jacobian=False)[0]) / (2 * e[j])
    return D


def test_the_fuel_optimal_double_integrator_over_three_segments():
    """The switching times and costates of the closed form, from a perturbed start."""
    pr = double_integrator(lam=1.0)
    ms = MultipleShooting(Shooting(pr, control_law(pr, "box"), rtol=1e-12, atol=1e-12), segments=3)
    exact = double_integrator_solution()
    r = ms.solve(np.array(exact.p0) * (1 + np.array([0.05, -0.03])))
    assert r.converged and r.norm <= 1e-10 and r.continuity <= 1e-12 and r.status == "converged" and r.tol == 1e-10
    assert r.z == pytest.approx(exact.p0, abs=1e-10) and r.objective == pytest.approx(exact.fuel, abs=1e-10)
    switches = np.concatenate([i.switching_times for i in r.integrations])
    assert r.switchings == 2 and switches == pytest.approx([exact.t1, exact.t2], abs=1e-10)


def test_a_free_final_time_moves_the_nodes():
    """Minimum time: t_f = 2 and the switch at 1, with the nodes at fixed fractions of the free horizon."""
    pr = race()
    ms = MultipleShooting(Shooting(pr, control_law(pr, "box"), rtol=1e-12, atol=1e-12), segments=4)
    r = ms.solve(np.array([-1.2, -0.9, 2.2]))
    assert r.tf == pytest.approx(2.0, abs=1e-10) and r.times == pytest.approx([0.0, 0.5, 1.0, 1.5, 2.0], abs=1e-10)


@pytest.mark.parametrize(
    "case",
    ["oscillator", "race"],
)
def test_the_jacobian_matches_central_differences(case):
    """The assembled Jacobian (segments' variational columns, the free t_f's column) against differences of R, with
    switchings inside the segments."""
    if case == "oscillator":
        pr = harmonic_oscillator(lam=1.0)
        z = np.array([1.0328, 0.003])
    else:
        pr = race()
        z = np.array([-1.1, -0.9, 2.1])
    ms = MultipleShooting(Shooting(pr, control_law(pr, "box"), rtol=1e-12, atol=1e-12), segments=3)
    Z = ms.nodes(z) + 1e-3 * np.random.default_rng(0).standard_normal(ms.nz)  # off the flow: defects at the nodes
    R, D, runs = ms.evaluate(Z)
    assert sum(r.switchings for r in runs) >= 1
    assert np.abs(D - central_differences(ms, Z)).max() <= 1e-6 * np.abs(D).max()


def test_bad_segments_are_named():
    pr = double_integrator(lam=1.0)
    with pytest.raises(ValueError, match="segments must be an integer of at least 2"):
        MultipleShooting(Shooting(pr, control_law(pr, "box")), segments=1)


def test_too_many_unknowns_for_the_dense_jacobian_are_refused_by_name():
    pr = double_integrator(lam=1.0)
    with pytest.raises(ValueError, match="more than the 4000 whose dense Jacobian"):
        MultipleShooting(Shooting(pr, control_law(pr, "box")), segments=1000)


def test_a_run_that_cannot_be_integrated_anywhere_is_returned_not_raised_when_asked():
    """raise_on_failure=False with every integration failing (a budget of one step): the run is returned, its last
    iterate's and its start's integrations both failed, with NaN residuals, no integrations and the outcome
    INTEGRATION_FAILED (the start used to be re-evaluated unguarded, which raised)."""
    from ocpkit import Outcome, SolverError

    pr = double_integrator(lam=1.0)
    ms = MultipleShooting(Shooting(pr, control_law(pr, "box"), max_steps=1), segments=2)
    Z0 = np.concatenate([[1.0, 1.0], [0.5, -0.5, 1.0, 1.0, 0.0]])
    with pytest.raises(SolverError) as info:
        ms.solve(Z0)
    assert info.value.outcome is Outcome.INTEGRATION_FAILED
    r = ms.solve(Z0, raise_on_failure=False)
    assert not r.converged and r.status is Outcome.INTEGRATION_FAILED and np.isnan(r.norm)
    assert r.integrations == [] and "and at the start" in r.detail and np.isnan(r.objective)
    with pytest.raises(ValueError, match="no recorded integrations"):
        r.trajectory.state(0.0)
