"""The second-order check of a certificate (ocpkit.second_order): the Jacobi test against a problem with a known
conjugate point (it must fail there) and without one, the convexity route, and where neither applies."""

import math

import casadi as ca
import numpy as np
import pytest

from ocpkit import Control, FreeFinalTime, OptimalControlProblem, Radau, State
from ocpkit.indirect import certify, to_extremal
from ocpkit.second_order import second_order
from ocpkit.shooting.arcs import ArcShooting, ArcType
from ocpkit.structure import control_structure

from compendium.problems import catalyst_mixing, rayleigh


def harmonic(horizon: float) -> OptimalControlProblem:
    """min 1/2 int (u^2 - x^2), x' = u, x(0) = x(T) = 0: the extremal x = 0 has the Jacobi field sin(T - t), so a
    conjugate point at T - pi where T > pi (a minimum for T < pi; the cost is unbounded below for T > pi)."""
    return OptimalControlProblem(
        "harmonic",
        [State("x", initial=0.0, final=0.0)],
        [Control("u")],
        lambda x, u, t: [u["u"]],
        tf=horizon,
        lagrange=lambda x, u, t: (u["u"] ** 2 - x["x"] ** 2) / 2,
    )


def zero_extremal(horizon: float):
    shooting = ArcShooting(harmonic(horizon), [(ArcType(("regular",)), 0.0, horizon)])
    return shooting.solve(np.zeros(shooting.nz))


@pytest.mark.parametrize("horizon", [3.5, 4.0, 6.0])
def test_a_known_conjugate_point_fails_the_certificate(horizon):
    result = zero_extremal(horizon)
    verdict = second_order(result.trajectory, control_structure(result.trajectory))
    assert verdict.verdict == "failed" and verdict.route == "jacobi"
    assert verdict.conjugate == pytest.approx(horizon - math.pi, abs=1e-4)
    certificate = certify(result.trajectory, result)
    assert certificate.failed == ["second_order"] and "conjugate point at t = " in certificate["second_order"].meaning


@pytest.mark.parametrize("horizon", [1.0, 3.0])
def test_without_a_conjugate_point_it_passes(horizon):
    result = zero_extremal(horizon)
    certificate = certify(result.trajectory, result)
    assert certificate.passed and certificate.second_order.verdict == "passed"
    assert certificate.second_order.route == "jacobi" and certificate.second_order.conjugate is None


def test_rayleigh_passes_the_jacobi_test_and_a_convex_problem_the_convexity_route():
    extremal = to_extremal(Radau(rayleigh(), 4, 20).solve(mesh_tolerance=1e-6))
    assert extremal.certificate.second_order.route == "jacobi" and extremal.certificate.second_order.passed
    turnpike = OptimalControlProblem(  # bang-singular-bang, but convex: the extremal is a global minimum
        "turnpike",
        [State("x", initial=1.0, final=0.5)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t: [u["u"]],
        tf=2.0,
        lagrange=lambda x, u, t: x["x"] ** 2,
    )
    extremal = to_extremal(Radau(turnpike, 4, 20).solve(mesh_tolerance=1e-7))
    assert extremal.objective == pytest.approx(3 / 8, abs=1e-9)
    assert np.asarray(extremal.trajectory.breakpoints[1:-1]) == pytest.approx([1.0, 1.5], abs=1e-9)
    assert extremal.certificate.second_order.route == "convexity" and extremal.certificate.second_order.passed


def test_where_neither_route_applies_it_says_why():
    extremal = to_extremal(Radau(catalyst_mixing(), 4, 30).solve(error_threshold=None))
    verdict = extremal.certificate.second_order
    assert verdict.verdict == "not applicable"
    assert verdict.detail.startswith(
        "not convex (the dynamics are not affine in (x, u)), and control 'u' has an upper arc"
    )
    assert "n/a  second_order" in extremal.certificate.describe()
    free = harmonic(2.0).replace(tf=FreeFinalTime(1.0, 3.0, 2.0))
    result = zero_extremal(2.0)
    result.trajectory.problem = free
    assert (
        "a free initial or final time" in second_order(result.trajectory, control_structure(result.trajectory)).detail
    )


def test_a_concave_kink_is_not_taken_for_convexity():
    """-|u| has a zero Hessian wherever it has one: the midpoint inequality catches it."""
    from ocpkit.second_order import not_convex

    kinked = OptimalControlProblem(
        "kinked",
        [State("x", initial=0.0, final=0.0)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t: [u["u"]],
        tf=1.0,
        lagrange=lambda x, u, t: x["x"] ** 2 - ca.fabs(u["u"]),
    )
    result = zero_extremal(1.0)
    result.trajectory.problem = kinked
    assert not_convex(kinked, result.trajectory) == "the running cost is not convex (the midpoint inequality fails)"


def test_units_and_long_horizons_do_not_make_a_minimum_fail():
    """The Jacobi fields are orthonormalised as they are integrated and dX's rows scaled: a slow control (x' = 1e-3
    u) and a long horizon with a stiff weight (the fields' columns would all align with the fastest mode) pass."""
    slow = OptimalControlProblem(
        "slow",
        [State("x1", initial=0.0, final=0.0), State("x2", initial=0.0, final=0.0)],
        [Control("u1"), Control("u2")],
        lambda x, u, t: [1e-3 * u[0] + x[0] ** 3, 1e-3 * u[1]],
        tf=1.0,
        lagrange=lambda x, u, t: (u[0] ** 2 + u[1] ** 2) / 2,
    )
    rotation = np.array([[math.cos(0.5), -math.sin(0.5)], [math.sin(0.5), math.cos(0.5)]])
    Q = rotation @ np.diag([1.0, 100.0]) @ rotation.T
    stiff = OptimalControlProblem(
        "stiff",
        [State("x1", initial=0.0, final=0.0), State("x2", initial=0.0, final=0.0)],
        [Control("u1"), Control("u2")],
        lambda x, u, t: [u[0] + x[0] ** 3, u[1]],
        tf=15.0,
        lagrange=lambda x, u, t: (
            (Q[0, 0] * x[0] ** 2 + 2 * Q[0, 1] * x[0] * x[1] + Q[1, 1] * x[1] ** 2 + u[0] ** 2 + u[1] ** 2) / 2
        ),
    )
    for problem in (slow, stiff):
        shooting = ArcShooting(problem, [(ArcType(("regular", "regular")), 0.0, float(problem.tf))])
        result = shooting.solve(np.zeros(shooting.nz))
        verdict = second_order(result.trajectory, control_structure(result.trajectory))
        assert verdict.verdict == "passed" and verdict.route == "jacobi", problem.name


def test_a_singular_h_uu_is_not_a_failure_and_a_problem_without_controls_is_named():
    """H_uu = 2 (1 - t) vanishes at t_f: the strengthened condition does not hold, which is no proof of a
    non-minimum (x = u = 0 is the global minimum); a problem without controls has no variation to test."""
    weighted = OptimalControlProblem(
        "weighted",
        [State("x", initial=0.0, final=0.0)],
        [Control("u")],
        lambda x, u, t: [u["u"] + x["x"] ** 3],
        tf=1.0,
        lagrange=lambda x, u, t: (1 - t) * u["u"] ** 2 + x["x"] ** 2,
    )
    shooting = ArcShooting(weighted, [(ArcType(("regular",)), 0.0, 1.0)])
    result = shooting.solve(np.zeros(shooting.nz))
    certificate = certify(result.trajectory, result)
    assert certificate.passed and certificate.second_order.verdict == "not applicable"
    assert "H_uu is singular at t = 1" in certificate.second_order.detail
    still = OptimalControlProblem(
        "still", [State("x", initial=1.0)], [], lambda x, u, t: [-x["x"]], tf=1.0, lagrange=lambda x, u, t: x["x"] ** 2
    )
    direct = Radau(still, 4, 5).solve(error_threshold=None)
    with pytest.raises(ValueError, match="'still' has no control: to_extremal solves the maximum principle"):
        to_extremal(direct)
