"""The problem definition (ocpkit.problem): one set of functions, immutability, and clear errors for bad input."""

import math

import casadi as ca
import numpy as np
import pytest

from ocpkit import HLGL, Control, FreeFinalTime, Guess, OptimalControlProblem, Radau, State
from ocpkit.problem import fixed_value, guess_function


def rest_to_rest(dynamics=None, **kw):
    return OptimalControlProblem(
        "rest_to_rest",
        [State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        [Control("u", -1.0, 1.0)],
        dynamics or (lambda x, u, t: ca.vertcat(x[1], u[0])),
        tf=FreeFinalTime(0.5, 5.0, 1.0),
        mayer=lambda x0, xf, t0, tf: tf,
        **kw,
    )


def test_functions_are_built_once_and_shared_by_parameter_copies():
    calls = []

    def dynamics(x, u, t, P):
        calls.append(1)
        return ca.vertcat(x[1], P["k"] * u[0])

    pr = OptimalControlProblem(
        "k",
        [State("x", initial=0.0), State("v", initial=0.0)],
        [Control("u", -1, 1)],
        dynamics,
        tf=1.0,
        lagrange=lambda x, u, t, P: u[0] ** 2,
        parameters={"k": 2.0},
    )
    other = pr.replace(parameters={"k": 3.0})
    assert len(calls) == 1, "the dynamics callable runs once; a parameter copy reuses the functions"
    assert other.functions is pr.functions
    assert float(pr.dynamics([0, 0], [1.0], 0)[1]) == 2.0 and float(other.dynamics([0, 0], [1.0], 0)[1]) == 3.0
    assert np.allclose(other.parameter_vector({"k": 5.0}), [5.0])
    renamed = pr.replace(tf=2.0)
    assert renamed.functions is not pr.functions and len(calls) == 2
    assert pr.functions.hamiltonian is pr.functions.hamiltonian, "H is assembled once per set of functions"


def test_problem_is_immutable():
    pr = rest_to_rest()
    with pytest.raises(AttributeError, match="immutable"):
        pr.tf = 3.0


@pytest.mark.parametrize(
    "dynamics, message",
    [
        (lambda x, u, t: ca.vertcat(x[1], math.cos(u[0])), "math or numpy function"),
        (lambda x, u, t: np.array([x[1], u[0]]), "numpy array"),
    ],
)
def test_dynamics_that_would_be_nan_are_rejected(dynamics, message):
    with pytest.raises((TypeError, ValueError), match=message):
        rest_to_rest(dynamics)


@pytest.mark.parametrize("tf", [float("nan"), float("inf")])
def test_non_finite_times_are_rejected(tf):
    with pytest.raises(ValueError, match="tf must be a finite number"):
        OptimalControlProblem(
            "t",
            [State("x", initial=0.0)],
            [Control("u", -1, 1)],
            lambda x, u, t: u,
            tf=tf,
            mayer=lambda x0, xf, t0, t1: xf[0],
        )
    with pytest.raises(ValueError, match="t0 must be a finite number"):
        OptimalControlProblem(
            "t",
            [State("x", initial=0.0)],
            [Control("u", -1, 1)],
            lambda x, u, t: u,
            t0=float("nan"),
            tf=1.0,
            mayer=lambda x0, xf, t0, t1: xf[0],
        )


def test_a_list_boundary_condition_is_ambiguous():
    with pytest.raises(TypeError, match="ambiguous"):
        State("x", initial=[0, 10])
    assert State("x", initial=(0, 10)).boundary_interval("initial") == (0.0, 10.0)
    assert fixed_value((2.0, 2.0)) == 2.0 and fixed_value((0.0, 1.0)) is None and fixed_value(None) is None


def test_guesses_are_parsed_by_one_function():
    with pytest.raises(ValueError, match="expected a value or"):
        State("x", guess=(0, 1, 2))
    g = guess_function((1.0, 3.0), "g")
    assert np.allclose(g(np.array([0.0, 0.5, 1.0]), None), [1.0, 2.0, 3.0])
    pr = rest_to_rest()
    tf, xs, us = Guess(tf=2.0, states={"v": lambda t: t}, controls={"u": 0.5}).functions(pr)
    t = np.array([0.0, 1.0, 2.0])
    assert np.allclose(xs(t), [[0, 0], [0.5, 1.0], [1.0, 2.0]])  # x: linear 0 -> 1 from its conditions
    assert np.allclose(us(t), 0.5)
    with pytest.raises(ValueError, match="returned shape"):
        Guess(states={"v": lambda t: 1.0}).functions(pr)[1](t)


def test_mesh_errors_name_the_argument():
    pr = rest_to_rest()
    with pytest.raises(ValueError, match="intervals must be at least 1"):
        Radau(pr, 4, intervals=0)
    with pytest.raises(ValueError, match="intervals must be at least 1"):
        HLGL(pr, 0)
