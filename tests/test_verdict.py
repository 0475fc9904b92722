"""The whole verdict of every solve (issue 41): every part of the estimated error, warned once per failing part with
its value, the tolerance and the remedy; the notes (a free time or parameter on its bound, a control on a bound over
the whole horizon, a state no function reads); ``verdict="fast"`` says what it skipped."""

import warnings

import casadi as ca
import numpy as np
import pytest

from ocpkit import HLGL, Control, FreeFinalTime, FreeParameter, OptimalControlProblem, Radau, State
from ocpkit.accuracy import AccuracyWarning
from ocpkit.verdict import SolutionNote, Verdict, flight_tolerance

from compendium.problems import catalyst_mixing, flat_moon_ascent


def _said(call):
    """Every warning a call gives, by category: ``{category: [message, ...]}``, and its result."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = call()
    out = {}
    for w in caught:
        out.setdefault(w.category, []).append(str(w.message))
    return out, result


def test_catalyst_mixing_on_radau_4x50_warns_naming_the_objective_part_and_the_remedy():
    """COPS catalyst mixing (published -0.0480556): Radau 4 x 50 claims a better cost than the optimum; the objective
    part (about 5e-3: the NLP's cost against its control's flown cost) is said by default, with the remedy."""
    said, sol = _said(lambda: Radau(catalyst_mixing(), 4, 50).solve())
    assert sol.objective < -0.0480556  # better than the optimum: the NLP is wrong, and now it says so
    objective = [m for m in said[AccuracyWarning] if "objective error" in m]
    assert len(objective) == 1, said
    assert "exceeds 0.001" in objective[0] and "refine the mesh (solve(mesh_tolerance=...))" in objective[0]
    assert "claims a better cost than its control gives" in objective[0] and "singular arc" in objective[0]
    v = sol.verdict
    assert not v.passed and "objective" in v.failing and 2e-3 < v.objective < 2e-2
    assert v.worst[0] == "objective" and v.tolerance == 1e-3 and v.complete
    # one warning per failing part: the state's is not over 1e-3 here, so it is the only one
    assert len(said[AccuracyWarning]) == len(v.failing)


def test_the_fast_verdict_says_that_it_skipped_the_objective():
    said, sol = _said(lambda: Radau(catalyst_mixing(), 4, 50).solve(verdict="fast"))
    assert not any("objective error" in m for m in said.get(AccuracyWarning, []))
    v = sol.verdict
    assert v.skipped == ("objective",) and not v.complete and v.objective is None and "objective" not in v.parts
    assert "objective not computed (solve(verdict='fast'))" in v.describe()
    # the whole verdict is one call away
    assert sol.judge(kind="whole").objective > 2e-3


def test_an_unknown_verdict_kind_is_named():
    with pytest.raises(ValueError, match=r"verdict must be one of \('whole', 'fast'\).*got 'quick'"):
        HLGL(flat_moon_ascent(), 4).solve(verdict="quick")


def _farthest(tf_upper: float) -> OptimalControlProblem:
    """The farthest a double integrator goes from rest to rest in a free time of at most ``tf_upper``: t_f ends on
    its upper bound."""
    return OptimalControlProblem(
        "farthest",
        states=[State("x", initial=0.0), State("v", initial=0.0, final=0.0)],
        controls=[Control("u", -1.0, 1.0)],
        dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=FreeFinalTime(1.0, tf_upper, 2.0),
        mayer=lambda x0, xf, t0, tf: -xf[0],
    )


def test_a_free_final_time_on_its_bound_carries_a_note():
    said, sol = _said(lambda: HLGL(_farthest(3.0), 20).solve())
    assert sol.tf == pytest.approx(3.0, abs=1e-6)
    notes = said[SolutionNote]
    assert len(notes) == 1 and notes[0].startswith("tf: the free final time ends on its upper bound (3")
    assert "widen the bound (FreeFinalTime(lower, upper, guess))" in notes[0]
    assert [n.subject for n in sol.verdict.notes] == ["tf"]


def test_a_free_parameter_and_a_control_on_a_bound_carry_notes():
    problem = OptimalControlProblem(
        "pinned",
        states=[State("x", initial=0.0), State("y", initial=0.0)],
        controls=[Control("u", 0.0, 1.0)],
        dynamics=lambda x, u, t, p: ca.vertcat(p["k"], u[0]),
        tf=1.0,
        free_parameters=[FreeParameter("k", 0.0, 2.0, guess=1.0)],
        mayer=lambda x0, xf, t0, tf, p: (xf[0] - 5.0) ** 2 - xf[1],
    )
    said, sol = _said(lambda: HLGL(problem, 4).solve())
    subjects = sorted(n.subject for n in sol.verdict.notes)
    assert subjects == ["control u", "parameter k"], sol.verdict.notes
    notes = " | ".join(said[SolutionNote])
    assert "parameter k: the free parameter ends on its upper bound (2" in notes
    assert "control u: the control is on its upper bound 1 over the whole horizon" in notes


def test_a_state_no_function_reads_is_noted_quietly():
    """The flat moon's downrange x is read by nothing (an output by design): recorded, not warned."""
    said, sol = _said(lambda: HLGL(flat_moon_ascent(), 10).solve())
    assert SolutionNote not in said
    notes = sol.verdict.notes
    assert [n.subject for n in notes] == ["state x"] and notes[0].quiet


def test_a_met_verdict_says_nothing_and_reports_every_part():
    said, sol = _said(lambda: HLGL(flat_moon_ascent(), 10).solve())
    assert AccuracyWarning not in said
    v = sol.verdict
    assert v.passed and v.complete and set(v.parts) == {"state", "objective"}
    assert v.state == sol.state_error and v.objective < 1e-6
    assert v.describe().startswith("passed at 0.001: state")


def test_a_refined_solution_is_judged_at_its_mesh_tolerance():
    said, sol = _said(lambda: HLGL(_farthest(3.0), 10).solve(mesh_tolerance=1e-6))
    assert sol.verdict.tolerance == 1e-6 and [n.subject for n in sol.verdict.notes] == ["tf"]
    assert sum("tf: the free final time" in m for m in said[SolutionNote]) == 1


def test_a_verdict_flies_the_control_at_a_tolerance_below_its_own():
    assert flight_tolerance(1e-3) == 1e-8 and flight_tolerance(1e-6) == pytest.approx(1e-11)
    assert flight_tolerance(1e-9) == 1e-12
    sol = HLGL(flat_moon_ascent(), 10).solve(error_threshold=None)
    coarse, fine = Verdict(sol, 1e-3), sol.judge(1e-9)
    assert coarse.objective == pytest.approx(fine.objective, abs=1e-6)


def test_error_estimate_is_deprecated_in_favour_of_the_verdict():
    sol = HLGL(flat_moon_ascent(), 10).solve(error_threshold=None)
    with pytest.warns(DeprecationWarning, match=r"Solution.error_estimate is deprecated; use Solution.state_error"):
        assert sol.error_estimate == sol.state_error == sol.verdict.state
    with pytest.warns(DeprecationWarning, match=r"PhaseSolution.error_estimate is deprecated; use"):
        assert sol.phases[0].error_estimate == sol.state_error
    assert np.isfinite(sol.state_error)


def _decay() -> OptimalControlProblem:
    """x' = -k x (+ u, which the cost keeps at 0) from 1, as close to 0.01 at t = 2 as k in [0.1, 1.5] allows: k ends
    on its upper bound."""
    return OptimalControlProblem(
        "decay",
        states=[State("x", initial=1.0)],
        controls=[Control("u", -1.0, 1.0)],
        dynamics=lambda x, u, t, p: -p["k"] * x[0] + u[0],
        tf=2.0,
        free_parameters=[FreeParameter("k", 0.1, 1.5, guess=0.5)],
        lagrange=lambda x, u, t: u[0] ** 2,
        mayer=lambda x0, xf, t0, tf: 100.0 * (xf[0] - 0.01) ** 2,
    )


def test_a_free_parameter_on_its_bound_is_noted_in_one_phase_and_in_several():
    from ocpkit.program import Program

    one = HLGL(_decay(), 10).solve(error_threshold=None)
    several = Program.split(_decay(), [1.0], HLGL(intervals=5)).solve(error_threshold=None)
    for sol in (one, several):
        assert sol.parameters["k"] == pytest.approx(1.5, abs=1e-6)
        assert [n.subject for n in sol.verdict.notes] == ["parameter k"], sol.verdict.notes


def test_a_part_that_is_not_a_number_fails_the_verdict():
    """A NaN estimate in any phase, or of any path constraint, is a failing part (Python's max would drop it)."""
    from ocpkit.verdict import worst_of

    assert np.isnan(worst_of([1e-9, float("nan")])) and np.isnan(worst_of([float("nan"), 1e-9]))
    sol = HLGL(flat_moon_ascent(), 10).solve(error_threshold=None)
    v = sol.judge()
    v.state = worst_of([v.state, float("nan")])
    assert not v.passed and v.failing == ["state"] and v.worst[0] == "state"
