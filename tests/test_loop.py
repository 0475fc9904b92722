"""A solve loop (``Transcription.loop()``, ``MultiPhase.loop()``) returns what ``solve`` returns, to the last bit."""

import numpy as np
import pytest
from _problems import fixed_gain_leg

from ocpkit import HLGL, Program, Radau, SolverError
from ocpkit.transcription.loop import LoopResult

from compendium.problems import flat_moon_ascent, lunar_ascent


@pytest.fixture(scope="module")
def lunar():
    return HLGL(lunar_ascent(thrust_as_parameter=True), 20)


def test_cold_and_warm_solves_equal_solve_bit_for_bit(lunar):
    loop = lunar.loop()
    result = loop({"a": 2.0})
    solution = lunar.solve(parameters={"a": 2.0}, error_threshold=None)
    assert isinstance(result, LoopResult) and result.converged and result.status == "Solve_Succeeded"
    assert np.array_equal(result.w, solution.nlp_result.w) and np.array_equal(result.lam_g, solution.nlp_result.lam_g)
    assert result.iterations == solution.iterations and result.objective == solution.objective
    assert result.tf == solution.tf and result.t0 == solution.t0 and result.parameters == {"a": 2.0}
    for a in (2.2, 2.5, 3.0):  # a continuation: each from the previous, loop against solve
        result, solution = (
            loop({"a": a}, guess=result),
            lunar.solve(solution, parameters={"a": a}, error_threshold=None),
        )
        assert np.array_equal(result.w, solution.nlp_result.w) and result.iterations == solution.iterations <= 4
    full = result.solution
    assert full is result.solution  # built once
    assert full.tf == solution.tf and full.problem.parameters["a"] == 3.0
    assert full.linear_solver == solution.linear_solver
    assert full.solve_options.as_kwargs() == {"ipopt_options": {}, "allow_acceptable": False}
    again = loop({"a": 3.0}, guess=full)  # a Solution of the same transcription: an exact warm start too
    assert again.iterations <= 2 and again.objective == pytest.approx(full.objective, rel=1e-12)
    assert loop().parameters == {"a": lunar.problem.parameters["a"]}  # the problem's own values


def test_another_meshs_solution_is_interpolated(lunar):
    coarse = HLGL(lunar_ascent(), 8).solve(error_threshold=None)
    result = lunar.loop()(guess=coarse)
    solution = lunar.solve(coarse, error_threshold=None)
    assert np.array_equal(result.w, solution.nlp_result.w)


def test_radau_and_linked_phases_with_one_parameter_in_both():
    """The gain k of x'' = k u, named by both phases: one value pins both (J = 6 / k^2), as ``solve`` does."""

    mp = Program.from_phases(
        [Radau(fixed_gain_leg(0.0, 0.5, initial=(0.0, 0.0)), 4, 3), HLGL(fixed_gain_leg(0.5, 1.0, final=(1.0, 0.0)), 4)]
    )
    loop = mp.loop()
    slots = mp.parameter_slots["k"]
    assert slots.size == 2
    lbw, ubw = mp.bounds({"k": 2.0})
    assert lbw[slots].tolist() == ubw[slots].tolist() == [2.0, 2.0]
    for k in (1.0, 2.0, 0.5):
        result, solution = loop({"k": k}), mp.solve(parameters={"k": k}, error_threshold=None)
        assert np.array_equal(result.w, solution.nlp_result.w)
        assert result.objective == pytest.approx(6.0 / k**2, rel=1e-9) and (result.t0, result.tf) == (0.0, 1.0)
    assert [p.problem.parameters["k"] for p in result.solution.phases] == [0.5, 0.5]


def test_bad_input_is_named(lunar):
    loop = lunar.loop()
    with pytest.raises(KeyError, match=r"unknown parameters \['b'\]"):
        loop({"b": 1.0})
    with pytest.raises(ValueError, match="parameter 'a' must be finite"):
        loop({"a": float("nan")})
    with pytest.raises(TypeError, match="parameters must be a mapping"):
        loop([2.0])


def test_a_failed_solve_is_loud_and_keeps_the_last_iterate():
    tr = HLGL(flat_moon_ascent(), 10)
    with pytest.raises(SolverError, match="Maximum_Iterations_Exceeded") as caught:
        tr.loop(ipopt_options={"max_iter": 2})()
    assert caught.value.result is not None and not caught.value.result.converged
    quiet = tr.loop(ipopt_options={"max_iter": 2}, raise_on_failure=False)()
    assert not quiet.converged and quiet.status == "Maximum_Iterations_Exceeded" and quiet.iterations == 2
    assert quiet.solution.converged is False


def test_linked_phases_keep_each_phases_value_of_a_parameter_not_given():
    """Phase 1 holds k = 1, phase 2 k = 3, and both a gain c: a loop given c alone leaves each phase's k, as solve."""

    first = fixed_gain_leg(0.0, 0.5, initial=(0.0, 0.0), parameters={"k": 1.0, "c": 1.0})
    mp = Program.from_phases(
        [HLGL(first, 4), HLGL(fixed_gain_leg(0.5, 1.0, final=(1.0, 0.0), parameters={"k": 3.0, "c": 1.0}), 4)]
    )
    loop = mp.loop()
    for given in (None, {"c": 2.0}, {"k": 2.0}):
        result, solution = loop(given), mp.solve(parameters=given, error_threshold=None)
        assert np.array_equal(result.w, solution.nlp_result.w) and result.objective == solution.objective
    assert loop({"c": 2.0}).parameters == {"k": None, "c": 2.0}  # the phases' k differ: None, not one of them
    assert loop({"k": 2.0}).parameters == {"k": 2.0, "c": 1.0}
    assert [p.problem.parameters["k"] for p in loop({"c": 2.0}).solution.phases] == [1.0, 3.0]


def test_a_result_of_another_transcriptions_loop_is_interpolated(lunar):
    coarse = HLGL(lunar_ascent(thrust_as_parameter=True), 8).loop()({"a": 2.5})
    result = lunar.loop()({"a": 2.5}, guess=coarse)
    solution = lunar.solve(coarse.solution, parameters={"a": 2.5}, error_threshold=None)
    assert np.array_equal(result.w, solution.nlp_result.w) and result.converged


def test_the_loops_parameters_are_its_own(lunar):
    loop = lunar.loop()
    loop().parameters["a"] = 99.0
    assert loop().parameters["a"] == lunar.problem.parameters["a"]
    with pytest.raises(TypeError, match="parameters must be a mapping"):
        loop([])
