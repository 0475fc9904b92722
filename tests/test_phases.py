"""Multi-phase problems: one NLP of linked phases (ocpkit.transcription.phases), against closed-form answers."""

import casadi as ca
import numpy as np
import pytest

from ocpkit import HLGL, Control, FreeFinalTime, Link, MultiPhase, OptimalControlProblem, Radau, State


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
    mp = MultiPhase([HLGL(leg(0.0, 0.5, initial=(0.0, 0.0)), 5), Radau(leg(0.5, 1.0, final=(1.0, 0.0)), 6, 2)])
    sol = mp.solve()
    assert sol.objective == pytest.approx(6.0, rel=1e-9)
    assert [p.objective for p in sol.phases] == pytest.approx([3.0, 3.0], rel=1e-9)  # int_0^.5 (6-12t)^2/2 = 3
    assert sol.link_residual < 1e-10
    t = np.linspace(0, 1, 11)
    assert np.allclose(sol.control(t)[:, 0], 6 - 12 * t, atol=1e-6)
    assert np.allclose(sol.state(t)[:, 0], 3 * t**2 - 2 * t**3, atol=1e-8)
    assert sol.t0 == 0.0 and sol.tf == 1.0 and sol.max_reintegration_error() < 1e-8
    assert sol.error_estimate == max(p.error_estimate for p in sol.phases) < 1e-12  # polynomials both schemes hold
    assert mp.n_constraints == sum(p.n_constraints for p in mp.phases) + 2


def test_a_jump_across_a_link():
    """An impulse of +0.5 in v at t = 1/2: u = 5.5 - 12 t and J = 49/8 (closed form)."""
    mp = MultiPhase(
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
    sol = MultiPhase([HLGL(first, 6), HLGL(leg(0.5, 1.0, final=(1.0, 0.0)), 6)]).solve()
    assert sol.phases[0].tf == pytest.approx(0.5, abs=1e-10)
    assert sol.objective == pytest.approx(6.0, rel=1e-9)


def test_bad_links_are_named():
    a, b = HLGL(leg(0.0, 0.5, initial=(0.0, 0.0)), 4), HLGL(leg(0.5, 1.0, final=(1.0, 0.0), names=("y", "w")), 4)
    with pytest.raises(ValueError, match=r"link 0 -> 1: states \['x', 'v'\] are not states of both phases"):
        MultiPhase([a, b])
    c = HLGL(leg(0.6, 1.0, final=(1.0, 0.0)), 4)
    with pytest.raises(ValueError, match=r"link 0 -> 1: phase 0 ends at tf = 0.5 but phase 1 starts at t0 = 0.6"):
        MultiPhase([a, c])
    d = HLGL(leg(0.5, 1.0, final=(1.0, 0.0)), 4)
    with pytest.raises(ValueError, match=r"link 0 -> 1: jumps of \['m'\], which the link does not join"):
        MultiPhase([a, d], [Link(0, 1, jumps={"m": -1.0})])
    with pytest.raises(ValueError, match="link 0 -> 0: phases must be two different indices"):
        MultiPhase([a, d], [Link(0, 0)])
    with pytest.raises(TypeError, match="phase 1 must be a Transcription"):
        MultiPhase([a, leg(0.5, 1.0)])
    with pytest.raises(ValueError, match="one guess per phase"):
        MultiPhase([a, d]).solve([None])


def test_a_free_initial_time_meets_the_previous_phase():
    """Phase 1 with a free t0 after phase 0 ending at 0.5: the link fixes t0 = 0.5 and J = 6."""
    from ocpkit import FreeInitialTime

    second = leg(FreeInitialTime(0.2, 0.8, 0.6), 1.0, final=(1.0, 0.0))
    sol = MultiPhase([Radau(leg(0.0, 0.5, initial=(0.0, 0.0)), 6), Radau(second, 6)]).solve()
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
    mp = MultiPhase(phases)
    shared = mp.solve()
    assert mp.shared_parameters == ["k"] and mp.n_constraints == sum(p.n_constraints for p in phases) + 3
    assert [p.parameters["k"] for p in shared.phases] == pytest.approx([shared.parameters["k"]] * 2, abs=1e-10)
    one = HLGL(gain_leg(0.0, 1.0, initial=(0.0, 0.0), final=(1.0, 0.0)), 12).solve()
    assert shared.parameters["k"] == pytest.approx(one.parameters["k"], rel=1e-8)
    assert shared.objective == pytest.approx(one.objective, rel=1e-8)
    local = MultiPhase(phases, local_parameters=["k"]).solve()
    k0, k1 = (p.parameters["k"] for p in local.phases)
    assert k0 < shared.parameters["k"] < k1 and local.objective < shared.objective and local.parameters == {}
    with pytest.raises(ValueError, match=r"local_parameters \['c'\] are not free parameters of any phase"):
        MultiPhase(phases, local_parameters=["c"])


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
    sol = MultiPhase([HLGL(free, 5), HLGL(costly, 5)]).solve()
    assert sol.phases[0].objective == 0.0 and sol.objective == pytest.approx(sol.phases[1].objective)
    # phase 0 can bring the state to (0.05, 0) itself (|u| <= 1 reaches 0.0625 at rest in 0.5), then phase 1 costs 0
    assert sol.objective == pytest.approx(0.0, abs=1e-8)
    feasible = HLGL(phase(0.0, 1.0, False, x={"initial": 0.0, "final": 0.2}, v={"initial": 0.0, "final": 0.0}), 5)
    only = feasible.solve()
    assert only.objective == 0.0 and only.converged and abs(only.state(1.0)[0] - 0.2) < 1e-8
