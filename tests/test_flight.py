"""The admissible control flown in one call (ocpkit.flight): against SciPy's DOP853 flying the same control."""

from __future__ import annotations

import warnings

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ocpkit import HLGL, Control, MultiRateHLGL, OptimalControlProblem, Radau, State
from ocpkit.accuracy import AccuracyWarning
from ocpkit.flight import fly

from compendium.problems import entry_landing, hang_glider, hyper_sensitive


def dop853_flight(sol, tol=1e-13):
    """The reference: the dynamics and the running cost with SciPy's DOP853, the admissible control evaluated by the
    solution itself at every step, restarting at every breakpoint of the state and control meshes."""
    pr = sol.problem
    nx = pr.nx
    stops = np.union1d(sol.breakpoints, sol.control_breakpoints)
    y = np.append(sol.initial_state(), 0.0)
    for a, b in zip(stops[:-1], stops[1:]):

        def rhs(t, z, a=a, b=b):
            u = sol.control(np.array(min(max(t, a), np.nextafter(b, a))))
            cost = pr.lagrange(z[:nx], u, t) if pr.L is not None else 0.0
            return np.append(np.asarray(pr.dynamics(z[:nx], u, t)).ravel(), float(cost))

        y = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=tol, atol=tol * np.append(pr.state_scale, 1.0)).y[:, -1]
    phi = float(pr.mayer(sol.initial_state(), y[:nx], sol.t0, sol.tf)) if pr.phi is not None else 0.0
    return y[:nx], float(y[nx]), phi + float(y[nx])


def quiet(make):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        return make()


CASES = {
    "hyper-sensitive, Radau 4 x 12": lambda: Radau(hyper_sensitive(50.0), 4, 12).solve(),
    "entry landing, Radau 4 x 10 (bang-bang thrust, clipped between nodes)": lambda: Radau(
        entry_landing(), 4, 10
    ).solve(),
    "hang glider, HLGL 50 (free t_f)": lambda: HLGL(hang_glider(), 50).solve(),
}


@pytest.mark.parametrize("name", list(CASES))
def test_the_flown_cost_and_state_agree_with_dop853(name):
    sol = quiet(CASES[name])
    xf, running, objective = dop853_flight(sol)
    flight = fly(sol)
    scale = sol.problem.state_scale
    assert np.abs((flight.final_state - xf) / scale).max() < 1e-9
    assert flight.objective == pytest.approx(objective, rel=1e-10, abs=1e-12)
    assert flight.running_cost == pytest.approx(running, rel=1e-10, abs=1e-12)


def periodic_angle_problem():
    """Steer a unit speed in a plane by its heading (a periodic control in (-pi, pi]) from the origin to (0, 1)
    while turning through the cut at pi: u's nodes straddle the cut, the interpolant must take the short way."""
    return OptimalControlProblem(
        "heading",
        states=[State("x", initial=0.0), State("y", initial=0.0)],
        controls=[Control("heading", -np.pi, np.pi, period=2 * np.pi)],
        dynamics=lambda x, u, t: ca.vertcat(ca.cos(u[0]), ca.sin(u[0])),
        tf=1.0,
        mayer=lambda x0, xf, t0, tf: (xf[0] + 0.9) ** 2 + (xf[1] + 0.05) ** 2,
        lagrange=lambda x, u, t: 0.1 * (1 - ca.cos(u[0] - 0.9 * np.pi)),
    )


def test_a_periodic_control_is_flown_as_the_solution_defines_it():
    sol = quiet(lambda: Radau(periodic_angle_problem(), 5, 4).solve())
    _, _, objective = dop853_flight(sol)
    assert fly(sol).objective == pytest.approx(objective, rel=1e-10)


def test_a_control_mesh_finer_than_the_state_mesh_is_flown_piece_by_piece():
    from compendium.problems import lunar_ascent

    sol = quiet(lambda: MultiRateHLGL(lunar_ascent(), 4, ratio=2, fast=["V"], control_mesh="fine",
                                      coupling="galerkin").solve())  # fmt: skip
    assert sol.control_breakpoints.size > sol.breakpoints.size
    xf, _, objective = dop853_flight(sol)
    flight = fly(sol)
    assert np.abs((flight.final_state - xf) / sol.problem.state_scale).max() < 1e-9
    assert flight.objective == pytest.approx(objective, rel=1e-10)


def test_a_flight_that_fails_raises_a_runtime_error_naming_the_integrator():
    # x' = x^2 from x(0) = 1 blows up at t = 1: the flight over [0, 2] cannot finish
    problem = OptimalControlProblem(
        "blow_up",
        states=[State("x", initial=1.0)],
        controls=[Control("u", -1.0, 1.0)],
        dynamics=lambda x, u, t: x[0] ** 2 + 0 * u[0],
        tf=2.0,
        lagrange=lambda x, u, t: u[0] ** 2,
    )
    sol = quiet(lambda: HLGL(problem, 4).solve(raise_on_failure=False))
    with pytest.raises(RuntimeError, match="flying the control failed"):
        fly(sol)


def test_the_integrator_is_built_once_per_problem_and_shared_by_its_copies():
    problem = hyper_sensitive(20.0)
    sol = quiet(lambda: Radau(problem, 4, 4).solve())
    fly(sol)
    built = dict(problem.functions.derived)
    copy = problem.replace(name="again")
    assert copy.functions is problem.functions
    fly(quiet(lambda: Radau(copy, 4, 6).solve()))
    assert {k: v for k, v in problem.functions.derived.items() if k in built} == built


def test_parameters_a_later_start_and_a_mayer_term_of_both_ends_are_flown_as_stated():
    from ocpkit import FreeParameter

    problem = OptimalControlProblem(
        "later",
        states=[State("x", initial=1.0), State("v", initial=0.0)],
        controls=[Control("u", -2.0, 2.0)],
        dynamics=lambda x, u, t, p: ca.vertcat(x[1], p["k"] * u[0] - p["c"] * x[0]),
        t0=1.0,
        tf=3.0,
        mayer=lambda x0, xf, t0, tf, p: (xf[0] - 0.5) ** 2 + 0.1 * x0[0] * tf,
        lagrange=lambda x, u, t, p: (t - 1.0) * u[0] ** 2,
        parameters={"k": 1.5},
        free_parameters=[FreeParameter("c", 0.5, 2.0, guess=1.0)],
    )
    sol = quiet(lambda: HLGL(problem, 6).solve())
    assert sol.t0 == 1.0 and "c" in sol.problem.parameters
    xf, running, objective = dop853_flight(sol)
    flight = fly(sol)
    assert np.abs(flight.final_state - xf).max() < 1e-9
    assert flight.running_cost == pytest.approx(running, rel=1e-9, abs=1e-10)  # CVODES: 1e-12 of max(1, |J|) a step
    assert flight.objective == pytest.approx(objective, rel=1e-10)


def test_a_problem_without_controls_is_flown():
    problem = OptimalControlProblem(
        "free_fall",
        states=[State("h", initial=10.0), State("v", initial=0.0)],
        controls=[],
        dynamics=lambda x, u, t: ca.vertcat(x[1], -9.81 - 0.1 * x[1]),
        tf=1.0,
        lagrange=lambda x, u, t: x[0],
    )
    sol = quiet(lambda: Radau(problem, 5, 3).solve())
    xf, running, objective = dop853_flight(sol)
    assert fly(sol).objective == pytest.approx(objective, rel=1e-10)


def test_a_periodic_control_with_bounds_narrower_than_its_period_is_only_clipped():
    problem = periodic_angle_problem().replace(controls=[Control("heading", -1.0, 1.0, period=2 * np.pi)])
    sol = quiet(lambda: Radau(problem, 5, 4).solve())
    assert np.isclose(sol.control(sol.time_grid(401)), 1.0).any(), "the control reaches its bound"
    _, _, objective = dop853_flight(sol)
    # clipped where the polynomial crosses the bound inside an interval: a kink both integrators step through
    assert fly(sol).objective == pytest.approx(objective, rel=1e-8)
