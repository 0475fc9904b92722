"""The attitude ascent and the two-timescale studies (compendium.studies.fast_slow, .two_timescale)."""

import math

import numpy as np
import pandas as pd
import pytest

from ocpkit import HLGL, MultiRateHLGL

from compendium.problems import attitude_ascent, lunar_ascent
from compendium.studies.fast_slow import (
    DESIGNS,
    STANDARD,
    accuracy_study,
    cost_to_reach,
    errors_against,
    measured_times,
    transcription,
    with_measured_times,
)
from compendium.studies.two_timescale import coupling_study


@pytest.fixture(scope="module")
def reference():
    return HLGL(attitude_ascent(), 160).solve(ipopt_options={"tol": 1e-12})


def test_attitude_ascent_lifts_off_vertical_and_ends_without_pitch_rate(reference):
    x0, xf = reference.state(np.array([reference.t0, reference.tf]))
    assert x0[4] == pytest.approx(math.pi / 2) and x0[5] == 0.0
    assert xf[5] == pytest.approx(0.0, abs=1e-9)
    # the attitude costs time: slower than the paper's problem, where the thrust turns instantly
    paper = HLGL(lunar_ascent(), 40).solve()
    assert paper.tf < reference.tf < paper.tf * 1.01


def test_attitude_ascent_pitch_over_shortens_with_the_effort_weight():
    def peak_rate_time(w):
        sol = HLGL(attitude_ascent(w), 80).solve()
        t = sol.time_grid(4001)
        return t[np.argmax(np.abs(sol.state(t)[:, 5]))] / sol.tf

    a, b = peak_rate_time(1e-7), peak_rate_time(1e-9)
    assert b < a
    assert b / a == pytest.approx(0.01**0.25, rel=0.15)  # the layer scales like w^(1/4)


@pytest.mark.parametrize("w", [0.0, -1.0, float("nan"), float("inf")])
def test_attitude_ascent_rejects_bad_effort_weights(w):
    with pytest.raises(ValueError, match="effort_weight"):
        attitude_ascent(w)


def test_designs_build_the_transcriptions_they_name():
    pr = attitude_ascent()
    assert isinstance(transcription(pr, STANDARD, 40), HLGL)
    tr = transcription(pr, "Galerkin, positions slow", 40, 4)
    assert isinstance(tr, MultiRateHLGL) and tr.intervals == 10 and tr.ratio == 4
    assert [pr.state_names[i] for i in tr.slow] == ["X", "Y"]
    assert tr.control_mesh == "fine" and tr.coupling == "galerkin"
    # positions slow: (1 - 1/M)/4 of the standard's 16 variables per fine segment are saved
    std = transcription(pr, STANDARD, 40)
    assert 1 - tr.n_variables / std.n_variables == pytest.approx((1 - 1 / 4) / 4, abs=0.01)
    with pytest.raises(ValueError, match="unknown design"):
        transcription(pr, "everything fast", 40, 2)
    with pytest.raises(ValueError, match="multiple of the ratio"):
        transcription(pr, next(iter(DESIGNS)), 42, 4)


def test_errors_against_itself_are_zero_and_groups_are_relative(reference):
    e = errors_against(reference, reference, n=101)
    assert set(e) == {"positions_error", "velocities_error", "attitude_error", "control_error", "tf_error"}
    assert max(e.values()) == 0.0
    coarse = HLGL(attitude_ascent(), 20).solve(ipopt_options={"tol": 1e-12})
    e = errors_against(coarse, reference, n=101)
    s = np.linspace(0.0, 1.0, 101)
    x, x_ref = coarse.state(s * coarse.tf), reference.state(s * reference.tf)
    q = np.abs(x[:, 5] - x_ref[:, 5]).max() / max(1.0, np.abs(x_ref[:, 5]).max())
    theta = np.abs(x[:, 4] - x_ref[:, 4]).max() / max(1.0, np.abs(x_ref[:, 4]).max())
    assert e["attitude_error"] == pytest.approx(max(q, theta))
    u, u_ref = coarse.control(s * coarse.tf)[:, 0], reference.control(s * reference.tf)[:, 0]
    assert e["control_error"] == pytest.approx(np.abs(u - u_ref).max() / np.abs(u_ref).max())
    assert e["tf_error"] == pytest.approx(abs(coarse.tf - reference.tf))


def test_accuracy_study_rows_and_the_measured_times_join(reference):
    pr = attitude_ascent()
    study = accuracy_study(pr, reference, [16], [2], designs=["Galerkin, positions slow"], n=401)
    assert list(study.design) == [STANDARD, "Galerkin, positions slow"]
    assert list(study.coarse_segments) == [16, 8]
    assert (study.attitude_error > 0).all()
    times = pd.DataFrame(
        {
            "design": [STANDARD],
            "ratio": [1],
            "fine_segments": [16],
            "nlp_parameters": [study.nlp_parameters.iloc[0]],
            "iterations": [study.iterations.iloc[0]],
            "end_to_end_s": [0.5],
            "effort_weight": [1e-8],
            "ipopt_tol": [1e-10],
        }
    )
    joined = with_measured_times(study, times, 1e-8, 1e-10)
    assert joined.end_to_end_s.iloc[0] == 0.5 and np.isnan(joined.end_to_end_s.iloc[1])
    assert with_measured_times(study, times, 1e-9, 1e-10).end_to_end_s.isna().all()  # another problem
    assert with_measured_times(study, times, 1e-8, 1e-12).end_to_end_s.isna().all()  # other solves
    with pytest.raises(ValueError, match="other NLPs"):
        with_measured_times(study, times.assign(nlp_parameters=1), 1e-8, 1e-10)
    with pytest.warns(UserWarning, match="other IPOPT iteration counts"):
        with_measured_times(study, times.assign(iterations=99), 1e-8, 1e-10)
    with pytest.raises(pd.errors.MergeError):
        with_measured_times(study, pd.concat([times, times]), 1e-8, 1e-10)  # one time per case


def test_the_committed_times_are_of_the_notebooks_nlps():
    times = measured_times()
    pr = attitude_ascent()
    for row in times.itertuples():
        assert transcription(pr, row.design, row.fine_segments, row.ratio).n_variables == row.nlp_parameters


def test_cost_to_reach_interpolates_log_log():
    study = pd.DataFrame(
        {
            "design": ["d"] * 3,
            "ratio": [2] * 3,
            "fine_segments": [10, 20, 40],
            "err": [1e-2, 1e-4, 1e-6],
            "cost": [100.0, 400.0, 1600.0],
        }
    )
    r = cost_to_reach(study, "err", 1e-3, "cost")
    assert r["cost_to_reach"].iloc[0] == pytest.approx(200.0)  # halfway in log error, halfway in log cost
    assert np.isnan(cost_to_reach(study, "err", 1e-8, "cost")["cost_to_reach"].iloc[0])  # never reached
    assert np.isnan(cost_to_reach(study, "err", 1e-1, "cost")["cost_to_reach"].iloc[0])  # below on every mesh


def test_coupling_study_names_its_rows():
    pr = lunar_ascent()
    ref = HLGL(pr, 80).solve()
    df = coupling_study(pr, ["V"], [2], ["coarse", "quadrature"], [4, 8], ref, n=201)
    assert list(zip(df.coupling, df.ratio)) == [("standard", 2), ("coarse", 2), ("quadrature", 2)]
    assert {"control_error_4", "state_error_8", "control_order", "state_order"} <= set(df.columns)
