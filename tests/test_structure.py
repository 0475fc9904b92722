"""The switching structure of a solution (ocpkit.structure): arcs and junction times against closed forms."""

import numpy as np
import pytest

from ocpkit import HLGL, Control, FreeFinalTime, OptimalControlProblem, Radau, State
from ocpkit.shooting import Shooting, control_law
from ocpkit.structure import control_structure

from compendium.problems import double_integrator, double_integrator_solution, goddard_rocket


def race():
    """Rest to rest over a unit distance in least time with |u| <= 1: full thrust to t = 1, full brake to t = 2."""
    return OptimalControlProblem(
        "race",
        [State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t: [x["v"], u["u"]],
        tf=FreeFinalTime(0.5, 5.0, 1.5),
        mayer=lambda x0, xf, t0, tf: tf,
    )


@pytest.mark.parametrize("make", [lambda p: Radau(p, 4, 15), lambda p: HLGL(p, 15)], ids=["radau", "hlgl"])
def test_a_bang_bang_switch_smeared_by_the_polynomial_is_a_junction_not_an_arc(make):
    """The switch at t = 1 falls inside a mesh interval, where the control polynomial crosses the range: a junction
    (within the direct solution's own error of 1), not a singular arc."""
    sol = make(race()).solve(error_threshold=None)
    s = control_structure(sol)
    assert s.kinds("u") == ["upper", "lower"]
    assert s.junctions("u") == pytest.approx([1.0], abs=1e-3) and abs(sol.tf - 2.0) < 1e-3


def test_bang_off_bang_junctions_from_the_switching_function():
    """The fuel-optimal double integrator (shooting): lower, zero, upper, the junctions where the switching function
    meets -+w, at the closed-form switching times to rounding."""
    pr = double_integrator(lam=1.0)
    exact = double_integrator_solution()
    trajectory = Shooting(pr, control_law(pr, "box")).solve(np.array(exact.p0)).trajectory
    s = control_structure(trajectory)
    assert s.kinds("u") == ["lower", "zero", "upper"]
    assert s.junctions("u") == pytest.approx([exact.t1, exact.t2], abs=1e-12)
    assert s.describe().startswith("u: lower on [0, 0.381966], zero on [0.381966, 2.61803]")


def test_the_goddard_rocket_has_a_singular_arc():
    """Full thrust, a singular arc, a coast (the COPS Goddard rocket), found alike on Radau's and HLGL's solutions."""
    g = goddard_rocket()
    radau = control_structure(Radau(g, 4, 40).solve(error_threshold=None))
    hlgl = control_structure(HLGL(g, 60).solve(error_threshold=None))
    assert radau.kinds("T") == hlgl.kinds("T") == ["upper", "singular", "lower"]
    assert radau.junctions("T") == pytest.approx(hlgl.junctions("T"), abs=2e-3)


def test_bad_input_is_named():
    sol = Radau(race(), 4, 4).solve(error_threshold=None)
    with pytest.raises(KeyError, match=r"unknown control 'w'; the controls are \['u'\]"):
        control_structure(sol).of("w")
    with pytest.raises(ValueError, match="min_share must lie in"):
        control_structure(sol, min_share=0.7)
    with pytest.raises(ValueError, match="samples must be at least 3"):
        control_structure(sol, samples=2)


def saturated():
    """Minimum energy with |u| <= 0.5 from (1, 0) to rest in 3 (J = 3/8 - sqrt(3)/12, the README's problem)."""
    return OptimalControlProblem(
        "saturated",
        [State("x", initial=1.0, final=0.0), State("v", initial=0.0, final=0.0)],
        [Control("u", -0.5, 0.5)],
        lambda x, u, t: [x["v"], u["u"]],
        tf=3.0,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
    )


def test_a_saturated_regular_control():
    """On the lower bound, regular (H_u = 0), on the upper bound, symmetric about t = 1.5 (the problem is)."""
    s = control_structure(Radau(saturated(), 4, 30).solve(error_threshold=None))
    assert s.kinds("u") == ["lower", "regular", "upper"]
    assert sum(s.junctions("u")) == pytest.approx(3.0, abs=1e-2)
