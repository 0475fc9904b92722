"""The direct-to-indirect chain names its fix (issue 41, item 5): a residual that stalls at the integrator's noise
above tol says the noise and the tol that would pass; a state no dynamics reads (an output integral) is named."""

import re

import casadi as ca
import numpy as np
import pytest

from ocpkit import Control, FreeFinalTime, OptimalControlProblem, Outcome, Radau, SolverError, State
from ocpkit.indirect import to_extremal
from ocpkit.shooting.result import noise_floor, stall_advice


def goddard_in_feet() -> OptimalControlProblem:
    """The Goddard rocket in English units, as Bryson (1999) and Betts (2010) state it (GPOPS-II's goddardRocket
    example): from rest at h = 0 ft with 3 slug to 1 slug, T <= 2 m0 g, drag 5.4915e-5 v^2 exp(-h / 23800 ft),
    g = 32.174 ft/s^2, exhaust speed 1580.9425 ft/s, constant gravity; maximum altitude (about 18550 ft), t_f
    free. Scaled for the direct NLP (1e4 ft, 1e3 ft/s), not for the shooting: its conditions are in feet."""
    g0, c, D0, H, m0, mf = 32.174, 1580.9425, 5.4915e-5, 23800.0, 3.0, 1.0
    Tmax = 2 * m0 * g0

    def dynamics(x, u, t):
        h, v, m = x[0], x[1], x[2]
        return ca.vertcat(v, (u[0] - D0 * v**2 * ca.exp(-h / H)) / m - g0, -u[0] / c)

    return OptimalControlProblem(
        "goddard_in_feet",
        states=[
            State("h", 0.0, 30000.0, initial=0.0, guess=(0.0, 18000.0), scale=1e4),
            State("v", 0.0, 2000.0, initial=0.0, guess=500.0, scale=1e3),
            State("m", mf, m0, initial=m0, final=mf, guess=(m0, mf)),
        ],
        controls=[Control("T", 0.0, Tmax, guess=Tmax / 2, scale=Tmax)],
        dynamics=dynamics,
        tf=FreeFinalTime(1.0, 100.0, 40.0, scale=10.0),
        mayer=lambda x0, xf, t0, tf: -xf[0],
    )


def test_a_residual_stalled_at_the_integrator_s_noise_names_the_noise_and_the_tol_that_passes():
    """Goddard in feet (full, singular, coast): arc shooting stops at |S| ~ 4e-9 above the default tol = 1e-10, where S
    scatters by ~3e-8 (its conditions are in feet). The error says so and names the tol; that tol certifies."""
    direct = Radau(goddard_in_feet(), 4, 40).solve(error_threshold=None)
    with pytest.raises(
        SolverError, match=r"stalled at the integrator's noise: S scatters by .* tol=1e-\d\d would pass"
    ) as info:
        to_extremal(direct)
    error, result = info.value, info.value.result
    assert error.outcome is Outcome.STALLED and result.noise is not None and result.norm <= 10 * result.noise
    assert "stalled at the integrator's noise" in result.remedy and result.detail.startswith("no step decreases")
    named = float(re.search(r"tol=(1e-\d\d) would pass", str(error)).group(1))
    assert named >= max(result.norm, result.noise) and named < 10 * max(result.norm, result.noise)
    extremal = to_extremal(direct, tol=named)
    assert extremal.certificate.passed and extremal.objective == pytest.approx(-18550.9, abs=1.0)


def test_the_noise_floor_is_the_scatter_about_a_line_and_a_stall_far_above_it_is_not_called_noise():
    rng = np.random.default_rng(5)
    smooth = lambda z: np.array([z[0] ** 2 - 2.0, 3.0 * z[1]])  # noqa: E731
    assert noise_floor(smooth, np.array([1.4, 0.3])) <= 1e-14
    noisy = lambda z: smooth(z) + 1e-6 * rng.standard_normal(2)  # noqa: E731
    assert 3e-7 <= noise_floor(noisy, np.array([1.4, 0.3])) <= 3e-6
    assert "tol=1e-05 would pass" in stall_advice(3e-6, 1e-10, 1.2e-6)
    assert "not the integrator's noise" in stall_advice(1e-2, 1e-10, 1e-6)


def planar_robot(output: bool = True) -> OptimalControlProblem:
    """A planar flying robot, rest to rest from the origin to (3, 4) in 6 with an unbounded thrust, minimum energy
    int |u|^2 dt: as an output state J' = |u|^2 with the cost J(t_f), or as the running cost. Closed form: the
    linear thrust of the double integrator, J = 2 * 12 * 25 / 6^3 = 25/18."""
    states = [State(n, initial=0.0, final=f) for n, f in (("x", 3.0), ("y", 4.0), ("vx", 0.0), ("vy", 0.0))]
    thrust = [Control("u1"), Control("u2")]
    if output:
        return OptimalControlProblem(
            "planar_robot_output_energy",
            [*states, State("J", initial=0.0)],
            thrust,
            lambda x, u, t: [x[2], x[3], u[0], u[1], u[0] ** 2 + u[1] ** 2],
            tf=6.0,
            mayer=lambda x0, xf, t0, tf: xf[4],
        )
    return OptimalControlProblem(
        "planar_robot_energy",
        states,
        thrust,
        lambda x, u, t: [x[2], x[3], u[0], u[1]],
        tf=6.0,
        lagrange=lambda x, u, t: u[0] ** 2 + u[1] ** 2,
    )


def test_an_output_integral_is_named_with_its_fix_and_the_fix_certifies():
    """With J' = |u|^2 a state, H's quadratic coefficient in u is the costate of J: an unknown of the shooting, of
    either sign at the law's checks, so no law derives (the error said only that H has no minimum). The error
    names J and the fix; stated as the running cost, the chain certifies the closed form."""
    from ocpkit.indirect import output_states

    problem = planar_robot()
    assert output_states(problem) == {"J": 1.0} and output_states(planar_robot(output=False)) == {}
    direct = Radau(problem, 4, 20).solve(error_threshold=None)
    with pytest.raises(
        ValueError,
        match=r"no box law.*; and no dynamics.*reads the state 'J' \(an output integral.*lagrange = 1 \* \(J's right-hand side\), drop 'J'",
    ):
        to_extremal(direct)
    extremal = to_extremal(Radau(planar_robot(output=False), 4, 20).solve(error_threshold=None))
    assert extremal.certificate.passed and extremal.objective == pytest.approx(25 / 18, abs=1e-12)


def test_a_shooting_failure_with_an_output_integral_names_it_too(monkeypatch):
    """Thrust bounded by 0.5 (the law derives, saturated) and a tol no integration reaches: the shooting stalls at
    its noise, and the error names the noise, the tol that would pass and the output state (multiple shooting, which
    cannot reach it either, is not tried: seconds, not twenty)."""
    import ocpkit.indirect as indirect

    monkeypatch.setattr(indirect, "SEGMENTS", ())
    problem = planar_robot().replace(controls=[Control("u1", -0.5, 0.5), Control("u2", -0.5, 0.5)])
    direct = Radau(problem, 4, 20).solve(error_threshold=None)
    with pytest.raises(SolverError, match=r"stalled at the integrator's noise.*reads the state 'J'") as info:
        to_extremal(direct, tol=1e-30)
    assert info.value.outcome is Outcome.STALLED and info.value.result.noise > 0
