"""The orbit-transfer model (ocpkit.problems.orbit_transfer) against independent physics."""

import casadi as ca
import numpy as np
import pytest

from ocpkit.problems import orbit_transfer, orbit_transfer_constants, thrust_units
from ocpkit.problems.orbit_transfer import equinoctial_to_cartesian


def test_thrust_units():
    assert thrust_units(1.0) == pytest.approx(3600**2 / 1e6)


def test_equinoctial_dynamics_match_cartesian_two_body_with_local_thrust():
    """d(r, v)/dt from the equinoctial equations (chain rule through the element-to-Cartesian map)
    equals Newton's law with the thrust resolved in the radial / orthoradial / normal frame."""
    c = orbit_transfer_constants()
    mu = c["mu_Mm3_h2"]
    pr = orbit_transfer(2.0, lam=1.0, tf=100.0)
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
        xs = np.array([rng.uniform(8, 45), rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), rng.uniform(-0.3, 0.3),
                       rng.uniform(-0.3, 0.3), rng.uniform(-10, 10), rng.uniform(800, 1500)])
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
        orbit_transfer(-1.0, tf=10.0)
    with pytest.raises(ValueError, match="fixed final time"):
        orbit_transfer(1.0)
    with pytest.raises(ValueError, match="objective"):
        orbit_transfer(1.0, tf=10.0, objective="energy")


@pytest.fixture(scope="module")
def systems():
    from ocpkit import orbit_study

    return orbit_study.TransferSystems()


def test_minimum_time_shooting_at_strong_thrust(systems):
    """From a direct Radau solution's costate estimates: converged, with the transversality conditions of
    a free final time (H = -1, the Mayer cost being tf) and free final L and m (their costates vanish)."""
    from ocpkit import orbit_study

    result, direct = orbit_study.minimum_time_start(systems, 60.0)
    assert result.converged and result.norm < 1e-10
    assert result.tf <= direct.tf + 1e-9, "the indirect solution is at least as fast as the direct one"
    y = result.trajectory.y
    assert abs(y[7 + 5]) < 1e-9 and abs(y[7 + 6]) < 1e-9  # p_L(tf) = p_m(tf) = 0
    H = result.trajectory.hamiltonian
    assert np.abs(H + 1).max() < 1e-6  # H = -1 along the whole transfer


def test_l1_solution_at_5N_from_the_cached_energy_solution(systems):
    """Energy costates cached in data/derived by notebook 05 (computed by ocpkit.orbit_study)."""
    from ocpkit import orbit_study

    energy = orbit_study.read_cache("orbit_transfer_energy")
    row = energy[np.isclose(energy.thrust_N, 5.0)].iloc[0]
    z = row[orbit_study.COSTATES].to_numpy(dtype=float)
    s = systems.shooting("fuel", 5.0, row.tf_h, detection="correction", jacobian="variational", tol=1e-8)
    r = s.solve(z, maxfev=300)
    assert r.norm < 1e-9
    assert orbit_study.fuel_kg(r) < row.energy_fuel_kg
    u = np.linalg.norm(r.trajectory.controls(s.compiled.system), axis=1)
    assert np.all(np.isclose(u, 0.0) | np.isclose(u, 1.0)), "bang-bang: |u| in {0, 1}"
    assert r.trajectory.switchings > 10
