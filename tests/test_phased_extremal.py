"""to_extremal on multi-phase boundary value problems (ocpkit.phased_extremal, ocpkit.shooting.phases): phases with
their own dynamics, an interior point at a free time, a costate jump at an interior-point constraint, a coast phase
without controls and a linkage constraint, and the refusals, each by name."""

import math
import warnings

import numpy as np
import pytest
from scipy.optimize import brentq

from ocpkit import (
    Constraint,
    Control,
    Duration,
    FreeFinalTime,
    FreeInitialTime,
    FreeParameter,
    Link,
    MultiPhaseProblem,
    OptimalControlProblem,
    Radau,
    SolverError,
    State,
)
from ocpkit.indirect import to_extremal
from ocpkit.outcome import Outcome
from ocpkit.program import Program
from ocpkit.shooting.phases import PhasedArcResult, PhasedTrajectory

from compendium.problems.collection import reference
from compendium.problems.collection.psopt import interior_point, interior_point_cost


def waypoint() -> MultiPhaseProblem:
    """From rest at x = 0 through x = 1 (at a free time, any speed) back to rest at x = 0, in least time; the way out
    accelerates at |u| <= 1, the way back at 2|u| <= 2 (its own dynamics)."""
    out = OptimalControlProblem(
        "out",
        states=[State("x", initial=0.0, final=1.0, guess=(0.0, 1.0)), State("v", initial=0.0, guess=0.5)],
        controls=[Control("u", -1.0, 1.0, guess=0.0)],
        dynamics=lambda x, u, t: [x["v"], u["u"]],
        t0=0.0,
        tf=FreeFinalTime(0.5, 5.0, 2.0),
    )
    back = OptimalControlProblem(
        "back",
        states=[State("x", final=0.0, guess=(1.0, 0.0)), State("v", final=0.0, guess=-0.5)],
        controls=[Control("u", -1.0, 1.0, guess=0.0)],
        dynamics=lambda x, u, t: [x["v"], 2 * u["u"]],
        t0=FreeInitialTime(0.5, 5.0, 2.0),
        tf=Duration(0.1, 5.0, 1.0),
        mayer=lambda x0, xf, t0, tf: tf,
    )
    return MultiPhaseProblem([out, back])


def waypoint_solution() -> dict[str, float]:
    """The closed form up to one scalar equation: crossing x = 1 at speed v, the way out takes t1 = 2 V - v
    (V = sqrt(1 + v^2 / 2), switching at V) and the way back (v - 2 w) / 2 (w = -sqrt(2 + v^2 / 2), switching
    (v - w) / 2 after t1); the least total time's v solves v / sqrt(1 + v^2/2) + v / (2 sqrt(2 + v^2/2)) = 1/2."""
    v = brentq(lambda v: v / math.sqrt(1 + v * v / 2) + v / (2 * math.sqrt(2 + v * v / 2)) - 0.5, 0.0, 2.0, xtol=1e-15)
    V, w = math.sqrt(1 + v * v / 2), -math.sqrt(2 + v * v / 2)
    t1 = 2 * V - v
    return {"v": v, "switch_out": V, "t1": t1, "switch_back": t1 + (v - w) / 2, "tf": t1 + (v - 2 * w) / 2}


@pytest.fixture(scope="module")
def waypoint_extremal():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        direct = Program(waypoint(), Radau(nodes=4, intervals=20)).solve(mesh_tolerance=1e-8)
    return direct, to_extremal(direct, integrator_tol=1e-14)


def test_phases_with_their_own_dynamics_meet_at_a_free_time(waypoint_extremal):
    """The junctions and the final time against the closed form, |S| at the noise; H continuous at the free link
    time (its transversality condition), the costate of v continuous, that of x jumping (the interior point)."""
    direct, extremal = waypoint_extremal
    exact = waypoint_solution()
    assert isinstance(extremal.shooting, PhasedArcResult) and extremal.certificate.passed
    assert extremal.norm <= 1e-12 and extremal.route == "multi-phase arc shooting (2 phases, 4 arcs)"
    out, back = extremal.phase("out").shooting.times, extremal.phase("back").shooting.times
    assert out == pytest.approx([0.0, exact["switch_out"], exact["t1"]], abs=1e-10)
    assert back == pytest.approx([exact["t1"], exact["switch_back"], exact["tf"]], abs=1e-10)
    assert extremal.objective == pytest.approx(exact["tf"], abs=1e-12)
    t1 = exact["t1"]
    before, after = extremal.phase("out").trajectory, extremal.phase("back").trajectory
    assert after.state(t1)[1] == pytest.approx(exact["v"], abs=1e-10)

    def H(tr, dynamics):
        x, p, u = tr.state(t1), tr.costate(t1), tr.control(t1)
        return p[0] * x[1] + p[1] * dynamics * u[0]

    assert H(before, 1.0) == pytest.approx(H(after, 2.0), abs=1e-10) == pytest.approx(-1.0, abs=1e-10)
    assert before.costate(t1)[1] == pytest.approx(after.costate(t1)[1], abs=1e-10)
    assert abs(before.costate(t1)[0] - after.costate(t1)[0]) > 0.1
    # each phase certified on its own against its direct phase, and the whole against the direct objective
    assert extremal.certificate["out: structure"].passed and extremal.certificate["back: structure"].passed
    assert extremal.certificate["objective_gap"].value < 1e-8
    assert extremal.certificate.second_order.verdict == "not applicable"
    assert "free time" in extremal.certificate.second_order.detail


def test_the_phases_make_one_trajectory_where_they_share_states_and_meet(waypoint_extremal):
    _, extremal = waypoint_extremal
    tr = extremal.trajectory
    assert isinstance(tr, PhasedTrajectory) and tr.joined
    t = np.array([0.5, 2.9])
    assert tr.state(t)[:, 0] == pytest.approx(
        [extremal.phase(0).trajectory.state(0.5)[0], extremal.phase(1).trajectory.state(2.9)[0]], abs=1e-15
    )
    assert tr.objective == extremal.objective
    with pytest.raises(ValueError, match=r"phase\(name\)\.plot\(\)"):
        extremal.plot()
    with pytest.raises(KeyError, match="unknown phase 'up'"):
        extremal.phase("up")


def test_an_interior_point_constraint_makes_the_costate_jump():
    """PSOPT's interior point, x(0.75) = 0.9 between two phases: the cost against the closed form; the costate
    jumps at t = 0.75 (x is fixed there, nothing holds p); a global minimum (convex phases, an affine link)."""
    direct = Program(interior_point(), Radau(nodes=4, intervals=20)).solve(mesh_tolerance=1e-8)
    extremal = to_extremal(direct, integrator_tol=1e-14)
    assert extremal.objective == pytest.approx(interior_point_cost(), abs=1e-12)
    assert extremal.certificate.passed and extremal.certificate.second_order.route == "convexity"
    before, after = extremal.phase("before").trajectory, extremal.phase("after").trajectory

    def slope(xa: float, xb: float, T: float, s: float) -> float:  # x' of x = (xa sinh(T - s) + xb sinh s) / sinh T
        return (-xa * math.cosh(T - s) + xb * math.cosh(s)) / math.sinh(T)

    # H = x^2 + u^2 + p u gives p = -2 u = -2 x' on each phase: the jump is -2 (x'(0.75+) - x'(0.75-))
    jump = -2 * (slope(0.9, 0.75, 0.25, 0.0) - slope(1.0, 0.9, 0.75, 0.75))
    assert after.costate(0.75)[0] - before.costate(0.75)[0] == pytest.approx(jump, abs=1e-9)
    assert after.state(0.75)[0] == pytest.approx(0.9, abs=1e-14)


def test_a_coast_phase_without_controls_and_a_linkage_constraint():
    """Dymos' two-burn orbit raise: burn, coast (no control), burn, free times, the acceleration linked by a linkage
    constraint; certified, its Delta v within the direct solution's and Dymos' published 0.3995 (4 digits)."""
    ref = reference("dymos_orbit_raise")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        direct = ref.transcribe(Radau(nodes=4, intervals=20)).solve(mesh_tolerance=1e-7)
    extremal = to_extremal(direct)
    assert extremal.certificate.passed and extremal.norm <= 1e-10
    assert extremal.objective == pytest.approx(direct.objective, abs=1e-8)
    assert extremal.objective == pytest.approx(ref.published()["value"], abs=1e-4)
    assert any(label.startswith("linkage:") for label in extremal.shooting.labels)
    with pytest.raises(AttributeError, match=r"do not make one trajectory.*phase\(name\)\.state"):
        extremal.trajectory.state(1.0)


def test_what_the_multi_phase_shooting_does_not_take_is_named():
    direct = Program(waypoint(), Radau(nodes=4, intervals=10)).solve(error_threshold=None)
    with pytest.raises(ValueError, match="problem=, control_set='ball' and method='switching' are for one phase"):
        to_extremal(direct, method="switching")
    # a free parameter of the trajectory: its transversality condition is not derived
    free = waypoint()
    out = free.problems[0].replace(
        dynamics=lambda x, u, t, p: [x["v"], p["gain"] * u["u"]],
        free_parameters=[FreeParameter("gain", 0.5, 1.0, guess=1.0)],
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        solved = Program(MultiPhaseProblem([out, free.problems[1]]), Radau(nodes=4, intervals=10)).solve()
    with pytest.raises(ValueError, match=r"the phases \['out'\] have free parameters"):
        to_extremal(solved)
    # a linkage inequality
    limited = MultiPhaseProblem(free.problems, constraints=[Constraint("slow", lambda e: e["out"].xf["v"], upper=2.0)])
    with pytest.raises(ValueError, match="linkage constraints .* include inequalities"):
        to_extremal(Program(limited, Radau(nodes=4, intervals=10)).solve(error_threshold=None))
    # a free time the direct solution ends on a bound of: H's transversality condition does not hold there
    bounded = MultiPhaseProblem([free.problems[0].replace(tf=FreeFinalTime(0.5, 1.5, 1.0)), free.problems[1]])
    with pytest.raises(ValueError, match=r"phase 'out': its final time 1\.5\d* lies on its upper bound 1\.5"):
        to_extremal(Program(bounded, Radau(nodes=4, intervals=10)).solve(error_threshold=None))


def test_a_switch_on_a_link_leaves_multipliers_free_and_the_certificate_says_so():
    """Pycollo's sliding mass cuts a bang-bang move at x = 1/4, 1/2, 3/4: the switch lies on the middle link, the
    interior points bind nothing, and their multipliers are not unique; the shooting converges to the right
    trajectory and time, but to costates that need not switch on the link, which the H-minimum check names."""
    ref = reference("pycollo_sliding_mass")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        direct = ref.transcribe(Radau(nodes=4, intervals=20)).solve(mesh_tolerance=1e-8)
    extremal = to_extremal(direct, raise_on_failure=False)
    assert extremal.norm <= 1e-10 and extremal.objective == pytest.approx(2 / math.sqrt(20), abs=1e-10)
    if not extremal.certificate.passed:
        assert extremal.status is Outcome.CERTIFICATE_FAILED
        assert all(name.endswith("hamiltonian_minimum") for name in extremal.certificate.failed)
        with pytest.raises(SolverError, match="hamiltonian_minimum"):
            to_extremal(direct)


def test_a_multi_phase_extremal_is_not_continued_as_one_phase(waypoint_extremal):
    from ocpkit.indirect import follow_extremal

    _, extremal = waypoint_extremal
    with pytest.raises(ValueError, match=r"has the phases \['out', 'back'\]"):
        follow_extremal(extremal, "anything", [1.0])
    with pytest.raises(ValueError, match="one phase of a multi-phase extremal"):
        follow_extremal(extremal.phase("out"), "anything", [1.0])


def test_a_bound_met_at_a_link_only_is_named():
    """x <= 0.8 on the first phase, which the second's reward for x drives the link onto: the first phase's x is
    linear and meets its bound at its end only, where x is free (a link). The structure has no arc of it, and the
    shooting would leave it out: the chain names it instead of returning an extremal that violates it."""
    first = OptimalControlProblem(
        "rise",
        states=[State("x", upper=0.8, initial=0.0, guess=(0.0, 0.8))],
        controls=[Control("u", guess=0.8)],
        dynamics=lambda x, u, t: [u["u"]],
        tf=1.0,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
    )
    second = OptimalControlProblem(
        "reward",
        states=[State("x", final=0.0, guess=(0.8, 0.0))],
        controls=[Control("u", guess=0.0)],
        dynamics=lambda x, u, t: [u["u"]],
        t0=1.0,
        tf=2.0,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2 - 4 * x["x"],
    )
    direct = Program(MultiPhaseProblem([first, second]), Radau(nodes=4, intervals=10)).solve(error_threshold=None)
    assert direct.phase("rise").state(1.0)[0] == pytest.approx(0.8, abs=1e-6)
    with pytest.raises(ValueError, match=r"phase 'rise': the direct solution reaches 'x.upper' at the phase's end"):
        to_extremal(direct)


def test_a_jump_a_free_link_time_a_phase_mayer_term_and_a_cost_at_the_ends_together():
    """Three phases of x' = u, 2 u, u with costs u^2/2, u^2/2, u^2 on [0, T1], [T1, 2], [2, 3]; x jumps by 1/2 at the
    free T1, the first phase's Mayer term is -0.3 T1, the trajectory's cost (x(3) - 3)^2 / 2. The costate p is one
    constant (the links are plain; a jump does not move it), u = -p, -2 p, -p/2; H's jump at T1 pays the Mayer
    term, -p^2/2 + 2 p^2 = 0.3, so p = -sqrt(0.2); p = x(3) - 3 gives T1 = (9.5 + 2.5 / p) / 3 and
    J = 0.95 - 0.6 T1 (the derivation of a review of this change)."""
    a = OptimalControlProblem(
        "a",
        states=[State("x", initial=0.0, guess=(0.0, 0.5))],
        controls=[Control("u", -10.0, 10.0, guess=0.5)],
        dynamics=lambda x, u, t: [u["u"]],
        lagrange=lambda x, u, t: 0.5 * u["u"] ** 2,
        mayer=lambda x0, xf, t0, tf: -0.3 * tf,
        tf=FreeFinalTime(0.5, 1.9, 1.0),
    )
    b = OptimalControlProblem(
        "b",
        states=[State("x", guess=(1.0, 2.0))],
        controls=[Control("u", -10.0, 10.0, guess=0.5)],
        dynamics=lambda x, u, t: [2 * u["u"]],
        lagrange=lambda x, u, t: 0.5 * u["u"] ** 2,
        t0=FreeInitialTime(0.5, 1.9, 1.0),
        tf=2.0,
    )
    c = OptimalControlProblem(
        "c",
        states=[State("x", guess=(2.0, 3.0))],
        controls=[Control("u", -10.0, 10.0, guess=0.5)],
        dynamics=lambda x, u, t: [u["u"]],
        lagrange=lambda x, u, t: u["u"] ** 2,
        t0=2.0,
        tf=3.0,
    )
    mp = MultiPhaseProblem(
        [a, b, c], [Link(0, 1, jumps={"x": 0.5}), Link(1, 2)], cost=lambda e: 0.5 * (e["c"].xf["x"] - 3.0) ** 2
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        direct = Program(mp, Radau(nodes=4, intervals=20)).solve(mesh_tolerance=1e-8)
    extremal = to_extremal(direct, integrator_tol=1e-14)
    p = -math.sqrt(0.2)
    T1 = (9.5 + 2.5 / p) / 3
    assert extremal.phase("a").shooting.times[-1] == pytest.approx(T1, abs=1e-10)
    assert extremal.objective == pytest.approx(0.95 - 0.6 * T1, abs=1e-12)
    for name in "abc":
        tr = extremal.phase(name).trajectory
        assert tr.costate(np.array([tr.t0, tr.tf])).ravel() == pytest.approx([p, p], abs=1e-10)
    jump = extremal.phase("b").trajectory.state(T1)[0] - extremal.phase("a").trajectory.state(T1)[0]
    assert jump == pytest.approx(0.5, abs=1e-12)
    assert "link a -> b: time" in extremal.shooting.labels
