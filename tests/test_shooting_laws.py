"""Control laws of the user's and minimum time as a Mayer term, in the shooting engine (ocpkit.shooting).

Each against an exact answer: the brachistochrone's cycloid, the minimum-energy and the
minimum-time double integrators.
"""

import math

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import brentq

from ocpkit import Control, FreeFinalTime, OptimalControlProblem, State
from ocpkit.shooting import Shooting, control_law

G, XF, YF = 9.81, 1.0, 0.6  # gravity; the end point, y downward


def brachistochrone(form: str) -> OptimalControlProblem:
    """``(x, y, v)' = (v cos u, v sin u, g sin u)`` from rest at the origin to (XF, YF), v(tf) free, min tf.

    ``form``: ``"mayer"`` (phi = tf, no running cost) or ``"lagrange"`` (L = 1).
    """
    cost = {"mayer": lambda x0, xf, t0, tf: tf} if form == "mayer" else {"lagrange": lambda x, u, t: 1}
    return OptimalControlProblem(
        f"brachistochrone_{form}",
        [State("x", initial=0.0, final=XF), State("y", initial=0.0, final=YF), State("v", initial=0.0)],
        [Control("u")],
        lambda x, u, t: ca.vertcat(x[2] * ca.cos(u[0]), x[2] * ca.sin(u[0]), G * ca.sin(u[0])),
        tf=FreeFinalTime(0.1, 10.0, 0.5),
        **cost,
    )


def brachistochrone_law(x, p):
    """H = p_x v cos u + (p_y v + g p_v) sin u (+ 1) = A cos u + B sin u is least at (cos u, sin u) = -(A, B)/|(A, B)|."""
    return ca.atan2(-(x[2] * p[1] + G * p[2]), -x[2] * p[0])


def cycloid():
    """The exact solution: x = R (th - sin th), y = R (1 - cos th), th = t sqrt(g / R), u = pi/2 - th/2.

    Costates (normal, H = -1 with the Mayer term tf, H = 0 with L = 1): p_x = -cos(u)/v = -1/(2 sqrt(g R)),
    p_y = -sin(u_f)/v_f from p_v(tf) = 0, and p_v(0) = -1/g from H(0) = g p_v sin u = -1 at v = 0.
    """
    th = brentq(lambda t: (1 - math.cos(t)) / (t - math.sin(t)) - YF / XF, 1e-6, 2 * math.pi - 1e-9)
    R = YF / (1 - math.cos(th))
    root = math.sqrt(G * R)
    p0 = np.array([-1 / (2 * root), -1 / (math.tan(th / 2) * 2 * root), -1 / G])
    return th, R, th * math.sqrt(R / G), p0


@pytest.fixture(scope="module")
def brachistochrone_runs():
    runs = {}
    for form in ("mayer", "lagrange"):
        pr = brachistochrone(form)
        shooting = Shooting(pr, control_law(pr, brachistochrone_law), rtol=1e-12, atol=1e-12)
        runs[form] = shooting, shooting.solve([-0.3, -0.3, -0.1, pr.tf_guess])
    return runs


def test_brachistochrone_minimum_time_as_a_mayer_term_is_the_cycloid(brachistochrone_runs):
    th, R, tf, p0 = cycloid()
    _, r = brachistochrone_runs["mayer"]
    assert r.converged and r.norm < 1e-12
    assert abs(r.tf - tf) < 1e-8  # exact tf = 0.56614317799606
    assert np.abs(r.p0 - p0).max() < 1e-8
    assert r.objective == pytest.approx(tf, abs=1e-8)  # the cost is tf itself
    # H = p'f = -d(phi)/d(tf) = -1 along the whole (autonomous) flow
    assert np.abs(r.integration.hamiltonian + 1).max() < 1e-9
    t = np.linspace(0, r.tf, 41)
    theta = t * math.sqrt(G / R)
    tr = r.trajectory
    exact_state = np.column_stack(
        [R * (theta - np.sin(theta)), R * (1 - np.cos(theta)), np.sqrt(2 * G * R * (1 - np.cos(theta)))]
    )
    assert np.abs(tr.state(t) - exact_state).max() < 1e-7  # cubic Hermite between the integrator's steps
    assert np.abs(tr.control(t)[:, 0] - (math.pi / 2 - theta / 2)).max() < 1e-8


def test_brachistochrone_with_lagrange_one_gives_the_same_extremal(brachistochrone_runs):
    """L = 1 (H(tf) = 0) and phi = tf (H(tf) + 1 = 0): the same costates, final time and cost."""
    _, mayer = brachistochrone_runs["mayer"]
    _, lagrange = brachistochrone_runs["lagrange"]
    assert lagrange.converged
    assert abs(lagrange.tf - mayer.tf) < 1e-10
    assert np.abs(lagrange.p0 - mayer.p0).max() < 1e-10
    assert lagrange.objective == pytest.approx(mayer.objective, abs=1e-10)
    assert np.abs(lagrange.integration.hamiltonian).max() < 1e-9


def test_a_law_of_the_users_is_one_smooth_mode(brachistochrone_runs):
    shooting, r = brachistochrone_runs["mayer"]
    law = shooting.law
    assert (law.n_modes, law.n_switching, law.control_set) == (1, 0, "user")
    assert "brachistochrone_law" in law.description
    assert r.integration.switchings == 0
    pr = shooting.problem
    # the switching treatments have nothing to treat: the same shooting function
    plain = Shooting(pr, law, switching="none", rtol=1e-12, atol=1e-12, system=shooting.compiled)
    assert np.abs(plain.residual(r.z) - shooting.residual(r.z)).max() < 1e-14


def double_integrator_energy(lower=-math.inf, upper=math.inf, *, parameters=False):
    """min int u^2/2 with x'' = k u from (1, 0) to (0, 0) in tf = 1: u = -6 + 12 t, J = 6, p(0) = (12, 6) for k = 1."""
    if parameters:
        kw = {
            "dynamics": lambda x, u, t, P: ca.vertcat(x[1], P["k"] * u[0]),
            "lagrange": lambda x, u, t, P: u[0] ** 2 / 2,
            "parameters": {"k": 1.0},
        }
    else:
        kw = {"dynamics": lambda x, u, t: ca.vertcat(x[1], u[0]), "lagrange": lambda x, u, t: u[0] ** 2 / 2}
    return OptimalControlProblem(
        "energy",
        [State("x", initial=1.0, final=0.0), State("v", initial=0.0, final=0.0)],
        [Control("u", lower, upper)],
        tf=1.0,
        **kw,
    )


def test_minimum_energy_with_a_law_of_the_users_equals_the_derived_law():
    pr = double_integrator_energy()

    def energy_law(x, p):
        return -p[1]  # dH/du = u + p_v = 0

    derived_unbounded = control_law(pr, "box", regularized=True)  # no saturation on an unbounded control
    derived_inactive = control_law(double_integrator_energy(-20.0, 20.0), "box", regularized=True)
    results = {}
    for name, law in [
        ("user", control_law(pr, energy_law)),
        ("derived", derived_unbounded),
        ("bounded", derived_inactive),
    ]:
        r = Shooting(pr, law, rtol=1e-12, atol=1e-12).solve([1.0, 1.0])
        assert r.converged
        results[name] = r
        assert r.objective == pytest.approx(6.0, abs=1e-10)
        assert np.abs(r.p0 - [12.0, 6.0]).max() < 1e-10
    assert abs(results["user"].objective - results["derived"].objective) < 1e-12
    assert np.abs(results["user"].p0 - results["bounded"].p0).max() < 1e-12
    t = np.linspace(0, 1, 11)
    assert np.abs(results["user"].trajectory.control(t)[:, 0] - (-6 + 12 * t)).max() < 1e-9


def test_a_law_receives_the_named_parameters_as_the_dynamics_do():
    pr = double_integrator_energy(parameters=True)

    def law_with_gain(x, p, params):
        return -params["k"] * p[1]

    r = Shooting(pr, control_law(pr, law_with_gain), rtol=1e-12, atol=1e-12).solve([1.0, 1.0])
    assert r.objective == pytest.approx(6.0, abs=1e-10)
    # k = 2: x'' = 2 u, u = -p_v k; the same motion with u halved, J = 6 / 4
    r2 = Shooting(pr.replace(parameters={"k": 2.0}), control_law(pr, law_with_gain), rtol=1e-12, atol=1e-12)
    assert r2.solve([1.0, 1.0]).objective == pytest.approx(1.5, abs=1e-10)


def test_minimum_time_bang_bang_as_a_mayer_term():
    """x'' = u, |u| <= 1, (1, 0) to (0, 0), phi = tf: u = -1 then +1, switching at 1, tf = 2, p(0) = (1, 1)."""
    pr = OptimalControlProblem(
        "min_time",
        [State("x", initial=1.0, final=0.0), State("v", initial=0.0, final=0.0)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=FreeFinalTime(0.5, 10.0, 2.5),
        mayer=lambda x0, xf, t0, tf: tf,
    )
    r = Shooting(pr, control_law(pr, "box"), rtol=1e-12, atol=1e-12).solve([0.9, 1.1, 2.3])
    assert abs(r.tf - 2.0) < 1e-10
    assert np.abs(r.p0 - [1.0, 1.0]).max() < 1e-10
    assert np.allclose(r.integration.switching_times, [1.0], atol=1e-10)


# -- bad input -----------------------------------------------------------------------------------


@pytest.mark.parametrize("form", ["mayer", "lagrange"])
def test_a_hamiltonian_not_of_the_derived_form_asks_for_a_law(form):
    """Once 'needs a Lagrange cost' (Mayer) or 'needs finite bounds around 0' (L = 1): bounds were not the issue."""
    pr = brachistochrone(form)
    for kind in ("box", "ball"):
        with pytest.raises(
            ValueError, match=r"a control law is needed: .*not of the form.*control_law\(problem, u_star\)"
        ):
            control_law(pr, kind)
    with pytest.raises(ValueError, match="u is unbounded"):
        control_law(pr, "box")


def test_unbounded_controls_of_the_derived_laws():
    l1 = OptimalControlProblem(
        "l1",
        [State("x", initial=0.0, final=1.0)],
        [Control("u")],
        lambda x, u, t: u[0],
        tf=1.0,
        lagrange=lambda x, u, t: ca.fabs(u[0]),
    )
    with pytest.raises(ValueError, match="'u' is unbounded .* H is affine in it .* no minimum"):
        control_law(l1, "box")
    with pytest.raises(ValueError, match="'u' is unbounded .* not positive"):
        control_law(l1, "box", regularized=True)
    with pytest.raises(ValueError, match="quadratic control term"):
        control_law(double_integrator_energy(), "box")


def test_bad_laws_are_named():
    pr = brachistochrone("mayer")

    def two_controls(x, p):
        return ca.vertcat(-p[0], -p[1])

    def math_law(x, p):
        return math.atan2(p[1], p[0])

    def math_inside(x, p):
        return x[2] * math.cos(p[0])

    def numpy_law(x, p):
        return np.array([p[0]])

    def foreign(x, p):
        return ca.SX.sym("w") * p[0]

    with pytest.raises(ValueError, match=r"control law 'two_controls' returned shape \(2, 1\), expected \(1, 1\)"):
        control_law(pr, two_controls)
    with pytest.raises(ValueError, match="control law 'math_law' returned NaN.*ca.cos"):
        control_law(pr, math_law)
    with pytest.raises(ValueError, match="control law 'math_inside' is not finite.*CasADi's"):
        control_law(pr, math_inside)
    with pytest.raises(TypeError, match="control law 'numpy_law' returned a numpy array"):
        control_law(pr, numpy_law)
    with pytest.raises(ValueError, match="control law 'foreign' depends on symbols other than"):
        control_law(pr, foreign)
    # a law may take the parameters whatever the problem has (ocpkit.names); a name the problem lacks is named
    with pytest.raises(KeyError, match=r"control law '<lambda>': unknown parameter 'k'; the parameters are \[\]"):
        control_law(pr, lambda x, p, params: params["k"] * p[0])
    with pytest.raises(TypeError, match=r"control law '<lambda>' needs 4 arguments; it is given 2, or 3 with"):
        control_law(pr, lambda x, p, params, extra: p[0])
    with pytest.raises(ValueError, match="not to a law of your own"):
        control_law(pr, brachistochrone_law, regularized=True)
    with pytest.raises(ValueError, match="or a control law u_star"):
        control_law(pr, "sphere")
