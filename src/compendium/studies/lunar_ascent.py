"""Lunar ascent studies: the constants a run solves with, the minimum time against the smoothing of the speed
(notebook 01); the flown position error of a solution (notebook 07)."""

from __future__ import annotations

import pandas as pd

from ocpkit import HLGL

from ..problems.lunar_ascent import lunar_ascent, lunar_ascent_constants


def describe_constants(constants: dict) -> str:
    """The constants of a run (:func:`~compendium.problems.lunar_ascent_constants` with the run's parameters), as
    notebook 01 prints them: thrust acceleration, gravity and speed smoothing, the units, the target; a value other
    than the data file's (the paper's reading, ``data/problems/lunar_ascent.toml``) names that one beside it."""

    def given(name: str, text: str, paper: str, whose: str = "the paper's") -> str:
        return text if constants[name] == constants["paper"][name] else f"{text} ({whose} {paper})"

    paper = constants["paper"]
    eps = given("speed_smoothing", f"{constants['speed_smoothing']:g}", f"{paper['speed_smoothing']:g}", "default")
    target = ", ".join(f"{k} = {v:.6f}" for k, v in constants["final"].items())
    if constants["altitude_km"] != paper["altitude_km"]:
        target += f" (altitude {constants['altitude_km']:g} km; the paper's {paper['altitude_km']:g} km)"
    return (
        f"a = {given('a', str(constants['a']), str(paper['a']))}, g = {constants['g']}, speed smoothing eps = {eps}\n"
        f"length unit {constants['length_unit_m'] / 1e3:.1f} km, time unit {constants['time_unit_s']:.2f} s, "
        f"velocity unit {constants['velocity_unit_m_s']:.2f} m/s\n"
        f"target: {target}"
    )


def smoothing_study(smoothings, segments: int = 20, ipopt_options: dict | None = None, **problem_options):
    """Minimum time of the lunar ascent for each speed smoothing eps (HLGL, fixed mesh).

    ``problem_options``: passed to :func:`~compendium.problems.lunar_ascent` (another thrust or target).
    Returns a DataFrame with eps, tf, the change of tf from the smallest eps,
    IPOPT iterations and the re-integration error.
    """
    rows = []
    for eps in smoothings:
        sol = HLGL(lunar_ascent(float(eps), **problem_options), segments).solve(ipopt_options=ipopt_options)
        rows.append(
            {
                "speed_smoothing": float(eps),
                "tf": sol.tf,
                "iterations": sol.iterations,
                "max_reintegration_error": sol.reintegrate().max_error,
            }
        )
    df = pd.DataFrame(rows)
    ref = df.loc[df["speed_smoothing"].idxmin(), "tf"]
    df.insert(2, "tf_minus_smallest_eps", df["tf"] - ref)
    return df


def ascent_position_error_m(solution, controls: str = "bounded") -> float:
    """Largest position error (m) of the re-integrated ascent (X or Y), flying the admissible control."""
    e = solution.reintegrate(controls=controls).max_error_by_state
    return max(e["X"], e["Y"]) * lunar_ascent_constants()["length_unit_m"]
