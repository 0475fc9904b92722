"""The Delta III ascent's four phase problems: constants, element conversions, dynamics, one phase solved."""

import math

import casadi as ca
import numpy as np
import pytest

from ocpkit import Guess, Radau

from compendium.paper import paper_table
from compendium.problems import delta3_constants, delta3_guesses, delta3_mass_drops, delta3_phases
from compendium.problems.delta3 import orbital_elements, orbital_elements_np, rv_from_elements

DEG = math.pi / 180


@pytest.fixture(scope="module")
def c():
    return delta3_constants()


@pytest.fixture(scope="module")
def phases():
    return delta3_phases()


def test_constants_are_the_published_ones(c):
    # GPOPS-II launchMain.m / launchContinuous.m (same values in GPOPS v1, yapss and the JuMP port)
    assert (c["mu"], c["Re"], c["omega_E"]) == (3.986012e14, 6378145.0, 7.29211585e-5)
    assert (c["rho0"], c["H"], c["CD"], c["g0"]) == (1.225, 7200.0, 0.5, 9.80665)
    assert c["S"] == pytest.approx(4 * math.pi, rel=1e-15)
    s, f, u = c["srb"], c["first_stage"], c["second_stage"]
    assert (s["thrust"], s["mdot"] * 75.2, s["dry"]) == pytest.approx((628500.0, 17010.0, 19290.0 - 17010.0))
    assert (f["thrust"], f["mdot"] * 261.0, f["dry"]) == pytest.approx((1083100.0, 95550.0, 104380.0 - 95550.0))
    assert (u["thrust"], u["mdot"] * 700.0, u["dry"]) == pytest.approx((110094.0, 16820.0, 19300.0 - 16820.0))
    assert c["payload_kg"] == 4164.0
    assert c["times"] == [0.0, 75.2, 150.4, 261.0, 961.0]
    assert c["target"] == pytest.approx((24361140.0, 0.7308, 28.5 * DEG, 269.8 * DEG, 130.5 * DEG), rel=1e-15)
    # lift-off state: Cape Canaveral, latitude 28.5 deg, at rest on the rotating Earth
    assert np.linalg.norm(c["r0"]) == pytest.approx(c["Re"], rel=1e-15)
    assert c["r0"][2] / c["Re"] == pytest.approx(math.sin(28.5 * DEG))
    assert c["v0"] == pytest.approx([0.0, c["omega_E"] * c["Re"] * math.cos(28.5 * DEG), 0.0])


def test_masses_and_mass_drops(c):
    p = c["phases"]
    assert p[0]["m_start"] == 301454.0  # launchMain.m's initialMass
    assert p[3]["m_start"] == pytest.approx(4164.0 + 19300.0, rel=1e-12)  # the first stage is spent at t3 = 261 s
    assert p[3]["m_end"] == 4164.0
    assert delta3_mass_drops() == (-6 * 2280.0, -3 * 2280.0, -8830.0)
    for k in range(3):  # drops link the end of each phase to the start of the next
        assert p[k + 1]["m_start"] - p[k]["m_end"] == pytest.approx(c["mass_drops"][k], abs=1e-9)
    for ph in p[:3]:  # fixed-time phases burn exactly down to their lower mass bound
        assert ph["m_start"] - ph["mdot"] * (ph["tf"] - ph["t0"]) == pytest.approx(ph["m_end"], rel=1e-12)
    # mdot = T / (g0 Isp) with Isp from propellant / burn time: the propellant rates themselves
    assert p[0]["mdot"] == pytest.approx(6 * 17010 / 75.2 + 95550 / 261, rel=1e-14)
    assert p[3]["mdot"] == pytest.approx(16820 / 700, rel=1e-14)


def test_published_optimum_is_consistent_with_the_constants(c):
    t = paper_table("delta3_gpops2").set_index("quantity")["value"]
    assert t["final_mass"] == 7529.712412
    # the last phase burns at a constant rate: tf = t3 + (m40 - m(tf)) / mdot reproduces the published tf
    last = c["phases"][3]
    tf = last["t0"] + (last["m_start"] - t["final_mass"]) / last["mdot"]
    assert tf == pytest.approx(t["final_time"], abs=5e-4)


@pytest.mark.parametrize("nu_deg", [0.0, 45.0, 135.0, 200.0, 330.0])
def test_elements_round_trip(c, nu_deg):
    mu = c["mu"]
    elements = (*c["target"], nu_deg * DEG)
    r, v = rv_from_elements(*elements, mu)
    back = orbital_elements_np(r, v, mu)
    assert back == pytest.approx(elements, rel=1e-12, abs=1e-10)
    symbolic = np.array(ca.DM(orbital_elements(ca.DM(r), ca.DM(v), mu))).ravel()
    assert symbolic == pytest.approx(back, rel=1e-14, abs=1e-14)
    r2, v2 = rv_from_elements(*back, mu)
    assert r2 == pytest.approx(r, abs=1e-6) and v2 == pytest.approx(v, abs=1e-9)


@pytest.mark.parametrize("Omega_deg, omega_deg", [(30.0, 60.0), (200.0, 300.0), (100.0, 250.0)])
def test_elements_in_every_quadrant(c, Omega_deg, omega_deg):
    elements = (7.0e6, 0.1, 50 * DEG, Omega_deg * DEG, omega_deg * DEG, 1.0)
    r, v = rv_from_elements(*elements, c["mu"])
    assert orbital_elements_np(r, v, c["mu"]) == pytest.approx(elements, rel=1e-12)


def test_each_phase_builds_with_its_initial_acceleration(c, phases):
    """At the lift-off position, at rest relative to the air (no drag), thrusting straight up: T/m - g."""
    assert [p.free_final_time for p in phases] == [False, False, False, True]
    r0, v0 = c["r0"], c["v0"]
    up = r0 / np.linalg.norm(r0)
    g = c["mu"] / c["Re"] ** 2
    expected = [16.10, 18.77, 14.88, 4.69]  # T/m at each phase start, m/s^2
    for p, ph, a in zip(phases, c["phases"], expected):
        x = np.concatenate([r0, v0, [ph["m_start"]]])
        f = np.array(p.dynamics(x, up, ph["t0"])).ravel()
        assert f[:3] == pytest.approx(v0)
        assert f[3:6] == pytest.approx((ph["thrust"] / ph["m_start"] - g) * up, rel=1e-9)
        assert ph["thrust"] / ph["m_start"] == pytest.approx(a, abs=5e-3)
        assert f[6] == -ph["mdot"]
        assert np.array(p.path(x, up, ph["t0"])).ravel() == pytest.approx([1.0, 0.0], abs=1e-9)
    # the drag decelerates a vehicle moving through the air: 200 m/s upwards at 5 km
    r = (c["Re"] + 5e3) * up
    x = np.concatenate([r, np.cross([0.0, 0.0, c["omega_E"]], r) + 200 * up, [c["phases"][0]["m_start"]]])
    f = np.array(phases[0].dynamics(x, np.zeros(3), 10.0)).ravel()
    rho = c["rho0"] * math.exp(-5e3 / c["H"])
    drag = 0.5 * c["CD"] * c["S"] * rho * 200**2 / x[6]
    gravity = c["mu"] / (c["Re"] + 5e3) ** 2
    assert f[3:6] == pytest.approx(-(gravity + drag) * up, rel=1e-9)


def test_last_phase_objective_and_orbit_constraint(c, phases):
    last = phases[3]
    r, v = c["r_guess"], c["v_guess"]
    xf = np.concatenate([r, v, [7500.0]])
    x0 = np.concatenate([c["r0"], c["v0"], [23464.0]])
    psi = np.array(last.boundary(x0, xf, 261.0, 924.0)).ravel()
    lo, hi = last.functions.boundary.lower, last.functions.boundary.upper
    assert np.array_equal(lo, hi)
    assert psi == pytest.approx(lo, rel=1e-12)  # the guess point lies on the target orbit
    assert psi[0] == pytest.approx(24361140.0 / c["Re"])  # a in Earth radii
    assert float(last.mayer(x0, xf, 261.0, 924.0)) == -7500.0
    assert float(phases[0].mayer(x0, xf, 0.0, 75.2)) == 0.0
    assert (last.tf.lower, last.tf.upper, last.tf.guess) == (262.0, 961.0, 961.0)


def test_guesses(c, phases):
    for kind in ("gpops2", "linear", "asset"):
        guesses = delta3_guesses(kind)
        assert len(guesses) == 4 and all(isinstance(g, Guess) for g in guesses)
        for p, g, ph in zip(phases, guesses, c["phases"]):
            tf, xs, us = g.functions(p)
            t = np.array([ph["t0"], tf])
            assert xs(t)[:, 6] == pytest.approx([ph["m_start"], ph["m_end"]])
            assert us(t) == pytest.approx(np.array([[0.0, 1.0, 0.0]] * 2))
        assert guesses[3].tf == 961.0
    _, xs, _ = delta3_guesses("linear")[0].functions(phases[0])
    assert xs(np.array([0.0]))[0, :3] == pytest.approx(c["r0"])
    _, xs, _ = delta3_guesses("gpops2")[2].functions(phases[2])
    assert xs(np.array([200.0]))[0, :3] == pytest.approx(c["r_guess"])
    # ASSET's line ends on the target orbit at mean anomaly -0.05 and stays above the ground (the line to true
    # anomaly 0, GPOPS-II's point, passes 312 km under it)
    last = delta3_guesses("asset")[3]
    _, xs, _ = last.functions(phases[3])
    assert xs(np.array([961.0]))[0, :3] == pytest.approx(c["r_guess_asset"])
    t = np.linspace(0.0, 961.0, 2001)
    line = [g.functions(p)[1] for g, p in zip(delta3_guesses("asset"), phases)]
    height = [
        np.linalg.norm(line[int(np.searchsorted(c["times"][1:4], s, side="right"))](np.array([s]))[0, :3]) for s in t
    ]
    assert min(height) >= c["Re"] - 1e-6
    with pytest.raises(ValueError, match="kind"):
        delta3_guesses("spline")


def test_first_phase_alone_solves(c, phases):
    """Phase 1 alone, its final state free, climbing as high as it can in its 75.2 s. (Its own objective is zero:
    every feasible point is optimal, and IPOPT's path to its 1e-10 tolerance turned on rounding, measured: Radau
    8 x 4 and 10 x 8 stopped at the acceptable level under MUMPS's AMF ordering, 10 x 4 under QAMD. With the final
    altitude as its objective the problem is well posed: 10 x 4, 8 x 4, 10 x 8 and 6 x 6 converge under either
    ordering, to one optimum.)"""
    highest = phases[0].replace(mayer=lambda x0, xf, t0, tf: -ca.sqrt(ca.dot(xf[0:3], xf[0:3])) / c["Re"])
    tops = []
    for nodes, intervals in ((10, 4), (8, 4)):
        sol = Radau(highest, nodes=nodes, intervals=intervals).solve(
            delta3_guesses()[0], ipopt_options={"print_level": 0}, error_threshold=None
        )
        assert sol.converged
        x = sol.state_values
        assert x[0] == pytest.approx(np.concatenate([c["r0"], c["v0"], [301454.0]]))
        assert x[-1, 6] == pytest.approx(c["phases"][0]["m_end"], rel=1e-10)
        assert np.abs(np.linalg.norm(sol.control_values, axis=1) - 1).max() < 1e-8
        altitude = np.linalg.norm(x[:, :3], axis=1) - c["Re"]
        assert altitude.min() > -1e-3 and altitude[-1] > 1e3  # it climbs
        tops.append(altitude[-1])
    assert tops[0] == pytest.approx(tops[1], rel=1e-8)  # one optimum (25.3 km), whatever the mesh


def test_asset_statement_and_guess(c):
    """ASSET's Delta III example (benchmarks/bench_delta3.py): the thrust along u/|u| with a free length in
    [0.5, 1.5], and a straight-line guess to the target orbit at mean anomaly -0.05 rad (Kepler's equation)."""
    from compendium.problems.delta3 import orbital_elements_np, true_anomaly

    e = c["target"][1]
    nu = true_anomaly(-0.05, e)
    E = 2 * math.atan(math.sqrt((1 - e) / (1 + e)) * math.tan(nu / 2))
    assert E - e * math.sin(E) == pytest.approx(-0.05, abs=1e-15)
    for e_high in (0.9, 0.99, 0.999):  # Newton's start from M + e sign(M): every M, every e < 1
        for M in np.linspace(-3.1, 3.1, 63):
            nu = true_anomaly(M, e_high)
            E = 2 * math.atan2(math.sqrt(1 - e_high) * math.sin(nu / 2), math.sqrt(1 + e_high) * math.cos(nu / 2))
            assert E - e_high * math.sin(E) == pytest.approx(M, abs=1e-12)
    assert orbital_elements_np(c["r_guess_asset"], c["v_guess_asset"], c["mu"])[:5] == pytest.approx(c["target"])
    guesses = delta3_guesses("asset")
    x = ca.DM([*c["r0"], *c["v0"], 2e5])
    unit, direction = (delta3_phases(control=k)[0] for k in ("unit", "direction"))
    u = ca.DM([0.3, 1.2, -0.4])
    f = direction.dynamics(x, u, 0.0)
    assert np.array(f).ravel() == pytest.approx(np.array(unit.dynamics(x, u / ca.norm_2(u), 0.0)).ravel(), rel=1e-14)
    bound = direction.path_constraints[0]
    assert (bound.lower, bound.upper) == (0.25, 2.25)
    with pytest.raises(ValueError, match="control must be 'unit' or 'direction'"):
        delta3_phases(control="angles")
    assert len(guesses) == 4
