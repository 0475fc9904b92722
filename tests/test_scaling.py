"""Automatic scaling (ocpkit.autoscale) and periodic controls (Control(period=...)): what the NLP sees, not the optimum."""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest

from ocpkit import HLGL, Constraint, Control, FreeFinalTime, OptimalControlProblem, Radau, State, autoscale

from compendium.problems import hang_glider


def unscaled_hang_glider() -> OptimalControlProblem:
    pr = hang_glider()
    return pr.replace(
        states=[dataclasses.replace(s, scale=1.0) for s in pr.states],
        tf=dataclasses.replace(pr.tf, scale=1.0),
        objective_scale=1.0,
    )


def test_bounds_give_a_shift_and_a_scale_and_the_guess_gives_the_rest():
    raw = unscaled_hang_glider()
    auto = autoscale(raw)
    x, given = auto.states[0], raw.states[0]
    # bounds [lower, upper]: shifted to their midpoint, scaled by their width (the NLP variable in [-1/2, 1/2])
    assert (x.scale, x.shift) == (given.upper - given.lower, (given.upper + given.lower) / 2)
    assert auto.tf.scale == pytest.approx(raw.tf.guess)
    x_f = given.guess_at(np.array([1.0]))[0]  # -x(t_f) at the guess
    assert auto.objective_scale == pytest.approx(abs(x_f))
    problem = OptimalControlProblem(
        "one_sided",
        states=[State("r", lower=0.0, initial=6.4e6, guess=6.4e6)],
        controls=[Control("u", guess=0.0)],
        dynamics=lambda x, u, t: u[0],
        tf=FreeFinalTime(1.0, 1e3, 200.0),
        lagrange=lambda x, u, t: u[0] ** 2,
        path_constraints=[Constraint("q", lambda x, u, t: x[0], upper=7e6)],
    )
    auto = autoscale(problem)
    assert auto.states[0].scale == pytest.approx(6.4e6) and auto.states[0].shift == 0.0
    assert auto.path_constraints[0].scale == pytest.approx(7e6)
    assert auto.objective_scale == 1.0  # a zero cost at the guess: left alone


def test_what_the_user_set_is_kept():
    pr = hang_glider()
    auto = autoscale(pr)
    for given, filled in zip(pr.states, auto.states):
        if given.scale != 1.0:  # x, y, vx are scaled by hand; vy is not and gets its bounds' width
            assert (filled.scale, filled.shift) == (given.scale, given.shift)
        else:
            assert filled.scale == given.upper - given.lower
    assert auto.tf.scale == pr.tf.scale and auto.objective_scale == pr.objective_scale


def test_autoscaling_saves_most_of_the_iterations_an_unscaled_problem_costs():
    raw = unscaled_hang_glider()
    unscaled = Radau(raw, 4, 50).solve(error_threshold=None)
    scaled = Radau(autoscale(raw), 4, 50).solve(error_threshold=None)
    # measured 31 against 180 (against 99 under MUMPS's QAMD ordering): at least two thirds saved
    assert scaled.converged and scaled.iterations <= 0.35 * unscaled.iterations
    assert scaled.objective == pytest.approx(unscaled.objective, rel=1e-6)


def test_scaling_does_not_change_the_optimum_of_a_smooth_problem():
    def problem(**scales):
        return OptimalControlProblem(
            "energy",
            states=[State("x", initial=0.0, final=100.0), State("v", initial=0.0, final=0.0)],
            controls=[Control("u", -1e3, 1e3)],
            dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
            tf=10.0,
            lagrange=lambda x, u, t: u[0] ** 2,
            **scales,
        )

    a = Radau(problem(), 6, 4).solve(error_threshold=None)
    b = Radau(autoscale(problem()), 6, 4).solve(error_threshold=None)
    assert b.objective == pytest.approx(a.objective, rel=1e-9)


# -- periodic controls (angles) ------------------------------------------------------------------------------------


def _heading_problem(period):
    from ocpkit import Control as C

    return OptimalControlProblem(
        "heading",
        states=[State("x", initial=0.0, final=1.0), State("y", initial=0.0, final=1.0)],
        controls=[C("theta", period=period)],
        dynamics=lambda x, u, t: ca.vertcat(ca.cos(u[0]), ca.sin(u[0])),
        tf=FreeFinalTime(0.5, 5.0, 1.5),
        mayer=lambda x0, xf, t0, tf: tf,
    )


def test_a_periodic_control_is_interpolated_the_short_way_round():
    import math

    import numpy as np

    from ocpkit import Guess

    def wrapped(t):  # the optimum pi/4, moved by whole turns from node to node
        return math.pi / 4 + 2 * math.pi * (np.round(np.asarray(t) * 7) % 3 - 1)

    for scheme in (lambda p: Radau(p, 5, 3), lambda p: HLGL(p, 3)):
        out = {}
        for period in (None, 2 * math.pi):
            sol = scheme(_heading_problem(period)).solve(Guess(controls={"theta": wrapped}), error_threshold=None)
            assert sol.tf == pytest.approx(math.sqrt(2), rel=1e-8)  # the nodes see only cos and sin
            t = sol.time_grid(601)
            out[period] = (np.abs(np.cos(sol.control(t)[:, 0]) - math.cos(math.pi / 4)).max(), sol.state_error)
        jumps, estimate = out[None]
        assert jumps > 0.1 and estimate > 1e-3  # between nodes the polynomial sweeps whole turns
        jumps, estimate = out[2 * math.pi]
        assert jumps < 1e-8 and estimate < 1e-8


def test_a_bounded_periodic_control_is_wrapped_into_its_bounds_not_clipped():
    """A heading in [-pi, pi] that crosses pi: unwrapped between nodes, then wrapped back into the bounds to be
    flown (clipping it would fly pi where the solution flies pi + d)."""
    import math

    from ocpkit import Control as C
    from ocpkit import Guess

    problem = OptimalControlProblem(
        "tracking",
        states=[State("e", initial=0.0)],
        controls=[C("theta", -math.pi, math.pi, period=2 * math.pi)],
        # follow r(t) = pi - 0.5 + t through the bound at pi: the cost sees theta only through cos and sin
        dynamics=lambda x, u, t: (1 - ca.cos(u[0] - (math.pi - 0.5 + t))) + ca.sin(u[0] - (math.pi - 0.5 + t)) ** 2,
        tf=1.0,
        mayer=lambda x0, xf, t0, tf: xf[0],
    )

    def heading(t):
        return np.angle(np.exp(1j * (math.pi - 0.5 + np.asarray(t))))  # the reference, wrapped into [-pi, pi]

    sol = Radau(problem, 8, 2).solve(Guess(controls={"theta": heading}), error_threshold=None)
    t = sol.time_grid(401)
    miss = np.angle(np.exp(1j * (sol.control(t)[:, 0] - (math.pi - 0.5 + t))))
    # the tracking error is quadratic in the cost: IPOPT's tolerance leaves about 1e-5 of it (clipped: 0.5)
    assert np.abs(miss).max() < 1e-4 and sol.state_error < 1e-6
    # flown within the bounds; reported as the continuous angle through pi (Control.period), the same angle
    admitted = sol.admissible(sol.control_interpolant(t))[:, 0]
    assert np.all(admitted >= -math.pi) and np.all(admitted <= math.pi) and admitted.min() < -math.pi + 0.6
    assert np.abs(sol.control(t)[:, 0] - (math.pi - 0.5 + t)).max() < 1e-4


def test_a_period_must_be_positive():
    with pytest.raises(ValueError, match="period of 'theta' must be positive"):
        Control("theta", period=0.0)
