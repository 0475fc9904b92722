"""Names in the problem statement (ocpkit.names): callables see variables by name, one signature whatever the
parameters, and any expression of x, u, t, p is sampled on a solution."""

import casadi as ca
import numpy as np
import pytest

from ocpkit import HLGL, Control, FreeParameter, OptimalControlProblem, Program, Radau, State
from ocpkit.shooting import control_law


def double_integrator(dynamics, lagrange, **extra):
    """min int L of x'' = u from (0, 0) to (1, 0) in t = 1 (u = 6 - 12 t, J = 6 for L = u^2 / 2)."""
    return OptimalControlProblem(
        "di",
        states=[State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        controls=[Control("u")],
        dynamics=dynamics,
        tf=1.0,
        lagrange=lagrange,
        **extra,
    )


def test_callables_see_states_and_controls_by_name():
    named = double_integrator(lambda x, u, t: [x["v"], u["u"]], lambda x, u, t: u["u"] ** 2 / 2)
    positional = double_integrator(lambda x, u, t: ca.vertcat(x[1], u[0]), lambda x, u, t: u[0] ** 2 / 2)
    a, b = HLGL(named, 6).solve(), HLGL(positional, 6).solve()
    assert a.objective == pytest.approx(6.0, rel=1e-10) and np.array_equal(a.nlp_result.w, b.nlp_result.w)


def test_an_unknown_name_is_named_with_the_callable():
    with pytest.raises(KeyError, match=r"dynamics: unknown state 'speed'; the states are \['x', 'v'\]"):
        double_integrator(lambda x, u, t: [x["speed"], u["u"]], None)
    with pytest.raises(KeyError, match=r"lagrange: unknown control 'w'; the controls are \['u'\]"):
        double_integrator(lambda x, u, t: [x["v"], u["u"]], lambda x, u, t: u["w"] ** 2)
    with pytest.raises(KeyError, match=r"lagrange: unknown parameter 'k'; the parameters are \[\]"):
        double_integrator(lambda x, u, t: [x["v"], u["u"]], lambda x, u, t, p: p["k"] * u["u"] ** 2)


def test_one_signature_whatever_the_parameters():
    """Adding a parameter used by one callable leaves the others as they were written (it used to be a TypeError
    in every three-argument lambda); a callable asking for p in a problem without parameters gets an empty p."""
    gain = [FreeParameter("k", 0.5, 4.0, guess=1.0)]
    problem = double_integrator(
        lambda x, u, t, p: [x["v"], p["k"] * u["u"]],
        lambda x, u, t: u["u"] ** 2 / 2 + 0.0 * t,
        free_parameters=gain,
        mayer=lambda x0, xf, t0, tf, p: (p["k"] - 2.0) ** 2,
    )
    sol = Radau(problem, 4, 4).solve()
    # J(k) = 6 / k^2 + (k - 2)^2 is least where 12 / k^3 = 2 (k - 2)
    k = sol.parameters["k"]
    assert 12 / k**3 == pytest.approx(2 * (k - 2), rel=1e-6) and sol.value("k") == k
    plain = double_integrator(lambda x, u, t, p: [x["v"], u["u"]], lambda x, u, t: u["u"] ** 2 / 2)
    assert HLGL(plain, 4).solve().objective == pytest.approx(6.0, rel=1e-10)
    with pytest.raises(
        TypeError, match=r"lagrange needs 5 arguments; it is given 3 \(x, u, t\), or 4 with the parameters p"
    ):
        double_integrator(lambda x, u, t: [x["v"], u["u"]], lambda x, u, t, p, q: u["u"] ** 2)


def test_sample_and_value_any_expression_of_a_solution():
    sol = HLGL(double_integrator(lambda x, u, t: [x["v"], u["u"]], lambda x, u, t: u["u"] ** 2 / 2), 6).solve()
    t, power = sol.sample(lambda x, u, t: x["v"] * u["u"], grid=np.linspace(0, 1, 7))
    v, u = 6 * t - 6 * t**2, 6 - 12 * t
    assert power.shape == (7,) and np.allclose(power, v * u, atol=1e-9)
    t, both = sol.sample(lambda x, u, t: [x["x"], 2 * t])
    assert both.shape == (401, 2) and np.allclose(both[:, 1], 2 * t)
    assert sol.value(lambda x0, xf, t0, tf: xf["x"] - x0["x"]) == pytest.approx(1.0, abs=1e-12)
    assert sol.value("tf") == 1.0 and sol.value("objective") == sol.objective
    with pytest.raises(ValueError, match="'v' is a function of time"):
        sol.value("v")
    with pytest.raises(KeyError, match="sample's expression: unknown state 'h'"):
        sol.sample(lambda x, u, t: x["h"])
    with pytest.raises(ValueError, match=r"times must lie in \[t0, tf\]"):
        sol.sample(lambda x, u, t: x["x"], grid=[2.0])


def test_sample_across_phases():
    def leg(t0, tf, **ends):
        states = [State("x", **ends.get("x", {})), State("v", **ends.get("v", {}))]
        dyn = lambda x, u, t: [x["v"], u["u"]]  # noqa: E731
        return OptimalControlProblem(
            f"leg{t0}", states, [Control("u")], dyn, t0=t0, tf=tf, lagrange=lambda x, u, t: u["u"] ** 2 / 2
        )

    first = leg(0.0, 0.5, x={"initial": 0.0}, v={"initial": 0.0})
    sol = Program.from_phases([HLGL(first, 5), HLGL(leg(0.5, 1.0, x={"final": 1.0}, v={"final": 0.0}), 5)]).solve()
    t, u = sol.sample(lambda x, u, t: u["u"], grid=np.linspace(0, 1, 9))
    assert np.allclose(u, 6 - 12 * t, atol=1e-8)


def test_a_control_law_of_the_user_sees_names():
    """u* = -p_v / 2 for min int u^2 (energy-optimal double integrator), written with names."""
    problem = OptimalControlProblem(
        "di_free",
        states=[State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        controls=[Control("u")],
        dynamics=lambda x, u, t: [x["v"], u["u"]],
        tf=1.0,
        lagrange=lambda x, u, t: u["u"] ** 2,
    )
    law = control_law(problem, lambda x, p: -p["v"] / 2)
    ham = law.hamiltonian
    u = ca.Function("u", [ham.x, ham.p], [law.groups[0].controls[0]])
    assert float(u([0.3, 0.1], [5.0, -3.0])) == 1.5 and law.description.startswith("user law")
