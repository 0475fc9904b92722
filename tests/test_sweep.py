"""Build once, solve many (Transcription.solve(parameters=...), exact warm starts) and sweeps on Dask."""

import numpy as np
import pandas as pd
import pytest

from ocpkit import HLGL, Radau
from ocpkit.errors import SolverError

from compendium.problems import flat_moon_ascent, lunar_ascent
from compendium.studies.sweeps import entry_landing_point, flat_moon_point
from compendium.sweep import run_point, sweep


def test_new_parameter_values_reuse_the_nlp_and_the_ipopt_instance():
    tr = HLGL(lunar_ascent(thrust_as_parameter=True), 20)
    first = tr.solve(error_threshold=None)
    nlp, solver = tr.nlp, tr.solver()
    other = tr.solve(parameters={"a": 2.5}, error_threshold=None)
    assert tr.nlp is nlp and tr.solver() is solver
    assert other.problem.parameters == {"a": 2.5} and first.problem.parameters == {"a": 3.0}
    fresh = HLGL(lunar_ascent(thrust_as_parameter=True).replace(parameters={"a": 2.5}), 20).solve(error_threshold=None)
    assert other.tf == pytest.approx(fresh.tf, rel=1e-12)
    # the pinned parameter is not a decision variable: the same NLP size as the problem without parameters
    assert first.decision_variables == HLGL(lunar_ascent(), 20).solve(error_threshold=None).decision_variables


def test_a_solution_of_the_same_transcription_is_an_exact_warm_start():
    tr = Radau(lunar_ascent(thrust_as_parameter=True), 4, 10)
    sol = tr.solve(error_threshold=None)
    again = tr.solve(sol, error_threshold=None)
    assert again.iterations <= 1 and again.tf == pytest.approx(sol.tf, rel=1e-10)
    nearby = tr.solve(sol, parameters={"a": 2.99}, error_threshold=None)
    cold = tr.solve(parameters={"a": 2.99}, error_threshold=None)
    assert nearby.iterations < cold.iterations and nearby.tf == pytest.approx(cold.tf, rel=1e-9)


def test_unknown_parameters_are_named():
    tr = HLGL(lunar_ascent(thrust_as_parameter=True), 4)
    with pytest.raises(KeyError, match="unknown parameters \\['thrust'\\]"):
        tr.solve(parameters={"thrust": 2.0})


def test_a_sweep_on_two_workers_matches_direct_solves():
    ratios = [1.8, 2.4, 3.0, 4.5]
    table = sweep(flat_moon_point, [{"thrust_to_weight": r} for r in ratios], workers=2, progress=False)
    assert table.ok.all() and list(table.thrust_to_weight) == ratios
    tr = HLGL(flat_moon_ascent(thrust_as_parameter=True), 20)
    for r, tf in zip(ratios, table.tf_s):
        assert tf == pytest.approx(tr.solve(parameters={"thrust_to_weight": r}, error_threshold=None).tf, rel=1e-10)
    assert (table.tf_relative_error < 1e-9).all()  # HLGL 20 against the linear-tangent closed form


def test_failed_points_are_recorded_with_their_status_and_reruns_skip_done_points(tmp_path):
    cache = tmp_path / "landing.csv"
    points = [{"speed_m_s": 280.0, "flight_path_deg": -65.0}, {"speed_m_s": 300.0, "flight_path_deg": -10.0}]
    table = sweep(entry_landing_point, points, workers=2, cache=cache, progress=False)
    assert table.ok.tolist() == [True, False]
    assert table.status[1] == "Infeasible_Problem_Detected" and np.isnan(table.fuel_kg[1])
    assert "Infeasible_Problem_Detected" in table.error[1]
    # every point is in the cache: no cluster is needed (an unreachable scheduler is never contacted)
    again = sweep(entry_landing_point, points, scheduler="tcp://127.0.0.1:9", cache=cache, progress=False)
    pd.testing.assert_series_equal(again.fuel_kg, table.fuel_kg)
    assert again.status.tolist() == table.status.tolist()


def test_run_point_records_any_exception():
    def broken(x):
        raise ZeroDivisionError("no")

    row = run_point(broken, {"x": 1})
    assert row["status"] == "ZeroDivisionError" and not row["ok"] and row["error"] == "no"

    def failed(x):
        raise SolverError("IPOPT", "Maximum_Iterations_Exceeded", 3000, "")

    assert run_point(failed, {"x": 1})["status"] == "Maximum_Iterations_Exceeded"


def test_bad_sweeps_are_refused():
    with pytest.raises(ValueError, match="at least one point"):
        sweep(flat_moon_point, [])
    with pytest.raises(ValueError, match="distinct"):
        sweep(flat_moon_point, [{"thrust_to_weight": 2.0}] * 2)
    with pytest.raises(ValueError, match="clash"):
        sweep(flat_moon_point, [{"status": 1}])


def test_boundary_values_given_as_parameters_need_no_rebuild():
    """Rest to rest over a distance d in t = 1 (minimum energy): u = d (6 - 12 t), J = 6 d^2, for any d."""
    import casadi as ca

    from ocpkit import Constraint, Control, OptimalControlProblem, State

    problem = OptimalControlProblem(
        "rest_to_rest",
        [State("x", initial=0.0), State("v", initial=0.0, final=0.0)],
        [Control("u")],
        lambda x, u, t, P: ca.vertcat(x[1], u[0]),
        tf=1.0,
        lagrange=lambda x, u, t, P: u[0] ** 2 / 2,
        parameters={"d": 1.0},
        boundary_constraints=[Constraint("arrive", lambda x0, xf, t0, tf, P: xf[0] - P["d"], 0.0, 0.0)],
    )
    tr = HLGL(problem, 6)
    nlp = None
    for d in (1.0, 2.0, -0.5):
        sol = tr.solve(parameters={"d": d})
        nlp = nlp or tr.nlp
        assert tr.nlp is nlp
        assert sol.objective == pytest.approx(6 * d**2, rel=1e-9)
        assert sol.state(1.0)[0] == pytest.approx(d, abs=1e-9)


def crash_at_one(x):
    """A task that kills its worker process at x = 1 (as a segfault in a solver would)."""
    import os

    if x == 1:
        os._exit(1)
    return {"y": 2.0 * x}


def test_a_point_that_kills_its_worker_is_a_failed_point():
    table = sweep(crash_at_one, [{"x": 0}, {"x": 1}, {"x": 2}], workers=2, progress=False)
    assert table.ok.tolist() == [True, False, True]
    assert table.status[1] == "KilledWorker" and np.isnan(table.y[1]) and table.y[2] == 4.0


def test_multithreaded_workers_each_build_their_own_transcription():
    from distributed import Client, LocalCluster

    ratios = [1.8, 2.2, 2.6, 3.0, 3.4, 3.8, 4.2, 4.6]
    with (
        LocalCluster(n_workers=1, threads_per_worker=2, processes=True, dashboard_address=None) as cluster,
        Client(cluster) as client,
    ):
        table = sweep(flat_moon_point, [{"thrust_to_weight": r} for r in ratios], client=client, progress=False)
    assert table.ok.all() and (table.tf_relative_error < 1e-9).all()


def test_results_may_not_overwrite_the_sweeps_columns():
    row = run_point(lambda x: {"status": "converged"}, {"x": 1})
    assert not row["ok"] and "clash" in row["error"]
