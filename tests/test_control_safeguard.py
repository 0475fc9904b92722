"""The box of an unbounded control that runs away (ocpkit.program.safeguard): COPS's hanging chain as published."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from ocpkit import HLGL, Control, OptimalControlProblem, Radau, State
from ocpkit.accuracy import AccuracyWarning
from ocpkit.program.safeguard import SAFEGUARD_FACTOR, control_safeguard
from ocpkit.verdict import SolutionNote

from compendium.problems import catenary, hanging_chain


@pytest.mark.parametrize(
    "scheme", [lambda p: HLGL(p, 50), pytest.param(lambda p: Radau(p, nodes=4, intervals=50), marks=pytest.mark.slow)]
)
def test_the_hanging_chain_as_published_refines_to_the_catenary(scheme):
    """COPS's statement and start, u free: the refinement reaches the closed-form catenary within 1e-6, with the
    control off its box (max |u| 18.35 at t = 1, the box 5 x 6 = 30)."""
    problem = hanging_chain()
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        sol = scheme(problem).solve(mesh_tolerance=1e-6)
    assert sol.refinement_outcome == "met"
    assert abs(sol.objective - catenary()["J"]) < 1e-6
    u = sol.phases[0].control_values[:, 0]
    assert 17.5 < np.max(np.abs(u)) < 30.0 - 1e-3


def test_a_coarse_mesh_holds_the_runaway_in_its_box_and_says_so():
    """Unbounded, HLGL 20's NLP takes u to 304 and the energy to 4.927, below the catenary's 5.068; held in the box
    [-30, 30] it stops on the box, and the warning names the control, its box and the fix."""
    problem = hanging_chain()
    guard = control_safeguard(HLGL(problem, 20).program)
    assert guard is not None and set(guard.names) == {"u"} and guard.limits[0] == pytest.approx(SAFEGUARD_FACTOR * 6)
    with pytest.warns(SolutionNote, match=r"control u: the unbounded control ran away .* box \+/-30") as caught:
        sol = HLGL(problem, 20).solve()
    said = [str(w.message) for w in caught if "unbounded control ran away" in str(w.message)]
    assert len(said) == 1 and "declare the control's bounds" in said[0]
    assert sol.held_controls == {"u": pytest.approx(30.0)} and [n.subject for n in sol.verdict.notes] == ["control u"]
    assert sol.converged and np.max(np.abs(sol.phases[0].control_values)) == pytest.approx(30.0, rel=1e-6)
    assert 5.0 < sol.objective < catenary()["J"]


def test_the_solve_the_box_replaces_is_counted_as_discarded_on_its_mesh(ipopt_iterations):
    """Refined from HLGL 20, the first mesh is solved twice, unbounded then in the box, and keeps the box's: the
    unbounded solve's iterations are that mesh's ``discarded_iterations``, the box's its ``ipopt_iterations``."""
    iterations = ipopt_iterations
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        warnings.simplefilter("ignore", SolutionNote)
        sol = HLGL(hanging_chain(), 20).solve(mesh_tolerance=1e-6, max_mesh_iterations=1)
    first = sol.mesh_history[0]
    assert sol.held_controls == {"u": pytest.approx(30.0)} and len(iterations) == 2
    assert first.discarded_iterations == iterations[0] > 0 and first.ipopt_iterations == iterations[1]


def test_no_box_without_a_guess_or_with_a_bound():
    """A control with a bound, or without a guess of its own, gets no box: those NLPs are the user's, unchanged."""

    def problem(**control) -> OptimalControlProblem:
        return OptimalControlProblem(
            "double_integrator",
            states=[State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
            controls=[Control("a", **control)],
            dynamics=lambda x, u, t: [x[1], u[0]],
            tf=1.0,
            lagrange=lambda x, u, t: u[0] ** 2,
        )

    assert control_safeguard(HLGL(problem(), 10).program) is None
    assert control_safeguard(HLGL(problem(guess=1.0, lower=-10.0), 10).program) is None
    guard = control_safeguard(HLGL(problem(guess=(1.0, -1.0)), 10).program)
    assert guard is not None and guard.indices.size == 41 and guard.limits[0] == 5.0
    # the optimum (a = 6 - 12 t, up to 6) lies beyond the box of 5: the unbounded solution, which the mesh resolves
    # exactly, is kept, and nothing is said
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        sol = HLGL(problem(guess=(1.0, -1.0)), 10).solve()
    assert sol.objective == pytest.approx(12.0, rel=1e-8)
