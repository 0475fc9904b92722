"""Periodic controls (Control(period=...)) reported as continuous angles: unwrapped along the trajectory and starting
in the declared turn, in control, sample, to_dataframe and what the explorer draws; flown as the same angle."""

import math
import warnings

import casadi as ca
import numpy as np
import pytest

from ocpkit import HLGL, Control, Guess, OptimalControlProblem, Radau, State
from ocpkit.flight import fly
from ocpkit.program import Program
from ocpkit.statement import declared_turn, wrap_periodic
from ocpkit.structure import control_structure

from compendium.explorer import History
from compendium.problems import orbit_raising

TURN = 2 * math.pi


def quiet(solve):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return solve()


@pytest.fixture(scope="module")
def drifting():
    """Orbit raising's heading (no bounds) on three meshes whose NLPs leave node values whole turns apart (Radau 3 x 50:
    down to -580 rad)."""
    problem = orbit_raising()
    return {
        "Radau 3 x 50": quiet(lambda: Radau(problem, 3, 50).solve()),
        "Radau 4 x 20": quiet(lambda: Radau(problem, 4, 20).solve()),
        "HLGL 40": quiet(lambda: HLGL(problem, 40).solve()),
    }


def assert_continuous_from_the_declared_turn(t, u, start=-math.pi):
    # a smooth heading on a dense grid: steps far below half a turn, none of a whole turn
    assert np.abs(np.diff(u)).max() < 0.1
    assert start <= u[0] < start + TURN


def test_a_heading_that_the_nlp_moves_by_turns_is_one_continuous_angle_in_every_output(drifting):
    for name, sol in drifting.items():
        nodes = sol.control_values[:, 0]
        assert nodes.max() - nodes.min() > 2 * TURN, f"{name}: the NLP's node values lie turns apart"
        t = sol.time_grid(4001)
        u = sol.control(t)[:, 0]
        assert_continuous_from_the_declared_turn(t, u)
        # the thrust turns through pi (0.43 to 5.44 rad): unwrapped, not wrapped back at the cut
        assert u.max() > 5.0 and u.min() > 0.4, name
        assert np.array_equal(sol.sample(lambda x, u, t: u["phi"], grid=t)[1], u)
        assert np.array_equal(sol.to_dataframe(t)["phi"].to_numpy(), u)
        drawn_t, drawn = History("phi").data(sol, samples=4001)
        assert np.array_equal(drawn_t, t) and np.array_equal(drawn, u)
        # the same angle as the scheme's own polynomial: whole turns apart, to rounding
        raw = sol.control_interpolant(t)[:, 0]
        turns = (u - raw) / TURN
        assert np.abs(turns - np.round(turns)).max() < 1e-9 and np.abs(turns).max() > 0.5


def test_the_schemes_agree_on_the_reported_heading(drifting):
    t = np.linspace(0.0, orbit_raising().tf, 801)
    headings = [sol.control(t)[:, 0] for sol in drifting.values()]
    for u in headings[1:]:
        assert np.abs(u - headings[0]).max() < 0.2  # the meshes' differences where the thrust swings, not turns


def test_the_flown_and_reintegrated_trajectory_is_the_one_of_the_wrapped_angle(drifting):
    sol = drifting["Radau 3 x 50"]
    continuous = sol.reintegrate()  # flies control(): the continuous angle
    raw = sol.reintegrate(controls="interpolant")  # flies the scheme's polynomial, turns apart
    assert np.abs(continuous.states - raw.states).max() < 1e-11
    # the flight (CVODES) and the re-integration (DOP853) reach the same radius from the same control
    assert -fly(sol).objective == pytest.approx(continuous.states[-1, 0], rel=1e-9)
    assert sol.accuracy.objective < 1e-6


def test_a_multi_phase_heading_continues_from_phase_to_phase():
    program = Program.split(orbit_raising(), [1.5, 2.5], lambda piece: Radau(piece, 3, 20))
    sol = quiet(program.solve)
    t = sol.time_grid(4001)
    u = sol.control(t)[:, 0]
    assert_continuous_from_the_declared_turn(t, u)
    last = sol.phase(2)
    # the last phase starts past pi, where a phase on its own would start in [-pi, pi)
    assert last.control(np.array([last.t0]))[0, 0] > math.pi
    assert last.control_start == {"phi": pytest.approx(sol.phase(1).control(np.array([1.5 + 1.0]))[0, 0])}
    assert np.array_equal(last.control(t[t >= 2.5])[:, 0], u[t >= 2.5])
    assert np.array_equal(sol.to_dataframe(t)["phi"].to_numpy(), u)
    assert np.array_equal(sol.sample(lambda x, u, t: u["phi"], grid=t)[1], u)


def tracking(lower, upper):
    """A heading that must follow pi - 0.5 + t over [0, 1], through pi (test_scaling's tracking problem)."""
    return OptimalControlProblem(
        "tracking",
        states=[State("e", initial=0.0)],
        controls=[Control("theta", lower, upper, period=TURN)],
        dynamics=lambda x, u, t: (1 - ca.cos(u[0] - (math.pi - 0.5 + t))) + ca.sin(u[0] - (math.pi - 0.5 + t)) ** 2,
        tf=1.0,
        mayer=lambda x0, xf, t0, tf: xf[0],
    )


def heading(t):
    return np.angle(np.exp(1j * (math.pi - 0.5 + np.asarray(t))))  # the reference, wrapped into [-pi, pi]


def test_a_bounded_heading_is_reported_continuous_and_warm_starts_within_its_bounds():
    problem = tracking(-math.pi, math.pi)
    sol = quiet(lambda: Radau(problem, 8, 2).solve(Guess(controls={"theta": heading}), error_threshold=None))
    t = sol.time_grid(401)
    u = sol.control(t)[:, 0]
    assert_continuous_from_the_declared_turn(t, u)
    assert np.abs(u - (math.pi - 0.5 + t)).max() < 1e-4  # beyond the upper bound pi, as the angle goes
    # another mesh started from it: within the bounds, the same angles (clipped, it would start at pi)
    other = Radau(problem, 5, 4).program
    groups = other.phases[0].layout.groups
    k = next(i for i, g in enumerate(groups) if g.is_control)
    start = other.unpack(other.initial_point(sol))[k][:, 0]
    assert np.all(start >= -math.pi) and np.all(start <= math.pi)
    expected = sol.control(np.asarray(groups[k].fractions))[:, 0]  # (t0 = 0, tf = 1)
    assert np.abs(np.angle(np.exp(1j * (start - expected)))).max() < 1e-12
    assert start.min() < -math.pi + 0.6
    resolved = quiet(lambda: Radau(problem, 5, 4).solve(sol, error_threshold=None))
    assert resolved.objective == pytest.approx(sol.objective, abs=1e-8)


def test_the_declared_turn_is_the_lower_bound_then_the_upper_then_centred():
    assert declared_turn(Control("a", 0.0, 10.0, period=TURN)) == 0.0
    assert declared_turn(Control("a", upper=1.0, period=TURN)) == pytest.approx(1.0 - TURN)
    assert declared_turn(Control("a", period=TURN)) == pytest.approx(-math.pi)
    assert declared_turn(Control("a", -1.0, 1.0, period=TURN)) is None  # its bounds hold it
    assert declared_turn(Control("a", -1.0, 1.0)) is None
    controls = [Control("a", 0.0, 10.0, period=TURN), Control("b", period=TURN), Control("c", -1.0, 1.0)]
    wrapped = wrap_periodic([[7.0, 7.0, 7.0], [-0.5, -0.5, -0.5]], controls)
    assert wrapped.tolist() == [[pytest.approx(7.0 - TURN), 7.0, 7.0], [pytest.approx(TURN - 0.5), -0.5, -0.5]]


def test_a_heading_starts_in_the_turn_of_its_bounds():
    problem = tracking(0.0, TURN)  # the heading starts at pi - 0.5, ends at pi + 0.5: inside [0, 2 pi)
    guess = Guess(controls={"theta": lambda t: math.pi - 0.5 + np.asarray(t)})
    sol = quiet(lambda: Radau(problem, 8, 2).solve(guess, error_threshold=None))
    t = sol.time_grid(401)
    assert_continuous_from_the_declared_turn(t, sol.control(t)[:, 0], start=0.0)
    assert np.abs(sol.control(t)[:, 0] - (math.pi - 0.5 + t)).max() < 1e-4


def test_a_periodic_control_with_bounds_a_turn_apart_has_no_arcs_on_them():
    """A heading in [0, 2 pi] that starts at 0: no bound holds it, though a heading near 0 is near a bound as a
    number (the structure read a 'lower' arc at the start)."""
    problem = OptimalControlProblem(
        "hold",
        states=[State("e", initial=0.0)],
        controls=[Control("theta", 0.0, TURN, period=TURN, guess=0.3)],
        dynamics=lambda x, u, t: 1 - ca.cos(u[0] - 0.2 * ca.sin(3 * t)),
        tf=1.0,
        mayer=lambda x0, xf, t0, tf: xf[0],
    )
    sol = quiet(lambda: Radau(problem, 4, 10).solve(error_threshold=None))
    t = sol.time_grid(401)
    u = sol.control(t)[:, 0]
    assert np.abs(u - 0.2 * np.sin(3 * t)).max() < 1e-2
    assert control_structure(sol).arcs == ()
