"""Test problems read their constants from data/ and validate their inputs."""

import math

import pytest

from compendium.problems import load_problem_data, lunar_ascent, lunar_ascent_constants


def test_lunar_constants_follow_the_documented_reading():
    c = lunar_ascent_constants()
    assert c["g"] == 1.0 and c["a"] == 3.0
    assert c["final"]["Y"] == pytest.approx(1 + 185.2 / 1737.4)
    assert c["final"]["U"] == pytest.approx(1627 / math.sqrt(1.62 * 1737.4e3))
    assert c["time_unit_s"] == pytest.approx(math.sqrt(1737.4e3 / 1.62))


def test_bad_smoothing_rejected():
    with pytest.raises(ValueError, match="speed_smoothing"):
        lunar_ascent(speed_smoothing=0.0)


def test_unknown_problem_data_named():
    with pytest.raises(FileNotFoundError, match="available"):
        load_problem_data("no_such_problem")


def test_the_lunar_ascents_target_altitude_as_a_parameter():
    """The paper's statement fixes Y(t_f); as the parameter ``altitude_km`` (a boundary equality) it gives the same
    t_f at the paper's 185.2 km, and another altitude is one solve(parameters=...) away."""
    from ocpkit import HLGL

    from compendium.problems import lunar_ascent

    paper = HLGL(lunar_ascent(), 20).solve(error_threshold=None)
    transcription = HLGL(lunar_ascent(thrust_as_parameter=True, target_as_parameter=True), 20)
    same = transcription.solve(error_threshold=None)
    assert same.problem.parameters == {"a": 3.0, "altitude_km": 185.2}
    assert same.tf == pytest.approx(paper.tf, abs=1e-12)
    higher = transcription.solve(same, parameters={"altitude_km": 300.0}, error_threshold=None)
    R_km = lunar_ascent_constants()["length_unit_m"] / 1e3
    assert higher.state(higher.tf)[1] == pytest.approx(1 + 300.0 / R_km, abs=1e-12) and higher.tf > paper.tf
