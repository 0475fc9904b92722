"""A state constraint only the final state can reach, read as its terminal condition (ocpkit.monotone), against a
closed form."""

import pytest

from ocpkit import Control, OptimalControlProblem, Radau, State
from ocpkit.indirect import certify, to_extremal
from ocpkit.monotone import as_terminal, monotone_constraints
from ocpkit.structure import control_structure


def budget(A: float = 1.0, T: float = 3.0, spend=lambda x, u: u["u"], lower: float = 0.0):
    """Go as far as a fuel budget allows: x1'' = u, u in [lower, 1], the fuel y' = spend >= 0 at most A, over T.
    Closed form (spend = u, A < T): full thrust until the budget is spent at t = A, then coast; x1(T) = A T - A^2/2,
    and the budget's multiplier nu = T - A (the switching function p2 + nu = t - T + nu vanishes at t = A)."""
    return OptimalControlProblem(
        "budget",
        [State("x1", initial=0.0), State("x2", initial=0.0), State("y", 0.0, A, initial=0.0)],
        [Control("u", lower, 1.0)],
        lambda x, u, t: [x["x2"], u["u"], spend(x, u)],
        tf=T,
        mayer=lambda x0, xf, t0, tf: -xf["x1"],
    )


def test_a_budget_and_only_a_budget_never_decreases():
    assert monotone_constraints(budget()) == {"y.upper": (0, 0.0)}  # y' = u >= 0; u = 0 holds y' = 0
    assert monotone_constraints(budget(lower=-1.0)) == {}  # y' = u can be negative: y <= A can bind before tf
    assert monotone_constraints(budget(spend=lambda x, u: u["u"] + x["x2"])) == {}  # the rate depends on the state


def test_a_budget_the_final_state_reaches_is_its_terminal_condition():
    direct = Radau(budget(), 4, 10).solve(error_threshold=None)
    extremal = to_extremal(direct)
    assert extremal.structure.kinds("u") == ["upper", "lower"] and extremal.certificate.passed
    assert extremal.trajectory.breakpoints[1] == pytest.approx(1.0, abs=1e-10)
    assert extremal.trajectory.objective == pytest.approx(-(3.0 - 0.5), abs=1e-10)
    assert extremal.shooting.multipliers == pytest.approx([2.0], abs=1e-9)
    assert extremal.certificate["terminal_multiplier_sign"].value == 0.0
    assert "y_upper_at_tf" in extremal.trajectory.problem.functions.boundary.labels
    # a multiplier of the wrong sign would gain from spending less: the check fails by name
    wrong = certify(extremal.trajectory, extremal.shooting, terminal={"y_upper_at_tf": -2.0})
    assert wrong.failed == ["terminal_multiplier_sign"]


def test_a_budget_not_spent_changes_nothing():
    direct = Radau(budget(A=5.0), 4, 10).solve(error_threshold=None)  # full thrust throughout spends 3 < 5
    structure = control_structure(direct)
    problem, same, added = as_terminal(direct.problem, structure, direct)
    assert (problem, same, added) == (direct.problem, structure, [])
    extremal = to_extremal(direct)
    assert extremal.trajectory.objective == pytest.approx(-4.5, abs=1e-10) and extremal.certificate.passed


def test_a_budget_only_just_reached_or_reached_at_the_last_instant_is_no_terminal_condition():
    """Full thrust throughout spends T: with A = T + 1e-7 or A = T the budget is reached at tf at most, no stretch
    of the horizon lies on it, and the extremal is the unconstrained one (an equality there would be degenerate)."""
    for A in (3.0 + 1e-7, 3.0):
        direct = Radau(budget(A=A), 4, 10).solve(error_threshold=None)
        extremal = to_extremal(direct)
        assert extremal.budgets == [] and extremal.certificate.passed
        assert extremal.trajectory.objective == pytest.approx(-4.5, abs=1e-9)


def test_a_continuation_through_a_budget_that_stops_binding_checks_its_multiplier():
    """Fuel now costs w per unit: the budget binds while nu = T - A - w >= 0, i.e. up to w = 2; beyond, the
    extremal with the budget's equality has nu < 0 and fails its certificate, and the structure is read again: at
    w = 2.5 the optimum spends T - w = 0.5 of the budget, J = -(0.5 T - 0.125) + 2.5 * 0.5 = -0.125."""
    from ocpkit.indirect import follow_extremal

    def priced(w):
        return OptimalControlProblem(
            "budget",
            [State("x1", initial=0.0), State("x2", initial=0.0), State("y", 0.0, 1.0, initial=0.0)],
            [Control("u", 0.0, 1.0)],
            lambda x, u, t: [x["x2"], u["u"], u["u"]],
            tf=3.0,
            mayer=lambda x0, xf, t0, tf, p: -xf["x1"] + p["w"] * xf["y"],
            parameters={"w": w},
        )

    extremal = to_extremal(Radau(priced(0.5), 4, 10).solve(error_threshold=None))
    assert extremal.budgets == ["y_upper_at_tf"] and extremal.shooting.multipliers[-1] == pytest.approx(1.5)
    path = follow_extremal(extremal, "w", [1.0, 2.5])
    last = path.extremals[-1]
    assert path.values[-1] == 2.5 and last.budgets == [] and last.certificate.passed
    assert last.trajectory.objective == pytest.approx(-0.125, abs=1e-9)
    assert any("re-detected" in how for *_, how in path.changes)
