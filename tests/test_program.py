"""The one program that owns the NLP (ocpkit.program): phases as the general case, one result, the schemes' contract."""

import numpy as np
import pytest
from test_phases import bd, leg

from ocpkit import (
    HLGL,
    Control,
    FreeParameter,
    Link,
    MultiPhaseProblem,
    MultiRateHLGL,
    OptimalControlProblem,
    PhaseSolution,
    Program,
    Radau,
    Scheme,
    Solution,
    SolverError,
    State,
    scheme,
)
from ocpkit.indirect import to_extremal
from ocpkit.program import Layout
from ocpkit.transcription import SCHEMES

from compendium.problems import bryson_denham


def double_integrator(control: Control, t0: float = 0.0, tf: float = 3.0, **ends) -> OptimalControlProblem:
    """Minimum energy from (1, 0) to rest at the origin (or the given end conditions), ``control`` the force."""
    x = ends.get("x", (1.0, 0.0))
    v = ends.get("v", (0.0, 0.0))
    return OptimalControlProblem(
        f"double_integrator_{t0}",
        [State("x", initial=x[0], final=x[1]), State("v", initial=v[0], final=v[1])],
        [control],
        lambda x, u, t: [x["v"], u["u"]],
        t0=t0,
        tf=tf,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
    )


# -- a control's end values ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("make", [lambda p: HLGL(p, 20), lambda p: Radau(p, 4, 20), lambda p: Radau(p, 30)])
def test_a_control_ends_at_its_final_value_on_every_scheme(make):
    """u(t_f) = 0 to 1e-9, whether the scheme has a control point at t_f (HLGL: its bounds) or not (Radau: a row on
    the last interval's polynomial extrapolated there, the control the solution reports); without the end value the
    optimal force ends far from 0 (u = 2/3 - 4t/9... here -2/3 at t_f = 3)."""
    free = make(double_integrator(Control("u", -1.0, 1.0))).solve(error_threshold=None)
    assert abs(free.control(free.tf)[0]) > 0.5
    ended = make(double_integrator(Control("u", -1.0, 1.0, initial=-0.5, final=0.0))).solve(error_threshold=None)
    assert abs(ended.control(ended.tf)[0]) < 1e-9 and abs(ended.control(ended.t0)[0] + 0.5) < 1e-9
    assert ended.objective > free.objective and ended.converged


def test_a_control_ends_at_its_final_value_in_a_phase_of_a_program():
    """The same in the last phase of a split program, on Radau (the row) and HLGL (the bound), and the
    whole-horizon control reports it."""
    whole = double_integrator(Control("u", -1.0, 1.0, final=0.0))
    for s in (Radau(nodes=4, intervals=5), HLGL(intervals=5)):
        sol = Program.split(whole, [1.5], s).solve(error_threshold=None)
        assert abs(sol.control(sol.tf)[0]) < 1e-9 and abs(sol.phase(1).control(3.0)[0]) < 1e-9
        assert sol.phase(0).problem.controls[0].final is None  # the first piece does not end the trajectory


def test_an_end_value_outside_the_bounds_is_refused_by_name():
    with pytest.raises(ValueError, match=r"final condition of 'u' \(2.0\) lies outside its bounds \[-1.0, 1.0\]"):
        Control("u", -1.0, 1.0, final=2.0)


# -- the layout: built once per mesh ------------------------------------------------------------------------------------


def test_the_layout_is_built_once_per_mesh(monkeypatch):
    """The two-mesh Bryson-Denham refinement on Radau 4 x 20 used to construct the problem-wide layout 110 times
    and its variable groups 58 times (every question recomputed them); the program builds its layout once per
    mesh, and every block and bound reads it."""
    from ocpkit.program import layout as layout_module

    built, groups, times = [], [], []
    original_build, original_init = Layout.build.__func__, layout_module.GlobalVariables.__init__
    original_groups = Radau.groups

    def count_build(cls, *args, **kwargs):
        built.append(1)
        return original_build(cls, *args, **kwargs)

    def count_times(self, *args, **kwargs):
        times.append(1)
        original_init(self, *args, **kwargs)

    def count_groups(self, problem):
        groups.append(1)
        return original_groups(self, problem)

    monkeypatch.setattr(Layout, "build", classmethod(count_build))
    monkeypatch.setattr(layout_module.GlobalVariables, "__init__", count_times)
    monkeypatch.setattr(Radau, "groups", count_groups)
    sol = Radau(bryson_denham(), 4, 20).solve(mesh_tolerance=1e-6)
    meshes = len(sol.mesh_history)
    assert meshes >= 2 and sol.refinement_outcome == "met"  # two here
    assert len(built) == len(groups) == len(times) == meshes


# -- one result for any number of phases ------------------------------------------------------------------------------


def two_legs(make=lambda p: Radau(p, 5, 2)):
    """(0, 0) to (1, 0) in t = 1 split at 1/2 as two stated phases: J = 6, u = 6 - 12 t, lambda = (-12, 12 t - 6)."""
    return Program.from_phases([make(leg(0.0, 0.5, initial=(0.0, 0.0))), make(leg(0.5, 1.0, final=(1.0, 0.0)))])


def test_a_two_phase_radau_solution_answers_its_costates_in_each_phase():
    sol = two_legs().solve()
    assert sol.has_costates and all(p.has_costates for p in sol.phases)
    t = np.array([0.1, 0.4, 0.6, 0.9])
    assert np.allclose(sol.costate(t), np.column_stack([np.full(t.size, -12.0), 12 * t - 6]), atol=1e-6)
    assert np.allclose(sol.phase(1).costate(np.array([0.75])), [[-12.0, 3.0]], atol=1e-6)
    assert np.allclose(sol.to_dataframe(t=t, costates=True)["lambda_v"], 12 * t - 6, atol=1e-6)


def test_to_extremal_certifies_a_problem_cut_into_phases():
    """The double integrator cut at t = 1 and 2 on Radau: the extremal of the whole problem, certified against the
    three phases' direct solution (J = 3/8 - sqrt(3)/12 with |u| <= 0.5)."""
    whole = double_integrator(Control("u", -0.5, 0.5))
    direct = Program.split(whole, [1.0, 2.0], Radau(nodes=4, intervals=7)).solve(error_threshold=None)
    extremal = to_extremal(direct)
    assert extremal.certificate.passed and extremal.trajectory.objective == pytest.approx(
        3 / 8 - np.sqrt(3) / 12, abs=1e-9
    )
    assert direct.problem.name == whole.name and direct.statement.source is whole


def test_to_extremal_shoots_stated_phases_as_one_boundary_value_problem():
    """Two stated legs of (0, 0) to (1, 0) in t = 1: J = 6 and lambda = (-12, 12 t - 6), the costate continuous
    across the link (both ends equal its multiplier); with a jump of 0.1 in v at t = 1/2 the costate stays
    continuous, so u = a + b t still, and v(1) = 0, x(1) = 1 give u = 5.9 - 12 t, J = 6.005."""
    extremal = to_extremal(two_legs().solve(), integrator_tol=1e-14)
    assert extremal.route.startswith("multi-phase arc shooting (2 phases")
    assert extremal.objective == pytest.approx(6.0, abs=1e-11) and extremal.certificate.passed
    t = np.array([0.1, 0.5, 0.9])
    assert np.allclose(extremal.trajectory.costate(t), np.column_stack([np.full(3, -12.0), 12 * t - 6]), atol=1e-9)
    assert extremal.certificate.second_order.route == "convexity"
    staged = Program.from_phases(
        [Radau(leg(0.0, 0.5, initial=(0.0, 0.0)), 5, 2), Radau(leg(0.5, 1.0, final=(1.0, 0.0)), 5, 2)],
        [Link(0, 1, jumps={"v": 0.1})],
    ).solve()
    jumped = to_extremal(staged, integrator_tol=1e-14)
    assert jumped.objective == pytest.approx(6.005, abs=1e-11)
    assert np.allclose(jumped.trajectory.control(t).ravel(), 5.9 - 12 * t, atol=1e-9)
    before, after = jumped.phase(0).trajectory, jumped.phase(1).trajectory
    assert after.state(0.5)[1] - before.state(0.5)[1] == pytest.approx(0.1, abs=1e-12)
    no_costates = Program.split(
        double_integrator(Control("u", -0.5, 0.5)), [1.0], MultiRateHLGL(intervals=4, ratio=2, fast=["v"])
    ).solve(error_threshold=None)
    with pytest.raises(ValueError, match="costate estimates"):
        to_extremal(no_costates)


def test_one_result_answers_the_same_questions_on_one_phase_and_many():
    """constraint, path_dataframe, summary, sample, value, reintegrate and accuracy, on a solution of one phase and of
    two; the result links its program and the user's statement; the one phase's fields answer only where there is
    one phase."""
    from ocpkit import Constraint

    one = Radau(bryson_denham(), 4, 10).solve(error_threshold=None)
    statement = MultiPhaseProblem(
        [bd(0.0, 0.5, True, x={"initial": 0.0}, v={"initial": 1.0}), bd(0.5, 1.0, True, x={"final": 0.0})],
        constraints=[Constraint("end_speed", lambda e: e[1].xf["v"], lower=-1.0, upper=-1.0)],
    )
    two = Program(statement, Radau(nodes=4, intervals=5)).solve(error_threshold=None)
    assert isinstance(one, Solution) and isinstance(two, Solution) and isinstance(two.phase(0), PhaseSolution)
    assert one.statement is one.program.statement and two.statement is statement
    for sol in (one, two):
        assert sol.objective == pytest.approx(4.0, rel=1e-3)
        c = sol.constraint("x_max")
        assert c["values"].max() <= 1 / 9 + 1e-7 and c["t"].size == c["values"].shape[0]
        assert "mu_x_max" in sol.path_dataframe().columns
        assert sol.summary()["objective"] == sol.objective
        t, x = sol.sample(lambda x, u, t: x["x"], grid=[0.25, 0.75])
        assert x == pytest.approx(sol.state(t)[:, 0])
        assert sol.value(lambda x0, xf, t0, tf: xf["v"]) == pytest.approx(-1.0, abs=1e-8)
        assert sol.reintegrate().max_error < 1e-3 and sol.accuracy.state == sol.state_error
    assert set(two.path_dataframe()["phase"]) == {"bd0.0", "bd0.5"}
    assert two.constraint("end_speed")["values"] == pytest.approx([-1.0])
    assert one.state_values.shape[1] == 2 and one.problem.name == "bryson_denham"
    with pytest.raises(AttributeError, match=r"a solution of 2 phases has a state_values per phase"):
        _ = two.state_values
    with pytest.raises(AttributeError, match="a solution of 2 phases has a problem per phase"):
        _ = two.problem


def test_one_scheme_transcribes_every_phase_and_a_shared_parameter_is_one_variable():
    """A scheme is configuration: one Radau for both phases of a stated trajectory; the gain declared once for the
    trajectory bounds both phases' (each phase's own declaration is wider)."""
    from test_phases import gain_leg

    statement = MultiPhaseProblem(
        [gain_leg(0.0, 0.5, initial=(0.0, 0.0)), gain_leg(0.5, 1.0, final=(1.0, 0.0))],
        free_parameters=[FreeParameter("k", 0.5, 1.5, guess=1.0)],
    )
    sol = Program(statement, Radau(nodes=5, intervals=3)).solve(error_threshold=None)
    assert sol.parameters["k"] == pytest.approx(1.5, abs=1e-7)  # pulled towards 2 + t, held by the declaration
    assert [p.parameters["k"] for p in sol.phases] == [sol.parameters["k"]] * 2


# -- the contract of a scheme ------------------------------------------------------------------------------------------


def test_every_registered_scheme_keeps_the_contract():
    """Each scheme, alone (configuration) and bound to a problem, is a Scheme; the table names them; a scheme alone
    has no program and says how to get one."""
    problem = double_integrator(Control("u", -1.0, 1.0))
    alone = {
        "hlgl": HLGL(intervals=4),
        "radau": Radau(nodes=3, intervals=4),
        "multirate": MultiRateHLGL(intervals=2, ratio=2, fast=["v"]),
    }
    assert set(SCHEMES) == set(alone)
    for name, s in alone.items():
        assert isinstance(s, Scheme) and isinstance(s, SCHEMES[name])
        sol = Program(problem, s).solve(error_threshold=None)
        assert sol.converged and sol.transcription == s.label
    assert scheme("RADAU", nodes=4, intervals=3).label == "Radau(nodes=4, intervals=3)"
    assert scheme("hlgl", problem, intervals=4).solve(error_threshold=None).converged
    with pytest.raises(KeyError, match=r"unknown scheme 'gauss'; the schemes are \['hlgl', 'multirate', 'radau'\]"):
        scheme("gauss", nodes=3)
    with pytest.raises(ValueError, match=r"HLGL\(intervals=4\) is a scheme alone: bind it to a problem"):
        HLGL(intervals=4).solve()
    with pytest.raises(ValueError, match="is bound to the problem 'double_integrator_0.0', not to the phase's"):
        Program(leg(0.0, 1.0, initial=(0.0, 0.0), final=(1.0, 0.0)), HLGL(problem, 4))


def test_a_refined_program_is_a_new_program_of_the_refined_schemes_and_refinement_says_when_nothing_changes():
    program = Program(bryson_denham(), HLGL(intervals=4))
    sol = program.solve(mesh_tolerance=1e-6)
    assert sol.program is not program and sol.program.statement is program.statement
    assert sol.program.scheme.intervals > 4 and program.scheme.intervals == 4
    errors = [np.zeros(program.scheme.intervals)]
    assert program.refine(errors, 1e-6) is program  # nothing over the tolerance: this very program


def test_path_constraints_are_reported_at_their_times_with_a_free_start():
    """The path-constraint times of a problem with a free initial time are the solved t0's (they were the guess's)."""
    from ocpkit import Constraint, FreeInitialTime

    problem = double_integrator(Control("u", -1.0, 1.0)).replace(
        t0=FreeInitialTime(0.0, 1.0, 0.2),
        tf=4.0,
        mayer=lambda x0, xf, t0, tf: -t0,
        path_constraints=[Constraint("v_min", lambda x, u, t: x["v"], lower=-0.8)],
    )
    sol = Radau(problem, 4, 10).solve(error_threshold=None)
    assert sol.t0 > 0.3 and sol.path_times[0] == pytest.approx(sol.t0, abs=1e-12)
    assert sol.path_times[-1] == pytest.approx(sol.tf, abs=1e-12)


def test_an_unknown_parameter_of_a_solve_is_named_before_anything_is_built():
    program = two_legs()
    with pytest.raises(KeyError, match=r"unknown parameters \['k'\]"):
        program.solve(parameters={"k": 1.0})
    assert program._nlp is None


def test_a_failed_solve_of_several_phases_keeps_its_last_iterate():
    with pytest.raises(SolverError, match="Maximum_Iterations_Exceeded") as info:
        two_legs().solve(ipopt_options={"max_iter": 0})
    assert isinstance(info.value.result, Solution) and len(info.value.result.phases) == 2


def test_penalise_control_keeps_a_running_cost_written_without_the_parameters():
    """penalise_control of a problem with parameters whose running cost is written (x, u, t) raised a TypeError."""
    from ocpkit.regularisation import penalise_control

    problem = OptimalControlProblem(
        "gain",
        [State("x", initial=1.0, final=0.0), State("v", initial=0.0, final=0.0)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t, p: [x["v"], p["k"] * u["u"]],
        tf=3.0,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
        parameters={"k": 1.0},
    )
    plain = HLGL(problem, 10).solve(error_threshold=None)
    penalised = HLGL(penalise_control(problem, 0.1), 10).solve(error_threshold=None)
    # the penalty 0.1 int u^2 adds a fifth of the energy cost at the same control (the optimum barely moves)
    assert penalised.objective == pytest.approx(plain.objective * 1.2, rel=1e-6)


# -- found in review ----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("make", [lambda p: HLGL(p, 10), lambda p: Radau(p, 4, 5)])
def test_end_values_are_not_truncated_by_integer_bounds(make):
    """A group whose bounds are all integers built its bounds as an integer array: an initial value 0.5 was held
    at 0 and a final 1.5 at 1, silently (states as well as controls)."""
    problem = OptimalControlProblem(
        "integers",
        [State("x", -2, 2, initial=0.5, final=1.5), State("v", -5, 5, initial=0, final=0)],
        [Control("u", -1, 1, initial=0.25, final=0.3)],
        lambda x, u, t: [x["v"], u["u"]],
        tf=3.0,
        lagrange=lambda x, u, t: u["u"] ** 2,
    )
    sol = make(problem).solve(error_threshold=None)
    assert sol.state(0.0)[0] == pytest.approx(0.5, abs=1e-9) and sol.state(3.0)[0] == pytest.approx(1.5, abs=1e-9)
    assert sol.control(0.0)[0] == pytest.approx(0.25, abs=1e-9) and sol.control(3.0)[0] == pytest.approx(0.3, abs=1e-9)


def test_one_phase_with_a_trajectory_cost_is_not_a_plain_problem():
    """A problem "cut" at no interior time is one phase whose Mayer term sits at the trajectory level: its solution
    reports that cost, its accuracy counts it, and its problem is the problem cut."""
    race = OptimalControlProblem(
        "race",
        [State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t: [x["v"], u["u"]],
        tf=3.0,
        mayer=lambda x0, xf, t0, tf: (xf["x"] - 1.0) ** 2,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
    )
    whole = Radau(race, 4, 10).solve(error_threshold=None)
    cut = Program.split(race, [3.0], Radau(nodes=4, intervals=10))
    assert len(cut.phases) == 1 and not cut.plain
    sol = cut.solve(error_threshold=None)
    assert sol.objective == pytest.approx(whole.objective, rel=1e-10) and not sol.single
    assert sol.phases[0].objective + sol.trajectory_cost == pytest.approx(sol.objective, rel=1e-12)
    assert sol.problem is race and sol.accuracy.objective < 1e-6


def test_a_problem_cut_into_phases_takes_one_guess_of_its_whole_horizon():
    """A solution (or a Guess) of the whole horizon starts every phase at its own window of it; the re-solve from
    an extremal of a cut problem works (it raised a TypeError)."""
    from ocpkit.indirect import _resolved_from, _statement

    whole = double_integrator(Control("u", -0.5, 0.5))
    alone = Radau(whole, 4, 21).solve(error_threshold=None)
    cut = Program.split(whole, [1.0, 2.0], Radau(nodes=4, intervals=7))
    start = cut.initial_point(alone)
    for p in cut.phases:
        x0 = start[p.to_global[p.layout.table("states")[0, 0]]]
        assert x0 == pytest.approx(alone.state(p.problem.t0)[0], abs=1e-6)
    direct = cut.solve(alone, error_threshold=None)
    extremal = to_extremal(direct)
    again = _resolved_from(direct, _statement(direct), extremal.trajectory, extremal.shooting, restated=False)
    assert again is not None and again.converged and again.objective == pytest.approx(direct.objective, rel=1e-7)


def test_one_guess_of_the_whole_horizon_starts_a_free_junction_at_the_phases_own_guess():
    """Phases whose junction times are free, given one solution of the whole horizon: each phase starts on its own
    window (its free start and end at the phase's own guesses; the trajectory's start and end at the guess's), so
    that phase k's states start at the guess's states at phase k's own time. Each phase took the guess's whole
    horizon before (every phase's states ran from the guess's start to its end, the junctions' times with them)."""
    from ocpkit import Duration, FreeFinalTime, FreeInitialTime, Guess

    whole = double_integrator(Control("u", -0.5, 0.5))
    alone = Radau(whole, 4, 21).solve(error_threshold=None)
    cuts = (1.0, 2.2)

    def piece(k, t0, tf):
        states = [
            State("x", initial=1.0 if k == 0 else None, final=0.0 if k == 2 else None),
            State("v", initial=0.0 if k == 0 else None, final=0.0 if k == 2 else None),
        ]
        return whole.replace(name=f"piece_{k}", states=states, t0=t0, tf=tf)

    pieces = [
        piece(0, 0.0, FreeFinalTime(0.5, 1.5, cuts[0])),
        piece(1, FreeInitialTime(0.5, 1.5, cuts[0]), Duration(0.5, 2.0, cuts[1] - cuts[0])),
        piece(2, FreeInitialTime(1.5, 2.8, cuts[1]), 3.0),
    ]
    program = Program.from_phases([Radau(p, 4, 7) for p in pieces])
    windows = list(zip((0.0, *cuts), (*cuts, 3.0)))

    def ends(start, p):  # x at the phase's first and last state nodes (the table: one row per state)
        table = p.layout.table("states")
        return start[p.to_global[table[0, 0]]], start[p.to_global[table[0, -1]]]

    start = program.initial_point(alone)
    for p, (a, b) in zip(program.phases, windows):
        assert ends(start, p) == pytest.approx((alone.state(a)[0], alone.state(b)[0]), abs=1e-6)
    # a Guess of the whole horizon: its functions of time follow it as a solution's do
    x = lambda t: np.interp(t, [0.0, 3.0], [1.0, 0.0])  # noqa: E731
    guessed = program.initial_point(Guess(tf=3.0, states={"x": x}))
    for p, (a, b) in zip(program.phases, windows):
        assert ends(guessed, p) == pytest.approx((x(a), x(b)), abs=1e-12)
    # one guess per phase keeps each its own times: here the whole horizon's, in every phase
    for p in program.phases:
        assert ends(program.initial_point([alone] * 3), p) == pytest.approx((1.0, alone.state(alone.tf)[0]), abs=1e-6)
    sol = program.solve(alone, error_threshold=None)
    assert sol.converged and sol.objective == pytest.approx(alone.objective, rel=1e-4)


def test_a_cut_problem_with_a_cost_at_its_cuts_is_not_shot_as_the_whole():
    """A cost at a cut time (a measurement) is not the problem cut: to_extremal shoots the phases with that cost
    (the costate jumps at the cut by its gradient), not the problem without it, and certifies the extremal, a
    global minimum (every phase convex, the cost at the cut convex)."""
    whole = double_integrator(Control("u", -0.5, 0.5))
    fit = Program.split(whole, [1.5], Radau(nodes=4, intervals=5), cost=lambda e: (e.at(1.5)["x"] - 0.5) ** 2)
    assert fit.phased.source is None
    direct = fit.solve(error_threshold=None)
    extremal = to_extremal(direct)
    assert extremal.route.startswith("multi-phase") and extremal.certificate.passed
    assert extremal.objective == pytest.approx(direct.objective, rel=1e-5)
    assert extremal.certificate.second_order.route == "convexity"
    x_cut = float(extremal.phase(0).trajectory.state(1.5)[0])
    jump = extremal.phase(1).trajectory.costate(1.5)[0] - extremal.phase(0).trajectory.costate(1.5)[0]
    assert jump == pytest.approx(-2 * (x_cut - 0.5), abs=1e-8)  # p+ = p- - d/dx (x - 1/2)^2
