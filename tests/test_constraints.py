"""Path and boundary constraints in every direct transcription, against closed-form answers."""

import math

import casadi as ca
import numpy as np
import pytest

from ocpkit import HLGL, Constraint, Control, MultiRateHLGL, OptimalControlProblem, Radau, State

from compendium.problems import bryson_denham, bryson_denham_solution

L_MAX = 1.0 / 9.0  # Bryson-Denham: x <= l with l = 1/9 < 1/6, J = 4 / (9 l) = 4


def bryson_denham_exact(t):
    e = bryson_denham_solution(t, L_MAX)
    return e["x"], e["v"], e["u"], e["lambda_x"], e["lambda_v"]


SCHEMES = {
    "hlgl": lambda pr: HLGL(pr, intervals=30),
    "radau": lambda pr: Radau(pr, nodes=4, intervals=30),
    "multirate": lambda pr: MultiRateHLGL(pr, 15, ratio=2, fast=["v"]),
}


@pytest.mark.parametrize("scheme", SCHEMES)
def test_bryson_denham_state_constraint(scheme):
    sol = SCHEMES[scheme](bryson_denham()).solve()
    assert abs(sol.objective - 4.0) < 2e-3, sol.objective
    g = sol.constraint("x_max")
    assert g["values"].max() <= L_MAX + 1e-7  # IPOPT relaxes bounds by 1e-8 (bound_relax_factor)
    assert np.all(g["multipliers"] >= -1e-8), "x <= l: multipliers of an upper bound are non-negative"
    # the constraint holds on the boundary arc (1/3, 2/3) and is inactive elsewhere
    on_arc = (g["t"] > 0.36) & (g["t"] < 0.64)
    assert np.allclose(g["values"][on_arc], L_MAX, atol=1e-6)
    x, *_ = bryson_denham_exact(sol.state_times)
    assert np.max(np.abs(sol.state_values[:, 0] - x)) < 1e-4


def test_bryson_denham_radau_costates_and_multiplier():
    """Costate estimates stay right with an active path constraint; the multiplier is two atoms of mass 18."""
    sol = Radau(bryson_denham(), nodes=4, intervals=30).solve()
    # IPOPT relaxes the bound l by 1e-8 (bound_relax_factor) and dJ/dl = -4 / (9 l^2) = -36: J is 4 - 3.6e-7
    assert abs(sol.objective - 4.0) < 1e-6
    t = sol.costate_times
    _, _, _, lam_x, lam_v = bryson_denham_exact(t)
    away = (np.abs(t - 1 / 3) > 0.02) & (np.abs(t - 2 / 3) > 0.02)
    # x <= l is a state constraint of order 2: along the boundary arc the discrete multipliers of neighbouring
    # points are nearly interchangeable with lambda_x, which the estimate then carries to 1e-3 of 18 (measured
    # 1.0e-3 here, 2.7e-3 on 60 intervals: it does not converge to zero); lambda_v, the control's, to 5e-5
    assert np.max(np.abs(sol.costate_values[away, 0] - lam_x[away])) < 1e-2
    assert np.max(np.abs(sol.costate_values[away, 1] - lam_v[away])) < 1e-4
    g = sol.constraint("x_max")
    first, second = g["multipliers"][g["t"] < 0.5, 0].sum(), g["multipliers"][g["t"] > 0.5, 0].sum()
    assert first == pytest.approx(18.0, rel=1e-4) and second == pytest.approx(18.0, rel=1e-4)
    df = sol.path_dataframe()
    assert list(df.columns) == ["t", "x_max", "mu_x_max"] and len(df) == 4 * 30 + 1


def test_path_points_are_where_each_scheme_holds_states_and_controls():
    pr = bryson_denham()
    hlgl, radau, multi = (SCHEMES[k](pr) for k in ("hlgl", "radau", "multirate"))
    assert hlgl.n_path_points == 4 * 30 + 1  # t_i, t_a, t_c, t_b of each segment and the end
    assert radau.n_path_points == 4 * 30 + 1  # every collocation point and the end
    assert multi.n_path_points == 4 * 15 + 1  # every control point (the quartic's five per coarse segment)
    for tr in (hlgl, radau, multi):
        assert tr.n_constraints == tr.n_defects + tr.n_path_points
        assert np.all(np.diff(np.sort(tr.path_point_fractions())) > 0), "no point is constrained twice"


def minimum_energy_to_a_line():
    """From rest, min 1/2 int_0^1 u^2 with the event x(1) + v(1) = 1 (v(1) free): J = 1 / (2 int (2-s)^2) = 3/14."""
    return OptimalControlProblem(
        "to_a_line",
        states=[State("x", initial=0.0), State("v", initial=0.0)],
        controls=[Control("u")],
        dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=1.0,
        lagrange=lambda x, u, t: u[0] ** 2 / 2,
        boundary_constraints=[Constraint("line", lambda x0, xf, t0, tf: xf[0] + xf[1], lower=1.0, upper=1.0)],
    )


@pytest.mark.parametrize("scheme", ["hlgl", "radau", "multirate"])
def test_boundary_constraint_event_condition(scheme):
    make = {
        "hlgl": lambda pr: HLGL(pr, 10),
        "radau": lambda pr: Radau(pr, 6, 2),
        "multirate": lambda pr: MultiRateHLGL(pr, 5, ratio=2, fast=["v"]),
    }[scheme]
    sol = make(minimum_energy_to_a_line()).solve()
    assert sol.objective == pytest.approx(3 / 14, rel=1e-9)
    c = sol.constraint("line")
    assert c["values"][0] == pytest.approx(1.0, abs=1e-9)
    # d J / d (right-hand side) = the multiplier, in magnitude: J(c) = 3 c^2 / 14, so dJ/dc = 3/7 at c = 1
    assert abs(c["multipliers"][0]) == pytest.approx(3 / 7, rel=1e-6)


def test_mixed_state_control_constraint_holds_at_every_point():
    """u + v <= 0.35 on the double integrator (mixed; unconstrained, u + v starts at 0.45): every transcription
    honours it and they agree."""
    pr = OptimalControlProblem(
        "mixed",
        states=[State("x", initial=0.0, final=0.3), State("v", initial=0.0, final=0.0)],
        controls=[Control("u", lower=-10, upper=10)],
        dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=2.0,
        lagrange=lambda x, u, t: u[0] ** 2 / 2,
        path_constraints=[Constraint("mixed", lambda x, u, t: u[0] + x[1], upper=0.35, scale=0.5)],
    )
    free = HLGL(pr.replace(path_constraints=()), 20).solve()
    objectives = []
    for tr in (HLGL(pr, 20), Radau(pr, 5, 8)):
        sol = tr.solve()
        c = sol.constraint("mixed")
        assert c["values"].max() <= 0.35 + 1e-7
        assert c["multipliers"].max() > 1e-3, "the constraint is active somewhere"
        objectives.append(sol.objective)
    assert objectives[0] > free.objective + 1e-3, "the constraint costs something"
    assert objectives[0] == pytest.approx(objectives[1], rel=1e-3)


# -- bad input: each error names the constraint ------------------------------------------------------


def _with(constraint, kind="path_constraints"):
    return OptimalControlProblem(
        "p",
        states=[State("x", initial=0.0)],
        controls=[Control("u")],
        dynamics=lambda x, u, t: u[0],
        tf=1.0,
        lagrange=lambda x, u, t: u[0] ** 2,
        **{kind: [constraint]},
    )


def test_a_constraint_of_the_wrong_shape_is_named():
    with pytest.raises(ValueError, match="path constraint 'square' must return one or more scalar expressions"):
        _with(Constraint("square", lambda x, u, t: ca.SX.ones(2, 2), upper=1.0))


def test_bounds_that_cannot_hold_are_named():
    with pytest.raises(ValueError, match="constraint 'c': lower > upper"):
        _with(Constraint("c", lambda x, u, t: x[0], lower=2.0, upper=1.0))
    with pytest.raises(ValueError, match="constraint 'c': lower has 3 values for 1 expression"):
        _with(Constraint("c", lambda x, u, t: x[0], lower=[0, 0, 0]))
    with pytest.raises(ValueError, match="constraint 'c' has no finite bound"):
        _with(Constraint("c", lambda x, u, t: x[0]))


def test_numpy_and_math_functions_are_named():
    with pytest.raises((TypeError, ValueError), match="path constraint 'm'"):
        _with(Constraint("m", lambda x, u, t: math.sqrt(x[0]), upper=1.0))
    with pytest.raises((TypeError, ValueError), match="boundary constraint 'n'"):
        _with(Constraint("n", lambda x0, xf, t0, tf: np.array([xf[0]]), upper=1.0), "boundary_constraints")


def test_constraint_names_and_types_are_checked():
    with pytest.raises(ValueError, match="identifier"):
        Constraint("not a name", lambda x, u, t: x[0], upper=1.0)
    with pytest.raises(TypeError, match="must be Constraint objects"):
        _with(lambda x, u, t: x[0])
    c = Constraint("c", lambda x, u, t: x[0], upper=1.0)
    with pytest.raises(ValueError, match=r"duplicate constraint names in path_constraints: \['c'\]"):
        OptimalControlProblem(
            "p",
            states=[State("x")],
            controls=[],
            dynamics=lambda x, u, t: 0 * x[0],
            tf=1.0,
            lagrange=lambda x, u, t: x[0] ** 2,
            path_constraints=[c, c],
        )


def test_the_shooting_engine_refuses_constraints_it_does_not_treat():
    from ocpkit.shooting import Shooting, control_law

    pr = minimum_energy_to_a_line()
    with pytest.raises(ValueError, match=r"does not treat path or boundary constraints \(\['line'\]"):
        Shooting(pr, control_law(pr.replace(boundary_constraints=()), "box", regularized=True))


# -- free static parameters and a free initial time ---------------------------------------------------


def parameter_to_choose(make):
    """Rest to rest at x(1) = p (boundary constraint), p free: J = 6 p^2 + 12 (p - 1)^2, minimal at p = 2/3, J = 4."""
    from ocpkit import FreeParameter

    pr = OptimalControlProblem(
        "choose_p",
        states=[State("x", initial=0.0), State("v", initial=0.0, final=0.0)],
        controls=[Control("u")],
        dynamics=lambda x, u, t, P: ca.vertcat(x[1], u[0]),
        tf=1.0,
        lagrange=lambda x, u, t, P: u[0] ** 2 / 2,
        mayer=lambda x0, xf, t0, tf, P: 12 * (P["p"] - 1) ** 2,
        free_parameters=[FreeParameter("p", lower=-5.0, upper=5.0, guess=0.0)],
        boundary_constraints=[Constraint("reach", lambda x0, xf, t0, tf, P: xf[0] - P["p"], lower=0.0, upper=0.0)],
    )
    return make(pr)


@pytest.mark.parametrize("scheme", ["hlgl", "radau", "multirate"])
def test_a_free_parameter_is_optimised(scheme):
    make = {
        "hlgl": lambda pr: HLGL(pr, 8),
        "radau": lambda pr: Radau(pr, 5, 2),
        "multirate": lambda pr: MultiRateHLGL(pr, 4, ratio=2, fast=["v"]),
    }[scheme]
    tr = parameter_to_choose(make)
    sol = tr.solve()
    assert sol.objective == pytest.approx(4.0, rel=1e-9)
    assert sol.problem.parameters["p"] == pytest.approx(2 / 3, rel=1e-9)  # the solution's problem has p fixed
    assert sol.reintegrate().max_error < 1e-6
    assert tr.n_variables == tr.global_indices()[-1] + 1


def test_a_free_initial_time():
    """Rest to rest over distance 1 ending at tf = 2, t0 free: J = 6 / T^3 + 18 T with T = 2 - t0 is minimal at
    T = 1 (t0 = 1), J = 24."""
    from ocpkit import FreeInitialTime

    pr = OptimalControlProblem(
        "free_start",
        states=[State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        controls=[Control("u")],
        dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
        t0=FreeInitialTime(0.0, 1.5, 0.5),
        tf=2.0,
        lagrange=lambda x, u, t: u[0] ** 2 / 2,
        mayer=lambda x0, xf, t0, tf: 18 * (tf - t0),
    )
    for tr in (HLGL(pr, 6), Radau(pr, 6, 1)):
        sol = tr.solve()
        assert sol.t0 == pytest.approx(1.0, abs=1e-8) and sol.objective == pytest.approx(24.0, rel=1e-9)
        assert sol.state_times[0] == pytest.approx(1.0, abs=1e-8)
        # a solution is a guess on another mesh, at its own t0 (not the problem's guess of t0)
        again = HLGL(pr, 8).solve(sol)
        assert again.t0 == pytest.approx(1.0, abs=1e-8) and again.iterations <= sol.iterations
    refined = HLGL(pr, 2).solve(mesh_tolerance=1e-10)
    assert refined.state_error <= 1e-10 and refined.t0 == pytest.approx(1.0, abs=1e-8)


def test_free_times_and_parameters_are_checked():
    from ocpkit import FreeFinalTime, FreeInitialTime, FreeParameter

    def make(**kw):
        spec = dict(
            states=[State("x", initial=0.0)],
            controls=[Control("u")],
            dynamics=lambda x, u, t: u[0],
            tf=1.0,
            lagrange=lambda x, u, t: u[0] ** 2,
        )
        return OptimalControlProblem("p", **(spec | kw))

    with pytest.raises(ValueError, match=r"final time 1.0 must exceed t0 \(at most 1.5\)"):
        make(t0=FreeInitialTime(0.0, 1.5, 0.5))
    with pytest.raises(ValueError, match="initial time guess 2.0 lies outside"):
        FreeInitialTime(0.0, 1.0, 2.0)
    with pytest.raises(ValueError, match=r"parameter names used twice .*\['k'\]"):
        make(
            parameters={"k": 1.0},
            free_parameters=[FreeParameter("k", lower=0, upper=1)],
            dynamics=lambda x, u, t, P: u[0],
            lagrange=lambda x, u, t, P: u[0] ** 2,
        )
    with pytest.raises(ValueError, match="free parameter 'k': the guess must be a number"):
        FreeParameter("k", lower=0, upper=1, guess=(0, 1))
    with pytest.raises(TypeError, match="FreeInitialTime: give a FreeFinalTime"):
        make(tf=FreeInitialTime(0.5, 1.0, 0.7))
    assert make(tf=FreeFinalTime(0.5, 2.0, 1.0)).free_final_time
