"""The orbit-transfer model (compendium.problems.orbit_transfer) against independent physics."""

import casadi as ca
import numpy as np
import pandas as pd
import pytest

from compendium.problems import (
    final_longitude,
    minimum_longitude,
    orbit_transfer,
    orbit_transfer_constants,
    thrust_units,
)
from compendium.problems.orbit_transfer import equinoctial_to_cartesian


def test_thrust_units():
    assert thrust_units(1.0) == pytest.approx(3600**2 / 1e6)


def test_equinoctial_dynamics_match_cartesian_two_body_with_local_thrust():
    """d(r, v)/dt from the equinoctial equations (chain rule through the element-to-Cartesian map)
    equals Newton's law with the thrust resolved in the radial / orthoradial / normal frame."""
    c = orbit_transfer_constants()
    mu = c["mu_Mm3_h2"]
    pr = orbit_transfer(2.0, lam=1.0, final="time", tf=100.0)
    x = ca.SX.sym("x", 7)
    u = ca.SX.sym("u", 3)
    pos, vel = equinoctial_to_cartesian(x[:6], mu)
    rv = ca.vertcat(*pos, *vel)
    xdot = pr.dynamics(x, u, 0.0)
    rv_dot = ca.mtimes(ca.jacobian(rv, x[:6]), xdot[:6])
    f = ca.Function("f", [x, u], [rv, rv_dot])
    rng = np.random.default_rng(7)
    Tmax = pr.parameters["Tmax"]
    for _ in range(25):
        xs = np.array(
            [
                rng.uniform(8, 45),
                rng.uniform(-0.6, 0.6),
                rng.uniform(-0.6, 0.6),
                rng.uniform(-0.3, 0.3),
                rng.uniform(-0.3, 0.3),
                rng.uniform(-10, 10),
                rng.uniform(800, 1500),
            ]
        )
        us = rng.uniform(-1, 1, 3)
        us /= max(1.0, np.linalg.norm(us))
        state, deriv = (np.asarray(v).ravel() for v in f(xs, us))
        r, v = state[:3], state[3:]
        e_r = r / np.linalg.norm(r)
        e_n = np.cross(r, v) / np.linalg.norm(np.cross(r, v))
        e_t = np.cross(e_n, e_r)
        acc = -mu * r / np.linalg.norm(r) ** 3 + Tmax / xs[6] * (us[0] * e_r + us[1] * e_t + us[2] * e_n)
        assert np.allclose(deriv[:3], v, rtol=1e-10, atol=1e-12)
        assert np.allclose(deriv[3:], acc, rtol=1e-9, atol=1e-10 * np.abs(acc).max())


def test_mass_flow_is_about_2000_s_specific_impulse():
    c = orbit_transfer_constants()
    isp_g0 = 1 / c["beta"] * 1e6 / 3600  # m/s
    assert isp_g0 / 9.80665 == pytest.approx(2000, rel=0.01)


def test_bad_orbit_transfer_arguments():
    with pytest.raises(ValueError, match="thrust_N"):
        orbit_transfer(-1.0)
    with pytest.raises(ValueError, match="needs the final time"):
        orbit_transfer(1.0, final="time")
    with pytest.raises(ValueError, match="objective"):
        orbit_transfer(1.0, objective="energy")
    with pytest.raises(ValueError, match="final must be one of"):
        orbit_transfer(1.0, final="apogee")
    with pytest.raises(ValueError, match="final must be one of"):
        orbit_transfer(1.0, objective="time", final="time")
    with pytest.raises(ValueError, match="final longitude must exceed"):
        orbit_transfer(1.0, longitude=0.0)
    with pytest.raises(ValueError, match="lam"):
        orbit_transfer(1.0, lam=2.0)


def test_the_slides_reading_fixes_the_final_longitude_and_frees_the_final_time():
    """Default reading (data/problems): L(tf) = L0 + 1.25 * 267.537780225 / Tmax, tf free; fixed time is the other."""
    c = orbit_transfer_constants()
    L0 = c["initial"]["L"]
    assert c["final_condition"] == "longitude"
    for T in (5.0, 0.1):
        pr = orbit_transfer(T)
        assert pr.free_final_time
        L = pr.states[pr.state_index("L")]
        assert L.final == pytest.approx(L0 + 1.25 * 267.537780225 / T)
        assert final_longitude(T) == pytest.approx(L.final)
        assert minimum_longitude(T) == pytest.approx(L0 + 267.537780225 / T)
    timed = orbit_transfer(5.0, final="time", tf=250.0)
    assert not timed.free_final_time and timed.tf == 250.0
    assert timed.states[timed.state_index("L")].final is None
    assert orbit_transfer(5.0, longitude=80.0).states[5].final == 80.0
    assert orbit_transfer(5.0, multiplier=2.0).states[5].final == pytest.approx(L0 + 2 * 267.537780225 / 5)


@pytest.fixture(scope="module")
def systems():
    from compendium.studies import orbit_transfer as orbit_study

    return orbit_study.TransferSystems()


def test_minimum_time_shooting_at_strong_thrust(systems):
    """From a direct Radau solution's costate estimates: converged, with the transversality conditions of
    a free final time (H = -1, the Mayer cost being tf) and free final L and m (their costates vanish)."""
    from compendium.studies import orbit_transfer as orbit_study

    result, direct = orbit_study.minimum_time_start(systems, 60.0)
    assert result.converged and result.norm < 1e-10
    assert result.tf <= direct.tf + 1e-9, "the indirect solution is at least as fast as the direct one"
    y = result.integration.y
    assert abs(y[7 + 5]) < 1e-9 and abs(y[7 + 6]) < 1e-9  # p_L(tf) = p_m(tf) = 0
    H = result.integration.hamiltonian
    assert np.abs(H + 1).max() < 1e-6  # H = -1 along the whole transfer


def test_the_slides_5N_transfer_from_the_cached_energy_solution(systems):
    """The slides' reading at 5 N from the energy costates cached by notebook 05: their fuel, switchings and steps.

    Slides 11-12 (detection): 134.49 kg, 22 switchings, 604 steps (data/paper/switching_detection.csv); the free
    final time makes H vanish along the whole transfer.
    """
    from compendium.paper import paper_table
    from compendium.studies import orbit_transfer as orbit_study

    energy = orbit_study.read_cache("orbit_transfer_energy")
    z = orbit_study.energy_start_vector(energy, "longitude", 5.0)
    slides = paper_table("switching_detection").set_index(["thrust_N", "detection", "jacobian"])
    ref = slides.loc[(5.0, "detection", "fd")]
    for detection in ("detection", "correction"):
        s = systems.shooting("fuel", 5.0, switching=detection, jacobian="variational", tol=1e-8)
        r = s.solve(z, maxfev=300)
        assert r.norm < 1e-9
        assert orbit_study.fuel_kg(r) == pytest.approx(ref.objective_kg, abs=0.05)
        assert r.integration.switchings == ref.switchings
        assert r.integration.steps == pytest.approx(ref.steps, rel=0.03)
        traj = s.integrate(r.z, record=True)
        assert np.abs(traj.hamiltonian).max() < 1e-6  # H(t) = 0 with a free final time
        assert abs(traj.y[5] - final_longitude(5.0)) < 1e-9
        u = np.linalg.norm(traj.controls(s.compiled.system), axis=1)
        assert np.all(np.isclose(u, 0.0) | np.isclose(u, 1.0)), "bang-bang: |u| in {0, 1}"
    assert (
        orbit_study.fuel_kg(r)
        < energy[(energy.reading == "longitude") & (energy.thrust_N == 5.0)].energy_fuel_kg.iloc[0]
    )


def test_the_noise_floor_study_takes_the_l1_tables_runs_at_their_tolerance(systems, monkeypatch):
    """tolerance_runs(reuse=...): the L1 table's MINPACK runs with the variational Jacobian at the slides' tolerance
    are the floor study's runs there, taken as they are (not solved again), their rows those it would make."""
    from ocpkit.shooting import Shooting

    from compendium.studies import orbit_transfer as orbit_study

    energy = orbit_study.read_cache("orbit_transfer_energy")
    z = orbit_study.energy_start_vector(energy, "longitude", 5.0)
    _, l1 = orbit_study.l1_runs(
        systems, 5.0, z, combinations=[("detection", "variational"), ("correction", "variational")]
    )
    solved, original = [], Shooting.solve
    monkeypatch.setattr(Shooting, "solve", lambda self, *a, **k: solved.append(1) or original(self, *a, **k))
    fresh, _ = orbit_study.tolerance_runs(systems, 5.0, z, [1e-8])
    assert len(solved) == 2
    reuse = orbit_study.reusable_runs({(5.0, *key): r for key, r in l1.items()}, 5.0, 1e-8)
    assert set(reuse) == {("detection", 1e-8), ("correction", 1e-8)}
    taken, results = orbit_study.tolerance_runs(systems, 5.0, z, [1e-8], reuse=reuse)
    assert len(solved) == 2 and all(results[key] is r for key, r in reuse.items())
    pd.testing.assert_frame_equal(taken.drop(columns="cpu_s"), fresh.drop(columns="cpu_s"))
    # one of the two taken, the other solved; a run of another treatment is refused, named
    partly, _ = orbit_study.tolerance_runs(
        systems, 5.0, z, [1e-8], reuse={("correction", 1e-8): reuse["correction", 1e-8]}
    )
    assert len(solved) == 3
    pd.testing.assert_frame_equal(partly.drop(columns="cpu_s"), fresh.drop(columns="cpu_s"))
    with pytest.raises(ValueError, match=r"reuse\[\('correction', 1e-08\)\] is a run with switching 'detection'"):
        orbit_study.tolerance_runs(systems, 5.0, z, [1e-8], reuse={("correction", 1e-8): reuse["detection", 1e-8]})


def test_shared_system_integrates_at_the_problems_thrust(systems):
    """Regression: the shared compiled system is built at 1 N; a 5 N shooting must burn 5 N worth of fuel."""
    from compendium.studies import orbit_transfer as orbit_study

    energy = orbit_study.read_cache("orbit_transfer_energy")
    z = orbit_study.energy_start_vector(energy, "longitude", 5.0)
    s = systems.shooting("fuel", 5.0, tol=1e-8)
    full = s.integrate(z)
    assert 1500.0 - full.y[6] > 100.0
    assert s.residual(z) == pytest.approx(s.residual(z, s.problem.parameter_values))


def test_minimum_time_restarts_find_a_lower_extremal_than_the_continuation(systems):
    """Regression: the thrust continuation ended at 5 N on an extremal at 173.48 h; restarting from the other
    thrusts' solutions finds 168.75 h (the lowest minimum of t_min against the final longitude, notebook 05)."""
    from compendium.studies import orbit_transfer as orbit_study
    from compendium.studies.orbit_transfer.minimum_time import _tmin_row

    cached = orbit_study.read_cache("orbit_transfer_tmin")
    donors = cached[np.isclose(cached.thrust_N, 6.955217) | np.isclose(cached.thrust_N, 12.42003)]
    assert len(donors) == 2
    # the 5 N row as the continuation left it: the 6.96 N solution carried to 5 N converges to 173.48 h
    z = donors[np.isclose(donors.thrust_N, 6.955217)][orbit_study.COSTATES + ["tmin_h"]].to_numpy(dtype=float)[0]
    z[-1] *= 6.955217 / 5.0
    at5 = systems.shooting("time", 5.0).solve(z, maxfev=150)
    assert at5.tf == pytest.approx(173.4822, abs=1e-3)
    table = pd.concat([donors, pd.DataFrame([_tmin_row(5.0, at5.z, at5.norm, True)])], ignore_index=True)
    table["target"] = np.isclose(table.thrust_N, 5.0)
    refined, extremals = orbit_study.refine_minimum_time(systems, table, log=None)
    row = refined[refined.target].iloc[0]
    assert row.continuation_tmin_h == pytest.approx(173.4822, abs=1e-3)
    assert row.tmin_h == pytest.approx(168.7510, abs=1e-3)
    assert extremals.best.sum() == 1 and extremals[extremals.best].tmin_h.iloc[0] == pytest.approx(row.tmin_h)
    # within a factor 1.2 of 5 N only the 5 N row itself restarts (the donors are 1.39 and 2.48 times stronger)
    alone, started = orbit_study.refine_minimum_time(systems, table, within=1.2, log=None)
    assert started.starts.sum() == 1 and alone[alone.target].tmin_h.iloc[0] == pytest.approx(173.4822, abs=1e-3)
    with pytest.raises(ValueError, match="within must be at least 1"):
        orbit_study.refine_minimum_time(systems, table, within=0.5, log=None)


def test_horizon_branch_falls_as_the_final_time_grows(systems):
    """The slides' 5 N transfer with its longitude released, followed in tf: fuel never rises, and its rate of
    change is beta Tmax H(tf) (the continuation rejects steps that jump to another extremal)."""
    from compendium.studies import orbit_transfer as orbit_study

    energy = orbit_study.read_cache("orbit_transfer_energy")
    tmin = orbit_study.read_cache("orbit_transfer_tmin")
    tmin5 = float(tmin[np.isclose(tmin.thrust_N, 5.0)].tmin_h.iloc[0])
    sol = systems.shooting("fuel", 5.0, tol=1e-8).solve(orbit_study.energy_start_vector(energy, "longitude", 5.0))
    released = orbit_study.solve_robustly(systems.shooting("fuel", 5.0, final="time", tf=sol.tf, tol=1e-8), sol.z[:-1])
    assert orbit_study.fuel_kg(released) < orbit_study.fuel_kg(sol)  # a free longitude costs no more fuel
    lo, hi = (sol.tf - 4.0) / tmin5, (sol.tf + 4.0) / tmin5
    branch = orbit_study.horizon_branches(systems, 5.0, [(sol.tf, released.z)], tmin5, lo=lo, hi=hi, step=0.005)
    assert len(branch) >= 5 and branch.tf_h.min() < sol.tf < branch.tf_h.max()
    dJ, dt = np.diff(branch.fuel_kg), np.diff(branch.tf_h)
    assert dJ.max() <= 1e-9
    rate = 0.5 * (branch.dfuel_dtf_kg_h.to_numpy()[1:] + branch.dfuel_dtf_kg_h.to_numpy()[:-1])
    assert np.abs(dJ / dt - rate).max() < 0.02
    bound = orbit_study.best_known_fuel(branch, np.linspace(branch.tf_h.min(), branch.tf_h.max(), 50))
    assert np.all(np.diff(bound.fuel_kg) <= 1e-12)


def test_the_jacobian_check_judges_a_column_only_where_its_steps_keep_the_switchings(systems):
    """jacobian_check: central differences whose step makes an arc appear or vanish measure the jump of S, not dS/dz
    (how a run that stalls near a grazing switching failed the notebook's check on another machine). A step of 5 %
    moves the 5 N energy start across switchings in some columns: those are not judged (NaN errors, not resolved),
    while a step of 1e-6 keeps them and agrees with the variational Jacobian; a column's noise is that of its
    larger usable step."""
    from ocpkit.shooting.result import noise_floor

    from compendium.studies import orbit_transfer as orbit_study
    from compendium.studies.orbit_transfer.low_thrust import central_differences, jacobian_check

    z = orbit_study.energy_start_vector(orbit_study.read_cache("orbit_transfer_energy"), "longitude", 5.0)
    fine = systems.shooting("fuel", 5.0, switching="correction", tol=1e-10)
    (small, large), kept = central_differences(fine, z, [1e-6, 0.05], fine.integrate(z).switchings)
    assert kept[0].all() and 0 < kept[1].sum() < z.size
    _, J = fine.jacobian_matrix(z, method="variational")
    assert np.all(np.linalg.norm(J - small, axis=0) <= 1e-3 * np.linalg.norm(small, axis=0))
    crossing = ~kept[1]
    assert np.all(np.linalg.norm(J - large, axis=0)[crossing] > 1e-2 * np.linalg.norm(large, axis=0)[crossing])

    kwargs = {"rtol": 1e-8, "reference_tol": 1e-10}
    coarse = jacobian_check(systems, 5.0, [("iterate", z)], steps=(0.05,), **kwargs)
    assert coarse.same_switchings.tolist() == kept[1].tolist()
    assert coarse[~coarse.same_switchings][["error", "error_reference_tol", "difference_noise"]].isna().all().all()
    assert not coarse[~coarse.same_switchings].resolved.any()
    assert coarse[coarse.same_switchings][["error", "error_reference_tol"]].notna().all().all()
    both = jacobian_check(systems, 5.0, [("iterate", z)], steps=(1e-6, 0.05), **kwargs)
    assert both.same_switchings.all() and both.error_reference_tol.max() <= 1e-3
    ratio = (both.difference_noise / coarse.difference_noise).to_numpy()
    assert np.allclose(ratio[kept[1]], 1.0) and np.isnan(ratio[~kept[1]]).all()
    noise = noise_floor(fine.residual, z)
    only_small = both.difference_noise.to_numpy()[~kept[1]]
    assert np.allclose(only_small, noise / (2e-6 * np.maximum(np.abs(z[~kept[1]]), 1.0)))


def test_column_errors_take_the_nearest_usable_step_only():
    """A step whose stencil crosses a switching is not taken even where it agrees better, nor one whose differences
    are zero or not finite; no usable step gives NaN, and a Jacobian column that is not finite an infinite error
    (the check fails on it)."""
    from compendium.studies.orbit_transfer.low_thrust import _column_errors, usable_steps

    J = np.eye(3)
    near, off = np.eye(3) * (1 + 1e-6), np.eye(3) * 1.1
    kept = np.array([[False, False, True], [True, False, True]])
    errors = _column_errors(J, [near, off], usable_steps([near, off], kept))
    assert errors[0] == pytest.approx(0.1 / 1.1) and np.isnan(errors[1]) and errors[2] == pytest.approx(1e-6, rel=1e-3)
    blank = off.copy()
    blank[:, 2] = 0.0
    blank[0, 0] = np.nan
    usable = usable_steps([blank, near], np.ones((2, 3), dtype=bool))
    assert usable.tolist() == [[False, True, False], [True, True, True]]
    assert _column_errors(J, [blank, near], usable)[2] == pytest.approx(1e-6, rel=1e-3)
    broken = J.copy()
    broken[1, 1] = np.nan
    assert _column_errors(broken, [near, off], usable_steps([near, off], np.ones((2, 3), dtype=bool)))[1] == np.inf
