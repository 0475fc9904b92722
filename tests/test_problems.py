"""Test problems read their constants from data/ and validate their inputs."""

import math

import pytest

from compendium.problems import entry_landing_constants, load_problem_data, lunar_ascent, lunar_ascent_constants


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


def test_the_entry_landings_initial_state_and_glide_slope_as_parameters():
    """constants_as_parameters: the initial speed and flight-path angle held by boundary equalities, the speed cap a
    path constraint, the glide slope a parameter of its cone; at the post's values the post's optimum."""
    from ocpkit import Radau

    from compendium.problems import entry_landing

    post = Radau(entry_landing(), 10, 20).solve(error_threshold=None)
    transcription = Radau(entry_landing(constants_as_parameters=True), 10, 20)
    same = transcription.solve(error_threshold=None)
    assert same.problem.parameters == {"initial_speed_m_s": 280.0, "initial_flight_path_deg": -65.0}
    assert same.objective == pytest.approx(post.objective, abs=1e-9)
    faster = transcription.solve(same, parameters={"initial_speed_m_s": 300.0}, error_threshold=None)
    unit = entry_landing_constants()["velocity_unit_m_s"]
    assert faster.state(0.0)[2] * unit == pytest.approx(300.0, abs=1e-9) and faster.objective > post.objective
    coned = entry_landing(downrange_m=900.0, glide_slope_deg=10.0, constants_as_parameters=True)
    assert coned.parameters["glide_slope_deg"] == 10.0


def test_the_lunar_ascents_thrust_and_target_as_constants_of_the_statement():
    """lunar_ascent(a=..., altitude_km=...): another thrust or target in the paper's statement (what notebook 01's
    parameters thrust_to_weight and target_altitude_km give) is the parametrised statement solved at those values;
    given as parameters, they are the defaults."""
    from ocpkit import HLGL

    stated = HLGL(lunar_ascent(a=2.5, altitude_km=300.0), 20).solve(error_threshold=None)
    varied = HLGL(lunar_ascent(thrust_as_parameter=True, target_as_parameter=True), 20).solve(
        parameters={"a": 2.5, "altitude_km": 300.0}, error_threshold=None
    )
    assert stated.tf == pytest.approx(varied.tf, rel=1e-9) and not stated.problem.parameters
    defaults = lunar_ascent(a=2.5, altitude_km=300.0, thrust_as_parameter=True, target_as_parameter=True)
    assert defaults.parameters == {"a": 2.5, "altitude_km": 300.0}
    assert lunar_ascent().states[1].final == pytest.approx(lunar_ascent_constants()["final"]["Y"], rel=1e-15)
    with pytest.raises(ValueError, match="altitude_km must be positive"):
        lunar_ascent(altitude_km=-1.0)
    with pytest.raises(ValueError, match="a must be positive"):
        lunar_ascent(a=0.0)


def test_the_downrange_bound_follows_the_entry():
    """The bound (V0 cos gamma0)^2 / (2 a_max) of another entry: a quarter of the post's at half its horizontal
    speed (a_max depends on V0 through the lift, so the check is at the post's speed with a steeper angle)."""
    from compendium.problems import minimum_downrange_bound

    post = minimum_downrange_bound()
    steep = minimum_downrange_bound(initial_flight_path_deg=-80.0)
    ratio = (math.cos(math.radians(-80.0)) / math.cos(math.radians(-65.0))) ** 2
    assert steep["downrange_bound_m"] == pytest.approx(ratio * post["downrange_bound_m"], rel=1e-12)
    same = minimum_downrange_bound(initial_speed_m_s=280.0, initial_flight_path_deg=-65.0)
    assert same == pytest.approx(post, rel=1e-14)


def test_problem_data_parsed_once_and_copied(monkeypatch, tmp_path):
    """A TOML file is parsed once while it is unchanged; each caller gets its own copy, and an edit is seen."""
    import tomllib

    import compendium.problems._data as data

    (tmp_path / "p.toml").write_text("a = 1.0\n[b]\nc = [1, 2]\n")
    monkeypatch.setattr(data, "problem_data_dir", lambda: tmp_path)
    calls = []
    real = tomllib.load
    monkeypatch.setattr(data.tomllib, "load", lambda fh: calls.append(1) or real(fh))
    first = load_problem_data("p")
    first["b"]["c"].append(3)
    assert load_problem_data("p") == {"a": 1.0, "b": {"c": [1, 2]}}
    assert len(calls) == 1
    (tmp_path / "p.toml").write_text("a = 2.0\n")
    assert load_problem_data("p") == {"a": 2.0}
    assert len(calls) == 2


def test_notebook_01_prints_the_constants_it_solves_with():
    """lunar_ascent_constants with a run's parameters is what lunar_ascent solves with, and describe_constants (the
    printout of notebook 01) says those values, the paper's beside any that differ; the paper's run prints as
    before."""
    from compendium.studies.lunar_ascent import describe_constants

    assert describe_constants(lunar_ascent_constants()) == (
        "a = 3.0, g = 1.0, speed smoothing eps = 1e-08\n"
        "length unit 1737.4 km, time unit 1035.60 s, velocity unit 1677.67 m/s\n"
        "target: Y = 1.106596, U = 0.969795, V = 0.000000"
    )
    run = lunar_ascent_constants(1e-6, a=2.5, altitude_km=300.0)
    printed = describe_constants(run).splitlines()
    assert printed[0] == "a = 2.5 (the paper's 3.0), g = 1.0, speed smoothing eps = 1e-06 (default 1e-08)"
    assert printed[2] == "target: Y = 1.172672, U = 0.969795, V = 0.000000 (altitude 300 km; the paper's 185.2 km)"
    solved = lunar_ascent(1e-6, a=2.5, altitude_km=300.0)
    assert solved.states[1].final == run["final"]["Y"]
    x = [0.0, 1.0, 0.0, 0.0]
    rate = float(solved.dynamics(x, [0.0], 0.0)[2])
    assert rate == pytest.approx(2.5 - 0.5 * 1e-6)  # a cos(0) - g eps / 2 at rest: the thrust is 2.5
    assert describe_constants(lunar_ascent_constants(a=3.0)).startswith("a = 3.0, g")
    with pytest.raises(ValueError, match="a must be positive and finite, got -1"):
        lunar_ascent_constants(a=-1.0)
