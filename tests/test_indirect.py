"""From a direct solution to a certified extremal in one call (ocpkit.indirect), against closed forms."""

import numpy as np
import pytest
from test_shooting import gain_optimum, gain_problem
from test_structure import race, saturated  # closed forms: switch at 1, t_f = 2; J = 3/8 - sqrt(3)/12

from ocpkit import HLGL, Outcome, Radau, SolverError
from ocpkit.indirect import Certificate, Check, certify, to_extremal
from ocpkit.structure import control_structure


def test_a_bang_bang_extremal_from_radau_in_one_call():
    direct = Radau(race(), 4, 15).solve(error_threshold=None)  # the switch inside an interval: t_f off by 3e-4
    extremal = to_extremal(direct)
    assert extremal.certificate.passed and extremal.structure.kinds("u") == ["upper", "lower"]
    assert extremal.trajectory.tf == pytest.approx(2.0, abs=1e-12) and extremal.shooting.norm <= 1e-10
    assert control_structure(extremal.trajectory).junctions("u") == pytest.approx([1.0], abs=1e-10)
    assert abs(direct.tf - 2.0) > 1e-5  # the extremal is the closed form; the direct solution was not


def test_a_saturated_regular_extremal():
    """Minimum energy with |u| <= 0.5 from (1, 0) to rest in 3: J = 3/8 - sqrt(3)/12 (closed form)."""
    extremal = to_extremal(Radau(saturated(), 4, 16).solve(error_threshold=None))
    assert extremal.structure.kinds("u") == ["lower", "regular", "upper"]
    assert extremal.trajectory.objective == pytest.approx(3 / 8 - np.sqrt(3) / 12, abs=1e-12)
    assert extremal.certificate["hamiltonian_minimum"].value <= 1e-8


def test_an_extremal_with_a_free_parameter():
    """x'' = k u, min int u^2/2 + (k - 2)^2: the direct solution's k starts the shooting, which treats k as a state;
    k solves 12 / k^3 = 2 (k - 2)."""
    extremal = to_extremal(Radau(gain_problem(), 4, 4).solve(error_threshold=None))
    k = gain_optimum()
    assert extremal.shooting.free_parameters["k"] == pytest.approx(k, rel=1e-12) and extremal.certificate.passed


def test_a_solution_without_costates_is_named():
    import dataclasses

    seeing = HLGL(race(), 10).solve(error_threshold=None)
    blind = dataclasses.replace(seeing, phases=[dataclasses.replace(seeing.phases[0], costate_values=None)])
    with pytest.raises(ValueError, match="needs the direct solution's costate estimates, which .* does not give"):
        to_extremal(blind)


def test_hlgl_costates_from_its_defect_multipliers():
    """Each HLGL defect is the collocation defect at an interior Lobatto point weighted by its quadrature weight, so
    its multiplier is the costate there: minimum time, lambda = (-1, t - 1) in closed form (H = -1 at the optimum),
    to the mesh's resolution of the switch; then one call to the extremal, t_f = 2 and the switch at 1."""
    direct = HLGL(race(), 20).solve(error_threshold=None)
    t = direct.costate_times
    assert t.size == 2 * 20 + 2 and t[0] == direct.t0 and t[-1] == direct.tf
    exact = np.column_stack([-np.ones_like(t), t - 1.0])
    assert np.abs(direct.costate_values - exact)[1:-1].max() <= 1e-3
    extremal = to_extremal(direct)
    assert extremal.trajectory.tf == pytest.approx(2.0, abs=1e-12) and extremal.certificate.passed
    assert control_structure(extremal.trajectory).junctions("u") == pytest.approx([1.0], abs=1e-10)


def test_hlgl_costates_converge_with_the_mesh_on_a_smooth_problem():
    """Minimum energy with |u| <= 0.5 (regular and saturated arcs): HLGL's estimates against Radau's converged ones
    fall with the mesh, and the extremal from HLGL is the closed form J = 3/8 - sqrt(3)/12."""
    reference = Radau(saturated(), 8, 40).solve(error_threshold=None)
    errors = []
    for n in (8, 32):
        direct = HLGL(saturated(), n).solve(error_threshold=None)
        inner = direct.costate_times[1:-1]
        errors.append(np.abs(direct.costate_values[1:-1] - reference.costate(inner)).max())
    assert errors[1] < errors[0] / 4
    extremal = to_extremal(HLGL(saturated(), 16).solve(error_threshold=None))
    assert extremal.trajectory.objective == pytest.approx(3 / 8 - np.sqrt(3) / 12, abs=1e-12)


def test_a_failed_certificate_raises_with_the_extremal(monkeypatch):
    import ocpkit.indirect as indirect

    failing = Certificate((Check("structure", 1.0, 0.0, "the direct solution's arcs"),))
    assert not failing.passed and failing.failed == ["structure"] and "FAIL structure" in failing.describe()
    monkeypatch.setattr(indirect, "certify", lambda *args, **kwargs: failing)
    direct = Radau(race(), 4, 15).solve(error_threshold=None)
    with pytest.raises(SolverError, match=r"failed checks \['structure'\]") as info:
        to_extremal(direct)
    assert info.value.result.certificate is failing and info.value.outcome is Outcome.CERTIFICATE_FAILED
    kept = to_extremal(direct, raise_on_failure=False)
    assert kept.certificate is failing and not kept.converged and kept.status is Outcome.CERTIFICATE_FAILED
    assert kept.shooting.converged and kept.norm == kept.shooting.norm and kept.iterations == kept.shooting.iterations


def planar_transfer(form: str = "ball", x_final: float = 3.0, tf: float = 6.0, u2_bound: float = 1.0):
    """Rest to rest from the origin to (3, 4) in t_f = 6 with the thrust |u| <= 1 bounded in norm, fuel int |u| dt.
    Closed form: full thrust along (0.6, 0.8) to t = 1, coast, full brake from t = 5; fuel 2. Two direct forms (a
    smooth NLP over the same states): ``"lifted"``, a magnitude G in [0, 1] with ``|u|^2 <= G^2`` and the fuel
    int G dt (lossless at the optimum); ``"angle"``, a magnitude rho in [0, 1] and an angle."""
    import casadi as ca

    from ocpkit import Constraint, Control, OptimalControlProblem, State

    states = [State(n, initial=0.0, final=f) for n, f in (("x", x_final), ("y", 4.0), ("vx", 0.0), ("vy", 0.0))]
    thrust = [Control("u1", -1.0, 1.0), Control("u2", -u2_bound, u2_bound)]
    if form == "lifted":
        return OptimalControlProblem(
            "planar_transfer_lifted",
            states,
            [*thrust, Control("G", 0.0, 1.0)],
            lambda x, u, t: [x[2], x[3], u[0], u[1]],
            tf=6.0,
            lagrange=lambda x, u, t: u[2],
            path_constraints=[Constraint("norm", lambda x, u, t: u[0] ** 2 + u[1] ** 2 - u[2] ** 2, upper=0.0)],
        )
    if form == "angle":
        return OptimalControlProblem(
            "planar_transfer_angle",
            states,
            [Control("rho", 0.0, 1.0, guess=0.5), Control("angle", -2 * np.pi, 2 * np.pi, guess=0.9)],
            lambda x, u, t: [x[2], x[3], u[0] * ca.cos(u[1]), u[0] * ca.sin(u[1])],
            tf=6.0,
            lagrange=lambda x, u, t: u[0],
        )
    return OptimalControlProblem(
        "planar_transfer",
        states,
        thrust,
        lambda x, u, t: [x[2], x[3], u[0], u[1]],
        tf=tf,
        lagrange=lambda x, u, t: ca.norm_2(u),
    )


def test_a_thrust_bounded_in_norm_from_a_restated_direct_solution():
    """The direct NLP lifts the thrust's norm into a control; the shooting takes the problem as posed, |u| <= 1:
    the switching method's law over the ball, the certificate sampling the ball; the closed-form switches."""
    direct = Radau(planar_transfer("lifted"), 4, 30).solve(error_threshold=None)
    extremal = to_extremal(direct, problem=planar_transfer(), control_set="ball")
    tr = extremal.trajectory
    assert extremal.certificate.passed and "structure" not in [c.name for c in extremal.certificate.checks]
    assert tr.objective == pytest.approx(2.0, abs=1e-10)
    integration = extremal.shooting.integration
    assert integration.switchings == 2 and integration.switching_times == pytest.approx([1.0, 5.0], abs=1e-9)
    assert tr.control(np.array([0.5]))[0] == pytest.approx([0.6, 0.8], abs=1e-9)


def test_a_restatement_must_keep_the_states_and_their_conditions():
    direct = Radau(planar_transfer("lifted"), 4, 10).solve(error_threshold=None)
    with pytest.raises(ValueError, match="has the states"):
        to_extremal(direct, problem=race(), control_set="ball")
    with pytest.raises(ValueError, match="state 'x': the final value is 2.0"):
        to_extremal(direct, problem=planar_transfer(x_final=2.0), control_set="ball")
    with pytest.raises(ValueError, match="the final time is 6.05 in 'planar_transfer' and 6.0"):
        to_extremal(direct, problem=planar_transfer(tf=6.05), control_set="ball")
    with pytest.raises(
        ValueError, match=r"needs one radius: the controls of 'planar_transfer' are bounded by \[0.5, 1.0\]"
    ):
        to_extremal(direct, problem=planar_transfer(u2_bound=0.5), control_set="ball")
    with pytest.raises(ValueError, match="control_set='ball' has the switching method's law only"):
        to_extremal(direct, problem=planar_transfer(), control_set="ball", method="arcs")
    with pytest.raises(ValueError, match="control_set must be one of"):
        to_extremal(direct, control_set="sphere")


def test_an_extremal_better_than_the_direct_local_minimum_is_confirmed_by_the_direct_method():
    """With thrust angles, the direct solve stops in a worse local minimum (its braking angle sweeps round: fuel
    2.17); the shooting from its costates finds the closed form (fuel 2), which differs from it. The same
    transcription, re-solved from the extremal (the angles fitted to its thrust), confirms it: the certificate
    compares with that solution and checks that the extremal is no worse than the first."""
    direct = Radau(planar_transfer("angle"), 4, 30).solve(error_threshold=None)
    assert direct.objective > 2.1  # the worse local minimum
    extremal = to_extremal(direct, problem=planar_transfer(), control_set="ball")
    assert extremal.first_direct is direct and extremal.direct is not direct
    assert extremal.direct.objective == pytest.approx(2.0, abs=1e-3) and "confirm_s" in extremal.timings
    assert extremal.trajectory.objective == pytest.approx(2.0, abs=1e-10)
    assert extremal.certificate["first_direct_objective"].value == 0.0 and extremal.certificate.passed


def test_the_parameters_a_solution_was_solved_with_are_the_extremal_s():
    """Minimum time over a unit distance with |x''| <= a, solved at a = 2 instead of the default 1: t_f = 2 /
    sqrt(a) = sqrt(2), the switch at 1 / sqrt(2); the shooting takes the solution's a, not the problem's default."""
    from ocpkit import Control, FreeFinalTime, OptimalControlProblem, State

    pr = OptimalControlProblem(
        "race_a",
        [State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t, p: [x["v"], p["a"] * u["u"]],
        tf=FreeFinalTime(0.2, 5.0, 1.5),
        mayer=lambda x0, xf, t0, tf: tf,
        parameters={"a": 1.0},
    )
    direct = Radau(pr, 4, 15).solve(parameters={"a": 2.0}, error_threshold=None)
    extremal = to_extremal(direct)
    assert extremal.trajectory.tf == pytest.approx(np.sqrt(2.0), abs=1e-10) and extremal.certificate.passed
    assert extremal.first_direct is None  # the gaps held: no re-solve


def test_a_phase_cut_from_its_links_is_not_confirmed_by_its_own_transcription():
    """The second leg of a linked two-phase solution, alone: its transcription, warm-started from the phase's
    solution, does not give it back (the links are gone), so no re-solve stands in for the direct solution and the
    certificate's gaps fail by name."""
    from test_phases import leg

    from ocpkit import Program

    linked = Program.from_phases(
        [Radau(leg(0.0, 0.5, initial=(0.0, 0.0)), 5, 2), Radau(leg(0.5, 1.0, final=(1.0, 0.0)), 5, 2)]
    )
    phase = linked.solve().phases[1]
    with pytest.raises(SolverError, match=r"failed checks \['objective_gap', 'state_gap'\]") as info:
        to_extremal(phase)
    assert info.value.result.first_direct is None


def test_the_ball_certificate_catches_a_thrust_turned_off_its_minimiser():
    """The extremal's thrust turned by 0.03 rad: between the ball's sample points, but H drops under a small turn
    back, so hamiltonian_minimum fails; the extremal itself passes."""
    direct = Radau(planar_transfer("lifted"), 4, 30).solve(error_threshold=None)
    extremal = to_extremal(direct, problem=planar_transfer(), control_set="ball")
    tr = extremal.trajectory

    class Turned:
        def __init__(self, theta):
            self.theta = theta

        def __getattr__(self, name):
            return getattr(tr, name)

        def control(self, t):
            c, s = np.cos(self.theta), np.sin(self.theta)
            return tr.control(t) @ np.array([[c, s], [-s, c]])

    assert certify(tr, extremal.shooting)["hamiltonian_minimum"].passed
    assert not certify(Turned(0.03), extremal.shooting)["hamiltonian_minimum"].passed


def rayleigh(bounded: bool = False, tf: float = 4.5):
    """Maurer & Augustin's Rayleigh problem: min int u^2 + x1^2 over [0, 4.5] from (-5, -5), the final state free;
    its Hamiltonian flow blows up from costates a little off (p2 and x2 feed each other)."""
    import casadi as ca

    from ocpkit import Control, OptimalControlProblem, State

    return OptimalControlProblem(
        "rayleigh",
        [State("x1", initial=-5.0), State("x2", initial=-5.0)],
        [Control("u", -1.0, 1.0) if bounded else Control("u")],
        lambda x, u, t: ca.vertcat(x[1], -x[0] + x[1] * (1.4 - 0.14 * x[1] ** 2) + 4 * u[0]),
        tf=tf,
        lagrange=lambda x, u, t: u[0] ** 2 + x[0] ** 2,
    )


def test_where_the_flow_blows_up_from_the_direct_costates_multiple_shooting_from_its_nodes():
    """Single shooting from Radau 4 x 20's costates stops (the flow's step falls to nothing); multiple shooting from
    the direct solution's states and costates at its nodes converges, and single shooting from its solution gives
    the extremal, which is the refined direct optimum."""
    direct = Radau(rayleigh(), 4, 20).solve(error_threshold=None)
    with pytest.raises(SolverError):
        from ocpkit.indirect import _unknowns
        from ocpkit.shooting import Shooting, control_law

        shooting = Shooting(direct.problem, control_law(direct.problem, regularized=True), rtol=1e-10, atol=1e-10)
        shooting.solve(_unknowns(shooting, direct), tol=1e-10)
    extremal = to_extremal(direct)
    assert extremal.route.startswith("multiple shooting") and extremal.certificate.passed
    refined = Radau(rayleigh(), 4, 20).solve(mesh_tolerance=1e-9)
    assert extremal.trajectory.objective == pytest.approx(refined.objective, abs=1e-8)
    assert abs(direct.objective - refined.objective) > 1e-4  # the extremal is the refined optimum, not the first


def test_when_every_route_fails_the_error_names_them(monkeypatch):
    import ocpkit.indirect as indirect

    direct = Radau(rayleigh(), 4, 20).solve(error_threshold=None)
    monkeypatch.setattr(indirect, "SEGMENTS", (2,))  # two segments: each still long enough to blow up
    with pytest.raises(SolverError, match="multiple shooting from the direct solution's nodes failed too") as info:
        to_extremal(direct)
    assert "2 segments" in str(info.value) and "after 2000000 steps" in str(info.value)  # the single's own unit
    monkeypatch.setattr(indirect, "SEGMENTS", (10,))
    monkeypatch.setattr("ocpkit.shooting.multiple.MAX_UNKNOWNS", 40)  # 2 + 9 nodes x 5 = 47 unknowns: too many
    with pytest.raises(SolverError, match="10 segments: more than 40 unknowns"):
        to_extremal(direct)


def test_on_a_horizon_too_unstable_for_one_integration_the_multiple_shooting_solution_is_the_extremal():
    """Over t_f = 8 single shooting from the multiple-shooting solution cannot hold |S| (the flow amplifies its own
    rounding); the extremal is the multiple-shooting result, its trajectory the segments' flows joined, certified
    like any other, and it is the refined direct optimum."""
    direct = Radau(rayleigh(tf=8.0), 4, 35).solve(error_threshold=None)
    extremal = to_extremal(direct)
    assert extremal.route == "multiple shooting (10 segments)" and extremal.certificate.passed
    tr = extremal.trajectory
    assert tr.t0 == 0.0 and tr.tf == 8.0 and extremal.shooting.norm <= 1e-10
    refined = Radau(rayleigh(tf=8.0), 4, 35).solve(mesh_tolerance=1e-9)
    assert extremal.trajectory.objective == pytest.approx(refined.objective, abs=1e-7)


def test_the_extremals_dense_output_keeps_h_constant_between_steps():
    """The integrator's steps are long on bang arcs; between them the trajectory interpolates y with its first and
    second derivatives (quintic Hermite). H along 4001 samples stays at the integration's accuracy (with a cubic
    interpolant: 1.1e-5, which failed the certificate)."""
    extremal = to_extremal(Radau(rayleigh(bounded=True), 4, 20).solve(error_threshold=None), method="switching")
    assert extremal.route == "single shooting"
    assert extremal.certificate["hamiltonian_constant"].value < 1e-7
    tr = extremal.trajectory
    t = np.linspace(tr.t0, tr.tf, 4001)
    H = tr.problem.functions.hamiltonian
    import casadi as ca

    Hf = ca.Function("H", [H.x, H.p, H.u, H.t, H.P], [H.H]).map(t.size)
    P = np.repeat(np.asarray(tr.problem.full_parameters, dtype=float).reshape(-1, 1), t.size, axis=1)
    values = np.asarray(Hf(tr.state(t).T, tr.costate(t).T, tr.control(t).T, t[None, :], P)).ravel()
    assert np.ptp(values) < 1e-7 * (1 + abs(values[0]))


def test_a_re_solve_from_the_extremal_keeps_the_first_solves_ipopt_options(monkeypatch):
    from ocpkit.indirect import _resolved_from, _statement

    direct = Radau(race(), 4, 15).solve(error_threshold=None, ipopt_options={"max_iter": 321})
    assert direct.solve_options.as_kwargs() == {"ipopt_options": {"max_iter": 321}, "allow_acceptable": False}
    extremal = to_extremal(direct)
    transcription = direct.program
    seen, solve = [], transcription.solve

    def spy(*args, **kwargs):
        seen.append(kwargs.get("ipopt_options"))
        return solve(*args, **kwargs)

    monkeypatch.setattr(transcription, "solve", spy)
    again = _resolved_from(direct, _statement(direct), extremal.trajectory, extremal.shooting, restated=False)
    assert again is not None and seen == [{"max_iter": 321}] * 2


def test_the_h_minimum_is_relative_to_what_a_control_changes_not_to_terms_it_leaves():
    """The race with a state z' = K v added to the cost: the extremal is the race's, but H gains terms of order K
    the control does not touch. A thrust 1e-5 short of its bound on [0.5, 1.5] still fails the H-minimum check."""
    import casadi as ca

    from ocpkit import Control, FreeFinalTime, OptimalControlProblem, State

    K = 1e4
    problem = OptimalControlProblem(
        "race",
        [State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0), State("z", initial=0.0, scale=K)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t: ca.vertcat(x[1], u[0], K * x[1]),
        tf=FreeFinalTime(0.5, 5.0, 1.5),
        mayer=lambda x0, xf, t0, tf: tf + xf[2] - K,
    )
    extremal = to_extremal(Radau(problem, 4, 15).solve(error_threshold=None))
    assert extremal.certificate.passed and abs(extremal.trajectory.costate(0.0)[0]) > K / 2

    class Short:  # the extremal with its thrust 1e-5 short of the bound on [0.5, 1.5]
        def __getattr__(self, name):
            return getattr(extremal.trajectory, name)

        def control(self, t):
            t = np.asarray(t, dtype=float)
            U = np.array(extremal.trajectory.control(t), dtype=float)
            U[(t > 0.5) & (t < 1.5)] *= 1 - 1e-5
            return U

    assert certify(Short(), extremal.shooting)["hamiltonian_minimum"].value > 1e-7
