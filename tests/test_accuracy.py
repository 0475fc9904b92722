"""Error estimates and mesh refinement (ocpkit.accuracy, Transcription.solve(mesh_tolerance=...))."""

import warnings

import casadi as ca
import numpy as np
import pytest

from ocpkit import HLGL, Control, FreeFinalTime, MultiRateHLGL, OptimalControlProblem, Radau, State
from ocpkit.accuracy import AccuracyWarning, control_switches, interval_errors
from ocpkit.nodes import integration_matrix, lgr_nodes

from compendium.problems import flat_moon_ascent, linear_tangent_solution


def minimum_energy():
    """Rest to rest over distance 1 in t = 1: x = 3t^2 - 2t^3, u = 6 - 12t: polynomials every scheme holds exactly."""
    return OptimalControlProblem(
        "min_energy",
        states=[State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        controls=[Control("u")],
        dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=1.0,
        lagrange=lambda x, u, t: u[0] ** 2 / 2,
    )


def test_integration_matrix_is_exact_for_polynomials():
    tau = lgr_nodes(7)
    A = integration_matrix(tau, np.append(tau, 1.0))
    for k in range(7):
        exact = (np.append(tau, 1.0) ** (k + 1) - (-1.0) ** (k + 1)) / (k + 1)
        assert np.allclose(A @ tau**k, exact, atol=1e-14)


@pytest.mark.parametrize(
    "make",
    [lambda pr: HLGL(pr, 4), lambda pr: Radau(pr, 4, 3), lambda pr: MultiRateHLGL(pr, 2, ratio=2, fast=["v"])],
    ids=["hlgl", "radau", "multirate"],
)
def test_the_estimate_is_at_rounding_level_where_the_scheme_is_exact(make):
    sol = make(minimum_energy()).solve()
    assert sol.state_error < 1e-13


def test_the_estimate_follows_the_true_error_on_the_flat_moon():
    """HLGL against the exact linear-tangent ascent: the estimate is within a factor 30 of the true relative
    state error, and both fall at about the scheme's order."""
    problem = flat_moon_ascent()
    exact = linear_tangent_solution()
    estimates, true_errors = [], []
    for n in (2, 4, 8):
        sol = HLGL(problem, n).solve(ipopt_options={"tol": 1e-14}, error_threshold=None)
        t = np.linspace(0, sol.tf, 401)
        X = sol.state(t)
        truth = exact.state(t * exact.tf / sol.tf)
        true_errors.append(float((np.abs(X - truth) / (1 + np.abs(truth).max(axis=0))).max()))
        estimates.append(sol.state_error)
    ratio = np.array(estimates) / np.array(true_errors)
    assert np.all((ratio > 1 / 30) & (ratio < 30)), (estimates, true_errors)
    assert estimates[0] / estimates[-1] > 4**4, "the estimate falls with the mesh"


def test_a_coarse_solve_warns_naming_the_interval():
    problem = flat_moon_ascent()
    with pytest.warns(AccuracyWarning, match=r"HLGL\(intervals=1\): estimated relative state error .* on interval 0"):
        HLGL(problem, 1).solve(error_threshold=1e-10)
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        HLGL(problem, 1).solve(error_threshold=None)


def hyper_sensitive(tf=40.0):
    from compendium.problems import hyper_sensitive as problem

    return problem(tf)


@pytest.mark.parametrize("make", [lambda pr: Radau(pr, 4, 8), lambda pr: HLGL(pr, 8)], ids=["radau", "hlgl"])
def test_refinement_meets_the_tolerance_and_puts_points_in_the_boundary_layers(make):
    sol = make(hyper_sensitive()).solve(mesh_tolerance=1e-6)
    history = sol.mesh_history
    assert sol.state_error <= 1e-6 and history[-1].error_estimate == sol.state_error
    assert len(history) >= 2 and history[0].error_estimate > 1e-6
    fractions = history[-1].fractions
    lengths = fractions * 40.0
    mid = np.cumsum(fractions) - fractions / 2
    assert lengths[(mid < 0.1) | (mid > 0.9)].min() < lengths[(mid > 0.3) & (mid < 0.7)].min() / 4
    # a uniform mesh of the final mesh's size is far less accurate: the points went where they were needed
    # (measured: Radau 110 points 5e-7 against 2.8e-2 uniform; HLGL 28 segments 9.5e-7 against 1.8e-2)
    final = sol.program.scheme
    if isinstance(final, HLGL):
        uniform = HLGL(hyper_sensitive(), final.intervals)
    else:
        uniform = Radau(hyper_sensitive(), 4, final.n_collocation // 4)
    assert uniform.solve(error_threshold=None).state_error > 100 * sol.state_error


def test_refinement_that_cannot_meet_the_tolerance_says_so():
    with pytest.warns(AccuracyWarning, match="mesh tolerance 1e-12 not met after 2 mesh iterations"):
        sol = HLGL(hyper_sensitive(), 4).solve(mesh_tolerance=1e-12, max_mesh_iterations=2)
    assert (
        len(sol.mesh_history) == 2 and sol.mesh_history[1].collocation_points > sol.mesh_history[0].collocation_points
    )


def test_estimate_points_must_be_sensible():
    sol = HLGL(minimum_energy(), 2).solve()
    with pytest.raises(ValueError, match="at least 2 points"):
        interval_errors(sol, points=1)


def test_multirate_refines_its_coarse_mesh():
    """Errors are estimated on the fine segments; a coarse segment splits where its worst fine segment is."""
    tr = MultiRateHLGL(flat_moon_ascent(), 2, ratio=2, fast=["vx", "vy"])
    sol = tr.solve(mesh_tolerance=1e-8)
    assert sol.state_error <= 1e-8
    assert sol.interval_errors.size == 2 * sol.program.scheme.intervals
    assert sol.program.scheme.intervals > 2


def minimum_time_double_integrator():
    """Rest to rest over distance 1, |u| <= 1, minimum time: u = +1 then -1, switching at t = 1, t_f = 2."""
    return OptimalControlProblem(
        "min_time",
        states=[State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        controls=[Control("u", -1.0, 1.0)],
        dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=FreeFinalTime(0.5, 5.0, 1.5),
        mayer=lambda x0, xf, t0, tf: tf,
    )


def test_control_switches_find_a_bang_bang_switch_inside_an_interval():
    sol = Radau(minimum_time_double_integrator(), 6, 3).solve(error_threshold=None)
    cuts = control_switches(sol, sol.estimate_intervals)
    assert [c.size for c in cuts] == [0, 2, 0]  # the switch, at t = 1, lies in the middle interval
    t_cut = sol.estimate_intervals[1] + cuts[1] * np.diff(sol.estimate_intervals)[1]
    assert t_cut[0] < 1.0 < t_cut[1] and np.diff(t_cut)[0] < 2.0 / 3.0 / 16  # bracketed, tightly
    free = OptimalControlProblem(
        "free",
        [State("x", initial=1.0)],
        [Control("u")],
        lambda x, u, t: -x[0] + u[0],
        tf=1.0,
        lagrange=lambda x, u, t: x[0] ** 2 + u[0] ** 2,
    )
    assert all(c.size == 0 for c in control_switches(Radau(free, 4, 2).solve(), [0.0, 0.5, 1.0]))


@pytest.mark.parametrize("make", [lambda p: Radau(p, 4, 3), lambda p: HLGL(p, 3)], ids=["radau", "hlgl"])
def test_refinement_puts_a_breakpoint_at_the_switch(make):
    """Cut at the switch, the mesh holds the bang-bang control exactly: the tolerance is met in a few iterations."""
    sol = make(minimum_time_double_integrator()).solve(mesh_tolerance=1e-7)
    # measured: Radau 2 mesh iterations (17 points), HLGL 4; without the cuts, 23 and 11 at 1e-6
    assert sol.state_error <= 1e-7 and len(sol.mesh_history) <= 5
    assert abs(sol.tf - 2.0) < 1e-6
    assert np.abs(sol.estimate_intervals - 1.0).min() < 1e-4


def test_mesh_split_at_cuts_segments_where_asked():
    from ocpkit.transcription.mesh import Mesh

    fractions, origin = Mesh.from_spec(2, None).split_at([np.array([0.25]), np.zeros(0)])
    assert np.allclose(fractions, [0.125, 0.375, 0.5]) and origin.tolist() == [0, 0, 1]


def test_control_switches_bracket_a_corner_where_the_control_leaves_its_bound():
    """u = 1 until x nears 2, then leaves the bound continuously: a corner, not a jump. On 4 intervals the coarse
    solution's corner lies inside the third (measured: t = 1.66, bracketed by cuts at 1.652 and 1.676)."""
    for lower in (-1.0, -np.inf):
        problem = OptimalControlProblem(
            "saturate",
            [State("x", initial=0.0)],
            [Control("u", lower, 1.0)],
            lambda x, u, t: u[0],
            tf=3.0,
            lagrange=lambda x, u, t: (x[0] - 2) ** 2 + 0.1 * u[0] ** 2,
        )
        sol = Radau(problem, 4, 4).solve(error_threshold=None)
        t = np.linspace(0, 3, 3001)
        corner = t[np.argmax(sol.control(t)[:, 0] < 0.999)]
        bp = sol.estimate_intervals
        cuts = [bp[k] + c * (bp[k + 1] - bp[k]) for k, cs in enumerate(control_switches(sol, bp)) for c in cs]
        assert any(a < corner < b for a, b in zip(cuts[:-1], cuts[1:]) if b - a < 0.75 / 16), (corner, cuts)


def test_control_switches_ignore_controls_with_equal_bounds():
    problem = OptimalControlProblem(
        "pinned_control",
        [State("x", initial=0.0, final=1.0)],
        [Control("u", 1.0, 1.0), Control("w")],
        lambda x, u, t: u[0] + u[1],
        tf=1.0,
        lagrange=lambda x, u, t: u[1] ** 2,
    )
    sol = HLGL(problem, 2).solve()
    assert all(c.size == 0 for c in control_switches(sol, sol.estimate_intervals))


def test_multiplier_estimates_shorten_a_refinement_and_change_nothing_else():
    """Each new mesh starts from the interpolated point with least-squares multipliers (and WARM_START): the entry
    landing's later meshes take a few IPOPT iterations (measured 6-10, against 26-31 from the point alone)."""
    from compendium.problems import entry_landing

    sol = Radau(entry_landing(), 4, 10).solve(mesh_tolerance=1e-5)
    later = [h.ipopt_iterations for h in sol.mesh_history[2:]]
    assert sol.state_error <= 1e-5 and max(later) <= 15
    # where no bound is active the estimate at IPOPT's solution is IPOPT's multipliers (the constraint Jacobian has
    # full rank: the least-squares solution is the exact one)
    tr = HLGL(minimum_energy(), 6)
    exact = tr.solve()
    lbw, ubw, _, _ = tr.nlp_bounds()
    lam_g, lam_w = tr.nlp.multiplier_estimate(exact.nlp_result.w, lbw, ubw)
    assert np.abs(lam_g - exact.nlp_result.lam_g).max() < 1e-8 * np.abs(exact.nlp_result.lam_g).max()
