"""Multi-phase problems: one NLP of linked phases (ocpkit.transcription.phases), against closed-form answers."""

import casadi as ca
import numpy as np
import pytest
from _problems import fixed_gain_leg

from ocpkit import HLGL, Control, FreeFinalTime, Link, OptimalControlProblem, Program, Radau, State


def leg(t0, tf, initial=(None, None), final=(None, None), names=("x", "v")):
    """min 1/2 int u^2 of the double integrator on [t0, tf], with the given end conditions."""
    return OptimalControlProblem(
        f"leg_{t0}_{tf}",
        states=[State(n, initial=a, final=b) for n, a, b in zip(names, initial, final)],
        controls=[Control("u")],
        dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
        t0=t0,
        tf=tf,
        lagrange=lambda x, u, t: u[0] ** 2 / 2,
    )


def test_two_phases_are_one_problem():
    """(0, 0) to (1, 0) in t = 1 split at t = 1/2, HLGL then Radau: J = 6, u = 6 - 12 t, continuous states."""
    mp = Program.from_phases([HLGL(leg(0.0, 0.5, initial=(0.0, 0.0)), 5), Radau(leg(0.5, 1.0, final=(1.0, 0.0)), 6, 2)])
    sol = mp.solve()
    assert sol.objective == pytest.approx(6.0, rel=1e-9)
    assert [p.objective for p in sol.phases] == pytest.approx([3.0, 3.0], rel=1e-9)  # int_0^.5 (6-12t)^2/2 = 3
    assert sol.link_residual < 1e-10
    t = np.linspace(0, 1, 11)
    assert np.allclose(sol.control(t)[:, 0], 6 - 12 * t, atol=1e-6)
    assert np.allclose(sol.state(t)[:, 0], 3 * t**2 - 2 * t**3, atol=1e-8)
    assert sol.t0 == 0.0 and sol.tf == 1.0 and sol.max_reintegration_error() < 1e-8
    assert sol.state_error == max(p.state_error for p in sol.phases) < 1e-12  # polynomials both schemes hold
    assert mp.n_constraints == sum(p.n_rows for p in mp.phases) + 2


def test_a_jump_across_a_link():
    """An impulse of +0.5 in v at t = 1/2: u = 5.5 - 12 t and J = 49/8 (closed form)."""
    mp = Program.from_phases(
        [Radau(leg(0.0, 0.5, initial=(0.0, 0.0)), 5, 2), Radau(leg(0.5, 1.0, final=(1.0, 0.0)), 5, 2)],
        [Link(0, 1, jumps={"v": 0.5})],
    )
    sol = mp.solve()
    assert sol.objective == pytest.approx(49 / 8, rel=1e-9)
    v_end, v_start = sol.phases[0].state_values[-1, 1], sol.phases[1].state_values[0, 1]
    assert v_start - v_end == pytest.approx(0.5, abs=1e-10)


def test_a_free_final_time_meets_the_next_phase():
    """Phase 0 with a free tf, phase 1 starting at 0.5: the link fixes tf = 0.5 and J = 6."""
    first = leg(0.0, FreeFinalTime(0.1, 0.9, 0.3), initial=(0.0, 0.0))
    sol = Program.from_phases([HLGL(first, 6), HLGL(leg(0.5, 1.0, final=(1.0, 0.0)), 6)]).solve()
    assert sol.phases[0].tf == pytest.approx(0.5, abs=1e-10)
    assert sol.objective == pytest.approx(6.0, rel=1e-9)


def test_bad_links_are_named():
    a, b = HLGL(leg(0.0, 0.5, initial=(0.0, 0.0)), 4), HLGL(leg(0.5, 1.0, final=(1.0, 0.0), names=("y", "w")), 4)
    with pytest.raises(ValueError, match=r"link 0 -> 1: states \['x', 'v'\] are not states of both phases"):
        Program.from_phases([a, b])
    c = HLGL(leg(0.6, 1.0, final=(1.0, 0.0)), 4)
    with pytest.raises(ValueError, match=r"link 0 -> 1: phase 0 ends at tf = 0.5 but phase 1 starts at t0 = 0.6"):
        Program.from_phases([a, c])
    d = HLGL(leg(0.5, 1.0, final=(1.0, 0.0)), 4)
    with pytest.raises(ValueError, match=r"link 0 -> 1: jumps of \['m'\], which the link does not join"):
        Program.from_phases([a, d], [Link(0, 1, jumps={"m": -1.0})])
    with pytest.raises(ValueError, match="link 0 -> 0: phases must be two different indices"):
        Program.from_phases([a, d], [Link(0, 0)])
    with pytest.raises(TypeError, match="phase 1 must be a scheme bound to its problem"):
        Program.from_phases([a, leg(0.5, 1.0)])
    with pytest.raises(ValueError, match="one guess per phase"):
        Program.from_phases([a, d]).solve([None])


def test_a_free_initial_time_meets_the_previous_phase():
    """Phase 1 with a free t0 after phase 0 ending at 0.5: the link fixes t0 = 0.5 and J = 6."""
    from ocpkit import FreeInitialTime

    second = leg(FreeInitialTime(0.2, 0.8, 0.6), 1.0, final=(1.0, 0.0))
    sol = Program.from_phases([Radau(leg(0.0, 0.5, initial=(0.0, 0.0)), 6), Radau(second, 6)]).solve()
    assert sol.phases[1].t0 == pytest.approx(0.5, abs=1e-10)
    assert sol.objective == pytest.approx(6.0, rel=1e-9)


def gain_leg(t0, tf, initial=(None, None), final=(None, None)):
    """The double integrator with a free gain k (x'' = k u) and a pull of k towards 2 + t on [t0, tf]."""
    from ocpkit import FreeParameter

    return OptimalControlProblem(
        f"gain_leg_{t0}_{tf}",
        states=[State("x", initial=initial[0], final=final[0]), State("v", initial=initial[1], final=final[1])],
        controls=[Control("u")],
        dynamics=lambda x, u, t, p: ca.vertcat(x[1], p["k"] * u[0]),
        t0=t0,
        tf=tf,
        lagrange=lambda x, u, t, p: u[0] ** 2 / 2 + (p["k"] - 2.0 - t) ** 2,
        free_parameters=[FreeParameter("k", 0.5, 4.0, guess=1.0)],
    )


def test_a_free_parameter_named_by_several_phases_is_one_parameter_of_the_trajectory():
    """k is pulled towards 2 + t: shared, k is the value the single-phase statement of the same problem finds on
    the same mesh (to the solver's tolerance); phase-local (``local_parameters``), each phase has its own, the first
    below the shared one and the second above. (The COPS gas-oil fit as 20 linked phases used to fit one set of
    rates per phase and report success.)"""
    phases = [HLGL(gain_leg(0.0, 0.5, initial=(0.0, 0.0)), 6), HLGL(gain_leg(0.5, 1.0, final=(1.0, 0.0)), 6)]
    mp = Program.from_phases(phases)
    shared = mp.solve()
    # one NLP variable for both phases' k: no copy, no row holding copies equal (the two link rows alone)
    assert mp.shared_parameters == ["k"] and mp.n_constraints == sum(p.n_rows for p in mp.phases) + 2
    assert mp.layout["parameter k"].size == 1
    assert [p.to_global[p.layout.global_indices][0] for p in mp.phases] == [mp.layout["parameter k"][0]] * 2
    assert [p.parameters["k"] for p in shared.phases] == pytest.approx([shared.parameters["k"]] * 2, abs=1e-10)
    one = HLGL(gain_leg(0.0, 1.0, initial=(0.0, 0.0), final=(1.0, 0.0)), 12).solve()
    assert shared.parameters["k"] == pytest.approx(one.parameters["k"], rel=1e-8)
    assert shared.objective == pytest.approx(one.objective, rel=1e-8)
    local = Program.from_phases(phases, local_parameters=["k"]).solve()
    k0, k1 = (p.parameters["k"] for p in local.phases)
    assert k0 < shared.parameters["k"] < k1 and local.objective < shared.objective and local.parameters == {}
    with pytest.raises(ValueError, match=r"local_parameters \['c'\] are not free parameters of any phase"):
        Program.from_phases(phases, local_parameters=["c"])


def test_a_solution_says_its_free_parameters():
    problem = gain_leg(0.0, 1.0, initial=(0.0, 0.0), final=(1.0, 0.0))
    sol = Radau(problem, 5, 3).solve()
    assert set(sol.parameters) == {"k"} and sol.parameters["k"] == sol.problem.parameters["k"]
    assert HLGL(leg(0.0, 1.0, initial=(0.0, 0.0), final=(1.0, 0.0)), 4).solve().parameters == {}


def test_a_phase_without_a_cost():
    """Coast-free steering in phase 0 (no cost), min 1/2 int u^2 in phase 1: the first phase is free to prepare the
    second, whose cost is that of the whole; a problem without any cost is a feasibility problem (J = 0)."""

    def phase(t0, tf, cost, **ends):
        return OptimalControlProblem(
            f"phase_{t0}",
            states=[State("x", **ends.get("x", {})), State("v", **ends.get("v", {}))],
            controls=[Control("u", -1.0, 1.0)],
            dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
            t0=t0,
            tf=tf,
            lagrange=(lambda x, u, t: u[0] ** 2 / 2) if cost else None,
        )

    free = phase(0.0, 0.5, False, x={"initial": 0.0}, v={"initial": 0.0})
    costly = phase(0.5, 1.0, True, x={"final": 0.05}, v={"final": 0.0})
    sol = Program.from_phases([HLGL(free, 5), HLGL(costly, 5)]).solve()
    assert sol.phases[0].objective == 0.0 and sol.objective == pytest.approx(sol.phases[1].objective)
    # phase 0 can bring the state to (0.05, 0) itself (|u| <= 1 reaches 0.0625 at rest in 0.5), then phase 1 costs 0
    assert sol.objective == pytest.approx(0.0, abs=1e-8)
    feasible = HLGL(phase(0.0, 1.0, False, x={"initial": 0.0, "final": 0.2}, v={"initial": 0.0, "final": 0.0}), 5)
    only = feasible.solve()
    assert only.objective == 0.0 and only.converged and abs(only.state(1.0)[0] - 0.2) < 1e-8


def brachistochrone_phase(name, t0, tf, **ends):
    """Dymos' brachistochrone (g = 9.80665) between the given end conditions, theta from the downward vertical."""
    g = 9.80665
    return OptimalControlProblem(
        name,
        states=[State(s, **ends.get(s, {})) for s in ("x", "y", "v")],
        controls=[Control("theta", 0.0, np.pi, guess=1.0)],
        dynamics=lambda x, u, t: [
            x["v"] * ca.sin(u["theta"]),
            -x["v"] * ca.cos(u["theta"]),
            g * ca.cos(u["theta"]),
        ],
        t0=t0,
        tf=tf,
    )


def cycloid_time(dx=10.0, drop=5.0, g=9.80665):
    """The brachistochrone's least time from rest over (dx, drop): the cycloid x = R (phi - sin phi), y = R (1 - cos
    phi) through the end point."""
    from scipy.optimize import brentq

    phi = brentq(lambda f: (f - np.sin(f)) / (1 - np.cos(f)) - dx / drop, 1e-3, 2 * np.pi - 1e-3)
    return phi * np.sqrt(drop / (1 - np.cos(phi)) / g)


def test_a_trajectory_cost_stated_once():
    """The brachistochrone split at x = 5 with the final time as the trajectory's cost: the cycloid's 1.8016031 (Dymos
    quotes 1.8016); tf written as a Mayer term in both phases would minimise t1 + t2 instead (1.80773 reported)."""
    mp = split_brachistochrone(lambda p: Radau(p, 5, 10))
    sol = mp.solve()
    assert cycloid_time() == pytest.approx(1.8016031, abs=5e-8)
    assert sol.objective == pytest.approx(cycloid_time(), rel=1e-9) and sol.trajectory_cost == sol.objective
    assert sol.phase("second").tf == sol.objective and sol.names == ["first", "second"]
    assert [p.objective for p in sol.phases] == [0.0, 0.0] and sol.link_residual < 1e-12
    twice = [ph.problem.replace(mayer=lambda x0, xf, t0, tf: tf) for ph in mp.phases]
    both = Program.from_phases([Radau(p, 5, 10) for p in twice]).solve()
    assert both.objective == pytest.approx(both.phases[0].tf + both.tf, rel=1e-12)
    assert both.tf > sol.tf + 1e-4  # another problem: the first phase hurries at the second's expense


def test_a_linkage_constraint_bounces_a_ball():
    """A ball dropped from 1 m bounces with v+ = -0.9 v-: the bounce is a linkage constraint between the phases'
    ends (not a continuity link); it rises to 0.81 m, in closed-form times (the dynamics are polynomial)."""
    from ocpkit import Constraint, FreeInitialTime

    g = 9.81

    def phase(name, t0, tf, **ends):
        states = [State("h", **ends.get("h", {})), State("v", **ends.get("v", {}))]
        return OptimalControlProblem(name, states, [], lambda x, u, t: [x["v"], -g], t0=t0, tf=tf)

    fall = phase("fall", 0.0, FreeFinalTime(0.1, 0.6, 0.5), h={"initial": 1.0, "final": 0.0}, v={"initial": 0.0})
    rise = phase("rise", FreeInitialTime(0.1, 0.6, 0.5), FreeFinalTime(0.61, 2.0, 1.2), v={"final": 0.0})
    bounce = Constraint("bounce", lambda e: e["rise"].x0["v"] + 0.9 * e["fall"].xf["v"], lower=0.0, upper=0.0)
    sol = Program.from_phases(
        [Radau(fall, 3, 2), Radau(rise, 3, 2)], [Link("fall", "rise", ["h"])], constraints=[bounce]
    ).solve()
    t1 = np.sqrt(2 / g)
    assert sol.phase("fall").tf == pytest.approx(t1, rel=1e-9)
    assert sol.tf == pytest.approx(t1 + 0.9 * np.sqrt(2 * g) / g, rel=1e-9)
    assert sol.phase("rise").state_values[-1, 0] == pytest.approx(0.81, rel=1e-9) and sol.link_residual < 1e-10
    with pytest.raises(
        ValueError, match=r"link fall -> lift: no phase named 'lift'; the phases are \['fall', 'rise'\]"
    ):
        Program.from_phases([Radau(fall, 3, 2), Radau(rise, 3, 2)], [Link("fall", "lift")])
    with pytest.raises(KeyError, match=r"linkage constraint 'bounce': unknown phase 'drop'; the phases are"):
        bad = Constraint("bounce", lambda e: e["drop"].xf["v"], lower=0.0, upper=0.0)
        Program.from_phases([Radau(fall, 3, 2), Radau(rise, 3, 2)], constraints=[bad])
    with pytest.raises(KeyError, match=r"the trajectory cost: unknown state 'y'"):
        Program.from_phases([Radau(fall, 3, 2), Radau(rise, 3, 2)], cost=lambda e: e[1].xf["y"])


def test_phases_in_different_objective_scales_minimise_their_sum():
    """Phase costs stated in different objective scales are one sum (each phase's NLP cost used to be divided by
    its own scale, so a phase with scale 100 weighed a hundredth): u = 6 - 12 t, J = 6, 3 in each phase."""
    first = leg(0.0, 0.5, initial=(0.0, 0.0)).replace(objective_scale=100.0)
    mp = Program.from_phases([Radau(first, 5, 2), Radau(leg(0.5, 1.0, final=(1.0, 0.0)), 5, 2)])
    sol = mp.solve()
    assert mp.objective_scale == 100.0 and sol.objective == pytest.approx(6.0, rel=1e-9)
    assert [p.objective for p in sol.phases] == pytest.approx([3.0, 3.0], rel=1e-9)
    # each phase's multipliers in its own cost's scale: the second phase's (cost scale 1 in a trajectory of 100)
    # as when every scale is 1 (lambda_x = -12, lambda_v = 12 t - 6 in closed form)
    one = Radau(leg(0.0, 0.5, initial=(0.0, 0.0)), 5, 2)
    t = np.array([0.75])
    costates = [m.solve().phases[1].costate(t)[0] for m in (mp, Program.from_phases([one, mp.schemes[1]]))]
    assert np.allclose(costates[0], costates[1], rtol=1e-6) and np.allclose(costates[0], [-12.0, 3.0], rtol=1e-3)


def test_a_trajectory_cost_sees_the_shared_parameters():
    """k shared by both phases is one entry of the trajectory's p; a cost pulling it to 3 moves it there."""
    phases = [HLGL(gain_leg(0.0, 0.5, initial=(0.0, 0.0)), 6), HLGL(gain_leg(0.5, 1.0, final=(1.0, 0.0)), 6)]
    free = Program.from_phases(phases).solve()
    pulled = Program.from_phases(phases, cost=lambda e, p: 1e3 * (p["k"] - 3.0) ** 2).solve()
    assert abs(pulled.parameters["k"] - 3.0) < abs(free.parameters["k"] - 3.0) / 10
    assert pulled.trajectory_cost == pytest.approx(1e3 * (pulled.parameters["k"] - 3.0) ** 2, rel=1e-12)


def test_a_problem_split_at_measurement_times():
    """x' = -k x from x(0) = 1, measured at the exact solution of k = 2: the fit at the cut times recovers k = 2 with
    J = 0 (to the discretisation); ends.at names a cut time, and times that are not cuts are refused."""
    from ocpkit import FreeParameter

    decay = OptimalControlProblem(
        "decay",
        [State("x", initial=1.0)],
        [],
        lambda x, u, t, p: -p["k"] * x["x"],
        tf=1.0,
        free_parameters=[FreeParameter("k", 0.1, 10.0, guess=1.0)],
    )
    times = [0.2, 0.5, 0.7, 1.0]
    cost = lambda e: sum((e.at(t)["x"] - np.exp(-2 * t)) ** 2 for t in times)  # noqa: E731
    mp = Program.split(decay, times, lambda pr: Radau(pr, 6, 2), cost=cost)
    sol = mp.solve()
    assert list(mp.cut_times) == [0.0, 0.2, 0.5, 0.7, 1.0] and len(sol.phases) == 4
    assert sol.parameters["k"] == pytest.approx(2.0, rel=1e-8) and sol.objective < 1e-16
    t, x = sol.sample(lambda x, u, t: x["x"], grid=np.linspace(0, 1, 11))
    assert np.allclose(x, np.exp(-2 * t), atol=1e-9)
    with pytest.raises(KeyError, match=r"no phase starts or ends at the fixed time t = 0.3"):
        Program.split(decay, times, lambda pr: Radau(pr, 3, 1), cost=lambda e: e.at(0.3)["x"])
    with pytest.raises(ValueError, match=r"times must lie in \[t0, tf\] = \[0.0, 1.0\]"):
        Program.split(decay, [0.5, 1.5], lambda pr: Radau(pr, 3, 1))
    with pytest.raises(ValueError, match="split needs fixed t0 and tf"):
        Program.split(decay.replace(tf=FreeFinalTime(0.5, 2.0, 1.0)), [0.5], lambda pr: Radau(pr, 3, 1))


def test_a_split_keeps_the_end_conditions_mayer_term_and_boundary_constraints():
    """The double integrator from (0, 0) with x(1) - x(0) = 1 (a boundary constraint), v(1) free but priced by the
    Mayer term 2 (v(1) - v(0))^2: split at 0.25 and 0.5 it is the same problem as whole on the same mesh (cubic
    states, so both exact: J = 2 (v1^2 + ...) is what both find), and not the problem without its Mayer term."""
    from ocpkit import Constraint

    whole = leg(0.0, 1.0, initial=(0.0, 0.0)).replace(
        mayer=lambda x0, xf, t0, tf: 2.0 * (xf["v"] - x0["v"]) ** 2,
        boundary_constraints=[Constraint("rise", lambda x0, xf, t0, tf: xf["x"] - x0["x"], lower=1.0, upper=1.0)],
    )
    sol = Program.split(whole, [0.25, 0.5], lambda pr: HLGL(pr, 2)).solve()
    one = HLGL(whole, mesh=[0.125, 0.125, 0.125, 0.125, 0.25, 0.25]).solve()
    assert sol.objective == pytest.approx(one.objective, rel=1e-9) and sol.link_residual < 1e-9
    assert sol.phases[-1].state_values[-1, 1] == pytest.approx(one.state_values[-1, 1], rel=1e-8)
    free = HLGL(whole.replace(mayer=None), 6).solve()
    assert free.objective < sol.objective - 0.1  # the Mayer term moved the optimum
    assert sol.phases[-1].state_values[-1, 0] == pytest.approx(1.0, abs=1e-10)
    assert [p.t0 for p in sol.phases] == [0.0, 0.25, 0.5]


def split_brachistochrone(make):
    """The brachistochrone split at x = 5, final time as the trajectory cost, each phase transcribed by ``make``."""
    from ocpkit import FreeInitialTime

    first = brachistochrone_phase(
        "first",
        0.0,
        FreeFinalTime(0.3, 1.7, 0.9),
        x={"initial": 0.0, "final": 5.0},
        y={"initial": 10.0},
        v={"initial": 0.0},
    )
    second = brachistochrone_phase(
        "second", FreeInitialTime(0.3, 1.7, 0.9), FreeFinalTime(1.71, 3.0, 1.8), x={"final": 10.0}, y={"final": 5.0}
    )
    return Program.from_phases({"first": make(first), "second": make(second)}, cost=lambda e: e["second"].tf)


def test_linked_phases_have_the_one_solve_session():
    """A coarse mesh warns naming the phase; mesh_tolerance refines every phase's mesh until every part of every
    phase's estimate meets it (to the cycloid's time within 1e-9); a solution of the same object is an exact warm
    start; reintegrate() gives one Reintegration whatever the number of phases."""
    from ocpkit.accuracy import AccuracyWarning

    mp = split_brachistochrone(lambda p: Radau(p, 3, 2))
    with pytest.warns(AccuracyWarning, match=r"phase 'first', Radau\(nodes=3, intervals=2\): estimated relative"):
        coarse = mp.solve()
    assert coarse.refinement_outcome is None and coarse.state_error > 1e-4
    sol = mp.solve(mesh_tolerance=1e-7)
    assert sol.refinement_outcome == "met" and len(sol.mesh_history) >= 3
    assert sol.accuracy.failing(1e-7) == [] and sol.objective == pytest.approx(cycloid_time(), rel=1e-9)
    assert sol.mesh_history[0].collocation_points < sol.mesh_history[-1].collocation_points
    finer = sol.program
    assert finer is not mp and all(p.n_defects // p.problem.nx > 6 for p in finer.phases)
    again = finer.solve(sol)
    assert again.iterations <= 3 and again.objective == pytest.approx(sol.objective, rel=1e-10)
    r = sol.reintegrate()
    assert r.t[0] == 0.0 and r.t[-1] == pytest.approx(sol.tf) and r.max_error < 1e-5
    assert r.max_error == pytest.approx(sol.max_reintegration_error(), rel=1e-12)


def test_linked_phases_take_new_parameter_values_without_rebuilding():
    """A fixed parameter named by both phases (the gain k of x'' = k u) takes new values per solve: J = 6 / k^2."""

    mp = Program.from_phases(
        [HLGL(fixed_gain_leg(0.0, 0.5, initial=(0.0, 0.0)), 4), HLGL(fixed_gain_leg(0.5, 1.0, final=(1.0, 0.0)), 4)]
    )
    assert mp.solve().objective == pytest.approx(6.0, rel=1e-9)
    solver = mp.solver()
    doubled = mp.solve(parameters={"k": 2.0})
    assert doubled.objective == pytest.approx(6.0 / 4, rel=1e-9) and mp.solver() is solver
    assert [p.problem.parameters["k"] for p in doubled.phases] == [2.0, 2.0]
    with pytest.raises(KeyError, match=r"unknown parameters \['g'\]; Program\(.*\) has \['k'\]"):
        mp.solve(parameters={"g": 1.0})


def bd(t0, tf, path, **ends):
    """Bryson-Denham on [t0, tf], with x <= 1/9 as a path constraint where ``path``, and the given end conditions."""
    from ocpkit import Constraint

    return OptimalControlProblem(
        f"bd{t0}",
        [State("x", **ends.get("x", {})), State("v", **ends.get("v", {}))],
        [Control("u")],
        lambda x, u, t: [x["v"], u["u"]],
        t0=t0,
        tf=tf,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
        path_constraints=[Constraint("x_max", lambda x, u, t: x["x"], upper=1 / 9)] if path else [],
    )


def test_refinement_with_path_constraints_in_some_phases_only():
    """Bryson-Denham split at 0.6 with x <= 1/9 in the first phase only: the phase without the constraint does
    not blind the refinement to the other's violations between points (it used to stop with them over)."""
    first = Radau(bd(0.0, 0.6, True, x={"initial": 0.0}, v={"initial": 1.0}), 3, 3)
    second = Radau(bd(0.6, 1.0, False, x={"final": 0.0}, v={"final": -1.0}), 3, 3)
    sol = Program.from_phases([first, second]).solve(mesh_tolerance=1e-6)
    assert sol.refinement_outcome == "met" and sol.accuracy.path["x_max"] <= 1e-6
    from ocpkit.program.solve import path_where

    assert not np.isnan(path_where(sol)[:, 1]).any()


def test_a_multiphase_warning_points_at_the_caller():
    from ocpkit.accuracy import AccuracyWarning

    with pytest.warns(AccuracyWarning) as record:
        split_brachistochrone(lambda p: Radau(p, 3, 2)).solve()
    assert record[0].filename == __file__


def test_the_trajectory_parameter_is_the_free_one_where_a_phase_fixes_its_own():
    """k fixed at 1 in the first phase and free (shared) in the other two: the trajectory's p["k"], its cost,
    value("k") and sample see the free one."""
    from ocpkit import FreeParameter

    def part(t0, tf, initial=(None, None), final=(None, None), **kw):
        states = [State("x", initial=initial[0], final=final[0]), State("v", initial=initial[1], final=final[1])]
        dyn = lambda x, u, t, p: [x["v"], p["k"] * u["u"]]  # noqa: E731
        return OptimalControlProblem(
            f"part{t0}", states, [Control("u")], dyn, t0=t0, tf=tf, lagrange=lambda x, u, t: u["u"] ** 2 / 2, **kw
        )

    free = [FreeParameter("k", 0.5, 4.0, guess=1.0)]
    phases = [
        HLGL(part(0.0, 1 / 3, initial=(0.0, 0.0), parameters={"k": 1.0}), 6),
        HLGL(part(1 / 3, 2 / 3, free_parameters=free), 6),
        HLGL(part(2 / 3, 1.0, final=(1.0, 0.0), free_parameters=free), 6),
    ]
    sol = Program.from_phases(phases, cost=lambda e, p: 10 * (p["k"] - 3.0) ** 2).solve()
    k = sol.parameters["k"]
    assert sol.trajectory_cost == pytest.approx(10 * (k - 3.0) ** 2, rel=1e-12) and sol.value("k") == k
    t, gain = sol.sample(lambda x, u, t, p: p["k"], grid=[0.1, 0.5, 0.9])
    assert gain[1:] == pytest.approx([k, k]) and gain[0] == 1.0  # phase 0's own k, the others the trajectory's
    assert sol.sample(lambda x, u, t: x["x"], grid=[])[1].shape == (0,)


def test_the_accuracy_of_a_cost_at_cut_times_flies_through_the_links():
    """A fit at cut times on a mesh too coarse for it: the objective part of the accuracy sees the flown states at
    the cut times (within a factor of a few of the true error of J), not only each phase's own flight."""
    from ocpkit import FreeParameter

    decay = OptimalControlProblem(
        "decay",
        [State("x", initial=1.0)],
        [],
        lambda x, u, t, p: -p["k"] * x["x"] ** 2,
        tf=3.0,
        free_parameters=[FreeParameter("k", 0.1, 10.0, guess=1.0)],
    )
    times = [0.5, 1.0, 1.5, 2.0, 3.0]
    data = {t: 1 / (1 + 2.0 * t) + 0.01 * (-1) ** i for i, t in enumerate(times)}
    cost = lambda e: sum((e.at(t)["x"] - y) ** 2 for t, y in data.items())  # noqa: E731
    coarse = Program.split(decay, times, lambda pr: Radau(pr, 2, 1), cost=cost).solve(error_threshold=None)
    fine = Program.split(decay, times, lambda pr: Radau(pr, 8, 2), cost=cost).solve(error_threshold=None)
    k = coarse.parameters["k"]
    exact = sum((1 / (1 + k * t) - y) ** 2 for t, y in data.items())  # the coarse k's cost on the exact states
    true = abs(exact - coarse.objective) / exact
    assert true > 1e-3 and true / 5 < coarse.accuracy.objective < 5 * true
    assert fine.accuracy.objective < 1e-8 and coarse.flown_trajectory_cost() == pytest.approx(exact, rel=1e-8)


def test_the_pieces_of_a_split_continue_the_whole_guess():
    """A (start, end) guess of the whole problem is one line across the pieces, not a sawtooth."""
    whole = leg(0.0, 1.0, initial=(0.0, 0.0), final=(1.0, 0.0)).replace(
        states=[State("x", initial=0.0, final=1.0, guess=(0.0, 1.0)), State("v", initial=0.0, final=0.0)]
    )
    mp = Program.split(whole, [0.25, 0.5], lambda pr: HLGL(pr, 2))
    starts = [s.initial_point()[0] for s in mp.schemes]  # each piece's first x node (scale 1)
    assert starts == pytest.approx([0.0, 0.25, 0.5])


def test_a_phase_given_by_its_start_and_duration():
    """Rest to rest over a unit distance with |u| <= 1, starting no earlier than 0.5, as early as possible:
    t0 = 0.5 and a duration of 2 (bang-bang, the switch at the middle, on the mesh: exact). The windows of t0 and
    tf overlap, which FreeFinalTime refuses (saying to give the duration)."""
    from ocpkit import Duration, FreeInitialTime

    def race(tf):
        return OptimalControlProblem(
            "race",
            [State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
            [Control("u", -1.0, 1.0)],
            lambda x, u, t: [x["v"], u["u"]],
            t0=FreeInitialTime(0.5, 2.0, 1.0),
            tf=tf,
            mayer=lambda x0, xf, t0, tf: tf,
        )

    sol = Radau(race(Duration(0.5, 5.0, 1.5)), 3, 2).solve()
    assert (sol.t0, sol.tf) == pytest.approx((0.5, 2.5), abs=1e-7)  # IPOPT relaxes bounds by 1e-8
    with pytest.raises(ValueError, match=r"must exceed t0 \(at most 2.0\); .* give the duration, tf=Duration"):
        race(FreeFinalTime(1.0, 5.0, 2.5))
    with pytest.raises(ValueError, match="a duration's lower bound must be positive"):
        Duration(0.0, 1.0, 0.5)


def test_overlapping_windows_of_linked_phases():
    """The split brachistochrone with its second phase given by a free start and a duration, whose final-time
    window [0.35, 3.7] overlaps the start's [0.3, 1.7]: the same cycloid time."""
    from ocpkit import Duration

    mp = split_brachistochrone(lambda p: Radau(p, 5, 10))
    second = mp.phases[1].problem.replace(tf=Duration(0.05, 2.0, 0.9))
    phases = {"first": mp.schemes[0], "second": Radau(second, 5, 10)}
    sol = Program.from_phases(phases, cost=lambda e: e["second"].tf).solve()
    assert sol.objective == pytest.approx(cycloid_time(), rel=1e-9)
    assert sol.phase("second").t0 == pytest.approx(sol.phase("first").tf, abs=1e-12)


def test_a_duration_is_not_an_absolute_final_time():
    """Start as late as possible (t0 <= 2) for a race that takes at least 2: with a duration in [2, 2.5] the start
    is 2.0; read as an absolute final time in [2, 2.5] it could be no later than 0.5."""
    from ocpkit import Duration, FreeInitialTime

    late = OptimalControlProblem(
        "late",
        [State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t: [x["v"], u["u"]],
        t0=FreeInitialTime(0.5, 2.0, 1.0),
        tf=Duration(2.0, 2.5, 2.2),
        mayer=lambda x0, xf, t0, tf: -t0,
    )
    sol = Radau(late, 3, 2).solve(error_threshold=None)
    assert sol.t0 == pytest.approx(2.0, abs=1e-7) and 4.0 - 1e-7 <= sol.tf <= 4.5 + 1e-7


@pytest.mark.parametrize("t0_free", [False, True])
@pytest.mark.parametrize("tf_kind", ["fixed", "free", "duration"])
@pytest.mark.parametrize("pinned, free", [(0, 0), (1, 0), (0, 2), (2, 1)])
def test_the_global_variables_round_trip(t0_free, tf_kind, pinned, free):
    """GlobalVariables: pack then unpack gives the physical values back, and the symbols give them from the packed
    vector, for every combination of a fixed or free t0, a fixed, free or duration tf, pinned and free parameters."""
    from ocpkit import Duration, FreeInitialTime, FreeParameter
    from ocpkit.transcription.mesh import GlobalVariables

    t0 = FreeInitialTime(0.0, 1.0, 0.5, scale=2.0) if t0_free else 0.25
    tf = {"fixed": 3.0, "free": FreeFinalTime(1.5, 4.0, 3.0, scale=3.0), "duration": Duration(0.5, 4.0, 2.0, 4.0)}
    problem = OptimalControlProblem(
        "globals",
        [State("x")],
        [],
        lambda x, u, t, p: [0 * x["x"]],
        t0=t0,
        tf=tf[tf_kind],
        parameters={f"a{i}": 1.0 + i for i in range(pinned)} or None,
        free_parameters=[FreeParameter(f"k{j}", -5.0, 5.0, scale=2.0, shift=1.0) for j in range(free)],
    )
    layout = GlobalVariables(problem)
    start, end = (0.7 if t0_free else 0.25), (3.0 if tf_kind == "fixed" else 3.3)
    values = {f"k{j}": 0.5 * j - 1.0 for j in range(free)}
    pinned_values = np.arange(pinned, dtype=float) + 7.0
    z = layout.pack(pinned_values, values, start, end)
    assert z.size == layout.size == pinned + free + int(t0_free) + int(tf_kind != "fixed")
    out = layout.unpack(z)
    assert out["t0"] == pytest.approx(start) and out["tf"] == pytest.approx(end)
    assert out["parameters"] == pytest.approx(values) and list(out["pinned"].values()) == pytest.approx(pinned_values)
    sym = ca.SX.sym("z", 3 + layout.size)  # a block's z ends with them
    q = ca.SX.sym("q", len(layout.constants))
    f = ca.Function("f", [sym, q], [layout.t0(sym), layout.tf(sym, q, 0), layout.P(sym)])
    t0_, tf_, P_ = f(np.concatenate([np.zeros(3), z]), layout.constants)
    assert float(t0_) == pytest.approx(start) and float(tf_) == pytest.approx(end)
    assert np.asarray(P_).ravel() == pytest.approx([*pinned_values, *values.values()])
    lb, ub = layout.bounds(pinned_values)
    assert np.all(lb <= z + 1e-12) and np.all(z <= ub + 1e-12)
