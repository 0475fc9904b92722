"""Multiple shooting over arcs (ocpkit.shooting.arcs), each arc type's derived flow against a closed form or a
published value, and the certificate catching a wrong extremal."""

import dataclasses

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import brentq
from test_shooting import gain_problem
from test_structure import saturated

from ocpkit import (
    HLGL,
    Constraint,
    Control,
    FreeFinalTime,
    OptimalControlProblem,
    Outcome,
    Program,
    Radau,
    SolverError,
    State,
)
from ocpkit.certificate import _arc_conditions, certify
from ocpkit.indirect import follow_extremal, to_extremal
from ocpkit.shooting.arcs import ArcShooting, ArcType, arc_sequence
from ocpkit.structure import Arc, Structure, control_structure

from compendium.paper import paper_table
from compendium.problems import (
    catalyst_mixing,
    double_integrator,
    double_integrator_solution,
    double_integrator_thrusters,
    free_flying_robot,
    free_flying_robot_net,
    goddard_constants,
    goddard_rocket,
    orbit_raising,
    rayleigh_mixed,
    tumour,
)


def parking(sign: float = 1.0):
    """min int sign x^2 dt, x' = u, |u| <= 1, x(0) = 1, t_f = 2. sign = 1: u = -1 to t = 1, then the singular arc
    x = 0, u = 0 (order one: phi = p, phi' = -2x, phi'' = -2u); J = 1/3."""
    return OptimalControlProblem(
        "parking",
        [State("x", initial=1.0)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t: [u["u"]],
        tf=2.0,
        lagrange=lambda x, u, t: sign * x["x"] ** 2,
    )


def test_a_singular_arc_against_its_closed_form():
    extremal = to_extremal(Radau(parking(), 4, 10).solve(error_threshold=None))
    assert extremal.structure.kinds("u") == ["lower", "singular"]
    tr = extremal.trajectory
    assert tr.breakpoints == pytest.approx([0.0, 1.0, 2.0], abs=1e-9)
    assert tr.objective == pytest.approx(1 / 3, abs=1e-9)
    assert np.abs(tr.control(np.linspace(1.05, 2.0, 20))).max() <= 1e-9  # the derived feedback: u = 0
    assert extremal.shooting.norm <= 1e-10 and extremal.certificate.passed


def test_singular_arcs_either_side_of_a_state_constraint_against_the_closed_form():
    """min int (x - g)^2, g = 0.8 sin(pi t / 2), x' = u, |u| <= 2, x <= 0.5, x(2) = 0.3: singular (x = g) until g
    reaches 0.5 at t1 = (2/pi) asin(0.625), on the bound to t2 = 2 - t1, singular again, then full thrust from t3,
    where g(t3) + 2 (2 - t3) = 0.3. The singular arc after the boundary arc keeps its entry conditions."""
    problem = OptimalControlProblem(
        "track",
        [State("x", -1.0, 0.5, initial=0.0, final=0.3)],
        [Control("u", -2.0, 2.0)],
        lambda x, u, t: [u["u"]],
        tf=2.0,
        lagrange=lambda x, u, t: (x["x"] - 0.8 * ca.sin(np.pi * t / 2)) ** 2,
    )
    extremal = to_extremal(Radau(problem, 4, 40).solve(error_threshold=None))
    assert extremal.structure.kinds("u") == ["singular", "boundary", "singular", "upper"]
    t1 = 2 / np.pi * np.arcsin(0.625)
    t3 = brentq(lambda t: 0.8 * np.sin(np.pi * t / 2) + 2 * (2 - t) - 0.3, 1.6, 2.0)
    assert extremal.trajectory.breakpoints[1:-1] == pytest.approx([t1, 2 - t1, t3], abs=1e-9)
    assert extremal.certificate.passed


def test_a_mixed_constraint_next_to_a_bang_arc():
    """max x(2), x' = u, u in [0, 1], u <= x, x(0) = 0.5: u = x until x = 1 at t = ln 2, then full: H is affine
    in u, so at the junction the control is continuous (not the multiplier zero)."""
    problem = OptimalControlProblem(
        "greedy",
        [State("x", initial=0.5)],
        [Control("u", 0.0, 1.0)],
        lambda x, u, t: [u["u"]],
        tf=2.0,
        mayer=lambda x0, xf, t0, tf: -xf["x"],
        path_constraints=[Constraint("below", lambda x, u, t: u["u"] - x["x"], upper=0.0)],
    )
    extremal = to_extremal(Radau(problem, 4, 20).solve(mesh_tolerance=1e-7))
    assert extremal.trajectory.breakpoints[1:-1] == pytest.approx([np.log(2)], abs=1e-10)
    assert extremal.trajectory.objective == pytest.approx(np.log(2) - 3, abs=1e-9) and extremal.certificate.passed


def test_one_unknown_and_explicit_time():
    """x' = u, x(0) = 0, x(1) = 1, min int u^2/2 + t x: the one unknown p0 = -5/6, J = 37/45 (closed form)."""
    problem = OptimalControlProblem(
        "one_unknown",
        [State("x", initial=0.0, final=1.0)],
        [Control("u")],
        lambda x, u, t: [u["u"]],
        tf=1.0,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2 + t * x["x"],
    )
    extremal = to_extremal(Radau(problem, 4, 10).solve(error_threshold=None))
    assert extremal.shooting.z == pytest.approx([-5 / 6], abs=1e-10)
    assert extremal.trajectory.objective == pytest.approx(37 / 45, abs=1e-9) and extremal.certificate.passed


def test_two_controls_switching_together():
    """Two double integrators raced rest to rest in least time, side by side: both controls switch at t = 1, each by
    its own switching condition (not one condition twice); t_f = 2."""
    problem = OptimalControlProblem(
        "twin_race",
        [
            State("x", initial=0.0, final=1.0),
            State("v", initial=0.0, final=0.0),
            State("y", initial=0.0, final=1.0),
            State("w", initial=0.0, final=0.0),
        ],
        [Control("a", -1.0, 1.0), Control("b", -1.0, 1.0)],
        lambda x, u, t: [x["v"], u["a"], x["w"], u["b"]],
        tf=FreeFinalTime(0.5, 5.0, 1.5),
        mayer=lambda x0, xf, t0, tf: tf,
    )
    extremal = to_extremal(Radau(problem, 4, 15).solve(error_threshold=None), method="arcs")
    assert extremal.trajectory.breakpoints == pytest.approx([0.0, 1.0, 2.0], abs=1e-12)
    assert extremal.certificate.passed


def test_the_generalised_legendre_clebsch_check_can_fail():
    """Maximising int x^2 (sign -1) along the same arcs: x = 0 is a singular extremal there, but a maximum of the
    cost along the arc: (-1)^1 d/du phi'' = -2 < 0 violates Kelley's condition."""
    problem = parking(-1.0)
    shooting = ArcShooting(problem, [(ArcType(("lower",)), 0.0, 1.0), (ArcType(("singular",)), 1.0, 2.0)])
    result = shooting.solve(np.array([-1.0, 1.0, 0.0, 0.0]))  # p0, t1, (x, p) at t1
    tr = result.trajectory
    t = np.linspace(0.0, 2.0, 201)
    kelley, _ = _arc_conditions(tr, t, tr.state(t), tr.costate(t), np.zeros(0))
    assert kelley == pytest.approx(1.0)
    good = to_extremal(Radau(parking(), 4, 10).solve(error_threshold=None)).certificate
    assert good["legendre_clebsch"].value == 0.0


def test_bang_bang_with_two_controls_against_the_closed_form():
    """The fuel-optimal double integrator with two thrusters: brake to t1, coast, push from t2 (closed form)."""
    direct = Radau(double_integrator_thrusters(), 4, 20).solve(error_threshold=None)
    extremal = to_extremal(direct, method="arcs")
    exact = double_integrator_solution()
    assert extremal.trajectory.breakpoints[1:-1] == pytest.approx([exact.t1, exact.t2], abs=1e-11)
    assert extremal.certificate.passed


def test_a_mixed_constraint_boundary_arc_against_its_closed_form():
    """min int (u - 2)^2 / 2 over [0, 1], x' = u, x(0) = 1, u <= x: on the boundary u = x = e^t until x = 2, at
    t = ln 2, where the multiplier mu = 2 e^-t - e^t / 2 reaches 0; then u = 2. J = (4 ln 2 - 5/2) / 2."""
    problem = OptimalControlProblem(
        "follow_the_state",
        [State("x", initial=1.0)],
        [Control("u")],
        lambda x, u, t: [u["u"]],
        tf=1.0,
        lagrange=lambda x, u, t: (u["u"] - 2) ** 2 / 2,
        path_constraints=[Constraint("below", lambda x, u, t: u["u"] - x["x"], upper=0.0)],
    )
    extremal = to_extremal(Radau(problem, 4, 20).solve(mesh_tolerance=1e-7))
    assert [str(a).split(" on")[0] for a in extremal.structure.of("u")] == ["boundary (below.upper)", "regular"]
    tr = extremal.trajectory
    assert tr.breakpoints == pytest.approx([0.0, np.log(2), 1.0], abs=1e-11)
    assert tr.objective == pytest.approx((4 * np.log(2) - 2.5) / 2, abs=1e-9)  # CVODES (tolerances 1e-12)
    t = np.linspace(0.0, 0.69, 7)
    assert tr.multiplier(t) == pytest.approx(2 * np.exp(-t) - np.exp(t) / 2, abs=1e-9)
    assert extremal.certificate.passed


def test_a_regular_arc_between_bounds_by_the_arc_method():
    """The saturated minimum-energy problem (closed form J = 3/8 - sqrt(3)/12) shot over its arcs: lower, regular
    (u = -p_v from H_u = 0), upper, the junctions where the regular control meets the bounds."""
    extremal = to_extremal(Radau(saturated(), 4, 16).solve(error_threshold=None), method="arcs")
    assert extremal.trajectory.objective == pytest.approx(3 / 8 - np.sqrt(3) / 12, abs=1e-9)  # CVODES, 1e-12
    assert extremal.certificate.passed and len(extremal.trajectory.breakpoints) == 4


def test_goddard_with_a_speed_limit_against_the_control_toolbox():
    """Bang, singular, boundary (v <= 0.1), off: the junctions and t_f of OptimalControl.jl's reference solution
    within 1e-9, |S| <= 1e-10, with no user-written Hamiltonian, law or shooting function."""
    direct = Radau(goddard_rocket(v_max=goddard_constants()["v_max"]), 4, 20).solve(mesh_tolerance=1e-6)
    extremal = to_extremal(direct)
    assert [a.kind for a in extremal.structure.of("T")] == ["upper", "singular", "boundary", "lower"]
    assert extremal.structure.of("T")[2].constraint == "v.upper"
    ref = paper_table("goddard_control_toolbox").set_index("quantity").value
    tr = extremal.trajectory
    assert tr.breakpoints[1:] == pytest.approx([ref.t1, ref.t2, ref.t3, ref.tf], abs=1e-9)
    # their costates are ours with the opposite sign (they maximise r(tf) with H maximised)
    assert tr.costate(0.0) == pytest.approx(-np.array([ref.p0_r, ref.p0_v, ref.p0_m]), rel=1e-7)
    assert extremal.shooting.norm <= 1e-10 and extremal.certificate.passed
    mu = tr.multiplier(np.linspace(tr.breakpoints[2], tr.breakpoints[3], 50)[1:-1])
    assert mu.min() > 0  # the speed limit's multiplier on its boundary arc


def test_a_singular_arc_recovers_the_optimum_a_chattering_direct_solution_misses():
    """Catalyst mixing on a uniform mesh: the direct control chatters on the singular arc and its cost is below the
    optimum; the extremal's is COPS' -0.0480556 (a discretised value: within one unit of its last digit)."""
    direct = Radau(catalyst_mixing(), 4, 30).solve(error_threshold=None)
    extremal = to_extremal(direct)
    assert extremal.structure.kinds("u") == ["upper", "singular", "lower"]
    published = paper_table("beyond_the_seeds").set_index(["problem", "quantity"]).value
    assert extremal.trajectory.objective == pytest.approx(published["catalyst_mixing", "objective"], abs=1e-7)
    assert direct.objective < published["catalyst_mixing", "objective"] - 1e-4


def test_a_regular_arc_with_a_boundary_equality_and_time_dependent_mass():
    """Orbit raising: the thrust angle from H_u = 0 carried as a state of the arc, v_t(tf) = sqrt(mu / r(tf)) with
    its multiplier, the mass falling with time (no H-constancy check: H is not constant)."""
    extremal = to_extremal(Radau(orbit_raising(), 4, 20).solve(mesh_tolerance=1e-6))
    published = paper_table("beyond_the_seeds").set_index(["problem", "quantity"]).value
    radius = float(extremal.trajectory.state(extremal.trajectory.tf)[0])
    assert radius == pytest.approx(published["orbit_raising", "final_radius"], abs=3e-8)  # as yapss asserts it
    assert "hamiltonian_constant" not in [c.name for c in extremal.certificate.checks]
    assert extremal.shooting.multipliers.shape == (1,) and extremal.certificate.passed


def test_boundary_arcs_of_a_mixed_constraint():
    """Rayleigh with u + x1/6 <= 0: boundary, regular, boundary, regular; J against Betts' 44.8044433 within the
    1e-7 (relative) GMAT's test of the same value asserts."""
    direct = Radau(rayleigh_mixed(), 4, 30).solve(mesh_tolerance=1e-6)
    extremal = to_extremal(direct)
    assert extremal.structure.kinds("u") == ["boundary", "regular", "boundary", "regular"]
    published = paper_table("beyond_the_seeds").set_index(["problem", "quantity"]).value
    assert extremal.trajectory.objective == pytest.approx(published["rayleigh_mixed", "objective"], rel=1e-7)
    assert extremal.certificate.passed


def test_the_certificate_catches_a_wrong_structure():
    """Rayleigh shot with its last regular arc left out (the boundary arc stretched to tf): the shooting converges,
    to an extremal whose multiplier turns negative, and the certificate says so by name."""
    direct = Radau(rayleigh_mixed(), 4, 30).solve(mesh_tolerance=1e-6)
    structure = control_structure(direct)
    arcs = arc_sequence(structure, direct.problem, direct.t0, direct.tf)[:-1]
    arcs[-1] = (arcs[-1][0], arcs[-1][1], direct.tf)
    shooting = ArcShooting(direct.problem, arcs)
    result = shooting.solve(shooting.guess(direct))
    certificate = certify(result.trajectory, result, direct, structure)
    assert "multiplier_sign" in certificate.failed and certificate["multiplier_sign"].value > 0.1


def test_a_continuation_through_the_death_of_a_boundary_arc(monkeypatch):
    """The Goddard rocket's speed limit lifted from 0.125 past the free extremal's top speed (about 0.133): the
    boundary arc shrinks, dies between 0.13 and 0.135, the structure is detected again and the continuation goes on
    to the unconstrained extremal (the COPS rocket's)."""
    problem = goddard_rocket(0.125, limit_as_parameter=True)
    extremal = to_extremal(Radau(problem, 4, 20).solve(error_threshold=None))
    assert extremal.structure.kinds("T") == ["upper", "singular", "boundary", "lower"]
    path = follow_extremal(extremal, "v_max", [0.13, 0.135, 0.14])
    assert path.values == [0.13, 0.135, 0.14] and all(e.certificate.passed for e in path.extremals)
    assert path.converged and path.status is Outcome.CONVERGED and len(path) == path.iterations == 3
    assert path[0] == (0.13, path.extremals[0]) and path.extremals[-1].converged
    assert [(v, before.count("|"), after.count("|")) for v, before, after, _ in path.changes] == [(0.135, 3, 2)]
    free = to_extremal(Radau(goddard_rocket(), 4, 20).solve(mesh_tolerance=1e-6))
    assert path.extremals[-1].trajectory.objective == pytest.approx(free.trajectory.objective, abs=1e-10)
    assert path.extremals[0].trajectory.objective > free.trajectory.objective  # the limit still binds at 0.13
    with pytest.raises(KeyError, match=r"unknown parameter 'speed'; 'goddard_rocket_speed_limit' has \['v_max'\]"):
        follow_extremal(extremal, "speed", [0.13])
    # a step that cannot be solved (the shooting refused beyond 0.13, no transcription to detect the structure
    # again): raised by default; raise_on_failure=False returns the path so far with the continuation's status
    solve = ArcShooting.solve

    def refused(self, z0, parameters=None, **options):
        if parameters is not None and parameters["v_max"] > 0.1300001:
            raise SolverError("arc shooting", "refused", 0, outcome=Outcome.STALLED)
        return solve(self, z0, parameters, **options)

    monkeypatch.setattr(ArcShooting, "solve", refused)
    stranded = dataclasses.replace(extremal, direct=None)
    with pytest.raises(SolverError, match="continuation failed with status 'failed at 0.130") as info:
        follow_extremal(stranded, "v_max", [0.13, 0.135])
    assert info.value.outcome is Outcome.STEP_TOO_SMALL
    partial = follow_extremal(stranded, "v_max", [0.13, 0.135], raise_on_failure=False)
    assert partial.values == [0.13] and not partial.converged and partial.status is Outcome.STEP_TOO_SMALL
    assert "no direct program" in partial.detail and partial.extremals[0].certificate.passed


def test_the_tumours_drug_budget_is_the_terminal_condition_it_amounts_to():
    """y' = u >= 0 and y <= A: the budget binds only at tf (ocpkit.monotone). Full dose until it is spent, then none;
    the final tumour volume is GPOPS-II's to 2.4e-8 (relative; theirs a direct method's at its mesh tolerance)."""
    extremal = to_extremal(Radau(tumour(), 4, 60).solve(error_threshold=None))
    assert extremal.structure.kinds("u") == ["upper", "lower"] and extremal.certificate.passed
    published = paper_table("beyond_the_seeds").set_index(["problem", "quantity"]).value
    final = extremal.trajectory.state(extremal.trajectory.tf)[0]
    assert final == pytest.approx(published["tumour_anti_angiogenesis", "final_tumour_volume"], rel=1e-7)
    assert extremal.shooting.multipliers[-1] > 0  # the budget binds


def test_where_the_chain_stops_it_says_which_arc_and_what_to_do():
    with pytest.raises(ValueError, match=r"has 2 controls inside their bounds: one constraint determines one"):
        to_extremal(Radau(free_flying_robot(), 4, 30).solve(error_threshold=None))
    goddard = Radau(goddard_rocket(), 4, 20).solve(error_threshold=None)
    with pytest.raises(ValueError, match=r"control 'T' has a singular arc on .*use method='arcs'"):
        to_extremal(goddard, method="switching")
    with pytest.raises(ValueError, match="method must be one of"):
        to_extremal(goddard, method="newton")


def test_arc_shooting_refuses_what_it_cannot_pose():
    l1 = double_integrator(0.5)  # lam |u| + (1 - lam) u^2: an L1 control on a regular arc
    with pytest.raises(ValueError, match=r"control\(s\) \['u'\] have an L1 cost"):
        ArcShooting(l1, [(ArcType(("regular",)), 0.0, 3.0)])
    with pytest.raises(ValueError, match="has free parameters: arc shooting does not take them yet"):
        ArcShooting(gain_problem(), [(ArcType(("regular",)), 0.0, 1.0)])
    steer = OptimalControlProblem(
        "coast",
        [State("x", initial=0.0), State("y", initial=0.0)],
        [Control("T", 0.0, 1.0), Control("theta")],
        lambda x, u, t: [u["T"] * ca.cos(u["theta"]), u["T"] * ca.sin(u["theta"])],
        tf=1.0,
        mayer=lambda x0, xf, t0, tf: -xf["x"] - xf["y"],
    )
    with pytest.raises(ValueError, match=r"H does not depend on \['theta'\] on this arc"):
        ArcShooting(steer, [(ArcType(("lower", "regular")), 0.0, 1.0)])
    problem = parking()
    with pytest.raises(ValueError, match=r"H is affine in \['u'\] on a regular arc"):
        ArcShooting(
            problem,
            [(ArcType(("upper",)), 0.0, 1.0), (ArcType(("singular",)), 1.0, 1.5), (ArcType(("regular",)), 1.5, 2.0)],
        )
    shooting = ArcShooting(problem, [(ArcType(("lower",)), 0.0, 1.0), (ArcType(("singular",)), 1.0, 2.0)])
    with pytest.raises(ValueError, match=r"z0 must have 4 entries"):
        shooting.solve(np.zeros(3))
    with pytest.raises(SolverError, match="arc shooting failed") as info:
        shooting.solve(np.array([5.0, 1.9, 3.0, 0.0]), max_iterations=1)
    assert info.value.result.norm > 1e-10 and info.value.outcome is info.value.result.status
    returned = shooting.solve(np.array([5.0, 1.9, 3.0, 0.0]), max_iterations=1, raise_on_failure=False)
    assert not returned.converged and returned.status is info.value.outcome and returned.iterations <= 1


def test_the_free_flying_robot_on_its_net_thrusts_with_l1_singular_arcs():
    """Solved directly as four nonnegative thrusts (smooth), shot on the net thrusts F = u1 - u2 with the cost |F|:
    the arcs are read in the net thrusts; F2 has a singular arc (psi2 = -1) after its first burn and before its
    last, each 0.7% of the horizon. The extremal's cost is below both published values (Betts' SOS 7.910154646 and
    GPOPS-II's 7.9101902, discretised optima)."""
    direct = Program(free_flying_robot(), HLGL(intervals=600)).solve(error_threshold=None)
    extremal = to_extremal(direct, problem=free_flying_robot_net(), method="arcs", min_share=0.005)
    assert extremal.structure.kinds("F2") == ["upper", "singular", "zero", "singular", "lower"]
    assert extremal.structure.kinds("F1") == ["lower", "zero", "upper", "zero", "lower", "zero", "upper"]
    assert extremal.certificate.passed and extremal.norm <= 1e-10
    published = paper_table("beyond_the_seeds").set_index(["problem", "quantity"]).value
    assert extremal.objective < published["free_flying_robot", "objective"]
    assert extremal.objective < published["free_flying_robot", "objective_gpops2"]
    assert extremal.objective == pytest.approx(direct.objective, rel=1e-6)
    # read as a switch (the default shortest arc), the singular arcs are missed, and the extremal of that structure
    # fails the H-minimum check where its switching function crosses -1 twice
    with pytest.raises(SolverError, match=r"failed checks \['hamiltonian_minimum'"):
        to_extremal(direct, problem=free_flying_robot_net(), method="arcs")


def test_an_l1_singular_arc_needs_a_bang_neighbour_for_its_branch():
    problem = free_flying_robot_net()
    kinds = ArcType(("zero", "singular"))
    arcs = arc_sequence(
        Structure(
            (
                Arc("F1", "zero", 0.0, 12.0),
                Arc("F2", "zero", 0.0, 1.0),
                Arc("F2", "singular", 1.0, 2.0),
                Arc("F2", "zero", 2.0, 12.0),
            )
        ),
        problem,
        0.0,
        12.0,
    )
    assert arcs[1][0] == kinds  # no branch: neither neighbour is at a bound
    with pytest.raises(ValueError, match=r"control 'F2' has an L1 cost and a singular arc with no bang arc"):
        ArcShooting(problem, arcs)


def test_a_restatement_is_read_in_its_controls_and_must_keep_the_dynamics():
    """With the default method the robot's restatement is read in its net thrusts too (the arcs route, its
    singular arcs kept by min_share); a restatement whose dynamics no controls of it reproduce is named."""
    direct = Program(free_flying_robot(), HLGL(intervals=600)).solve(error_threshold=None)
    extremal = to_extremal(direct, problem=free_flying_robot_net(), min_share=0.005)
    assert extremal.route.startswith("arc shooting") and extremal.certificate.passed
    wrong = free_flying_robot_net()
    altered = OptimalControlProblem(
        "altered",
        states=wrong.states,
        controls=wrong.controls,
        dynamics=lambda x, u, t: [x[3], x[4], x[5], u[0] * ca.cos(x[2]), u[0] * ca.sin(x[2]), 0.5 * u[1]],
        tf=wrong.tf,
        lagrange=lambda x, u, t: ca.fabs(u[0]) + ca.fabs(u[1]),
    )
    with pytest.raises(ValueError, match=r"'altered' does not give the direct solution's dynamics"):
        to_extremal(direct, problem=altered, method="arcs")


def test_an_l1_cost_with_a_quadratic_term_stays_regular():
    """lam |u| + (1 - lam) u^2: H is strictly convex in u off zero, so its interior arcs are regular, not singular
    (the saturated law, which the switching method shoots)."""
    from ocpkit.hamiltonian_form import l1_controls, piecewise_affine_controls

    problem = double_integrator(0.5)
    assert l1_controls(problem) and not piecewise_affine_controls(problem)
    assert piecewise_affine_controls(free_flying_robot_net()) == {0, 1}
    # a norm of several controls (a thrust bounded in a ball, |u| as its cost) is not piecewise affine either
    ball = OptimalControlProblem(
        "ball",
        [State("x", initial=0.0, final=1.0), State("y", initial=0.0, final=1.0)],
        [Control("ux", -1.0, 1.0), Control("uy", -1.0, 1.0)],
        lambda x, u, t: [u[0], u[1]],
        tf=2.0,
        lagrange=lambda x, u, t: ca.sqrt(u[0] ** 2 + u[1] ** 2),
    )
    assert not piecewise_affine_controls(ball)
