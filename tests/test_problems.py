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
