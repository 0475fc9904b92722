"""Standard versus two-timescale collocation: the rows of Desai & Conway's Tables 1-2 and studies beyond them."""

from __future__ import annotations

from typing import Sequence

import pandas as pd

from ocpkit import HLGL, MultiRateHLGL, OptimalControlProblem

TABLE_COLUMNS = [
    "scheme", "segments", "nlp_parameters", "defect_equations", "iterations",
    "max_state_diff_pct", "max_control_diff_pct", "build_s", "solve_s",
]


def _row(scheme: str, segments: str, solution, diff: dict | None) -> dict:
    return {
        "scheme": scheme,
        "segments": segments,
        "nlp_parameters": solution.nlp_parameters,
        "defect_equations": solution.defect_equations,
        "iterations": solution.iterations,
        "max_state_diff_pct": diff["states"] if diff else float("nan"),
        "max_control_diff_pct": diff["controls"] if diff else float("nan"),
        "build_s": solution.build_s,
        "solve_s": solution.solve_s,
    }


def compare_case(
    problem: OptimalControlProblem,
    coarse_segments: int,
    ratio: int,
    fast: Sequence[str],
    scheme: str,
    *,
    fast_interpolation: str = "coarse",
    ipopt_options: dict | None = None,
    n: int = 2001,
):
    """Solve the standard mesh (coarse x ratio segments) and the two-timescale scheme from the same guess.

    Returns ``(table, standard, two_timescale)``: a two-row DataFrame with
    :data:`TABLE_COLUMNS` (differences of the two-timescale solution from the
    standard one, :meth:`ocpkit.trajectory.Trajectory.difference`) and both solutions.
    """
    standard = HLGL(problem, coarse_segments * ratio).solve(ipopt_options=ipopt_options)
    mr = MultiRateHLGL(problem, coarse_segments, ratio=ratio, fast=fast, fast_interpolation=fast_interpolation)
    two = mr.solve(ipopt_options=ipopt_options)
    diff = two.difference(standard, n)
    rows = [
        _row("standard", str(coarse_segments * ratio), standard, None),
        _row(scheme, f"{coarse_segments}/{coarse_segments * ratio}", two, diff),
    ]
    return pd.DataFrame(rows, columns=TABLE_COLUMNS), standard, two


def side_by_side(paper: pd.DataFrame, ours: pd.DataFrame) -> pd.DataFrame:
    """Paper and compendium values next to each other, matched on the ``scheme`` column."""
    p = paper.set_index("scheme")
    o = ours.set_index("scheme")
    missing = sorted(set(p.index) - set(o.index))
    if missing:
        raise KeyError(f"schemes {missing} of the paper have no computed row")
    out = pd.DataFrame({"segments": p["segments"]})
    for col, ours_label in (
        ("nlp_parameters", "nlp_parameters"),
        ("defect_equations", "defect_equations"),
        ("iterations", "iterations (IPOPT)"),
        ("max_state_diff_pct", "max_state_diff_pct"),
        ("max_control_diff_pct", "max_control_diff_pct"),
    ):
        out[f"{col} paper"] = p[col]
        out[f"{ours_label} ours"] = o.loc[p.index, col]
    return out.reset_index()


def ratio_study(
    problem: OptimalControlProblem,
    coarse_segments: int,
    ratios: Sequence[int],
    fast: Sequence[str],
    reference,
    *,
    fast_interpolation: str = "coarse",
    ipopt_options: dict | None = None,
    n: int = 2001,
) -> pd.DataFrame:
    """NLP size and accuracy of the two-timescale scheme versus the ratio M (fixed coarse mesh).

    Each row compares the two-timescale solution with the standard solution on
    the same fine mesh (``diff_vs_standard``) and with a converged ``reference``
    solution (``error_vs_reference``), in percent.
    """
    rows = []
    for M in ratios:
        table, standard, two = compare_case(
            problem, coarse_segments, int(M), fast, "two_timescale",
            fast_interpolation=fast_interpolation, ipopt_options=ipopt_options, n=n,
        )
        err = two.difference(reference, n)
        err_std = standard.difference(reference, n)
        rows.append({
            "fast_interpolation": fast_interpolation,
            "coarse_segments": coarse_segments,
            "ratio": int(M),
            "nlp_parameters": two.nlp_parameters,
            "standard_nlp_parameters": standard.nlp_parameters,
            "iterations": two.iterations,
            "state_diff_vs_standard_pct": table.loc[1, "max_state_diff_pct"],
            "control_diff_vs_standard_pct": table.loc[1, "max_control_diff_pct"],
            "state_error_vs_reference_pct": err["states"],
            "control_error_vs_reference_pct": err["controls"],
            "standard_control_error_vs_reference_pct": err_std["controls"],
            "tf_minus_reference": two.tf - reference.tf,
        })
    return pd.DataFrame(rows)


def segments_study(
    problem: OptimalControlProblem,
    coarse_segments: Sequence[int],
    ratio: int,
    fast: Sequence[str],
    reference,
    **kwargs,
) -> pd.DataFrame:
    """:func:`ratio_study` at a fixed ratio for several coarse meshes."""
    return pd.concat(
        [ratio_study(problem, int(n), [ratio], fast, reference, **kwargs) for n in coarse_segments],
        ignore_index=True,
    )
