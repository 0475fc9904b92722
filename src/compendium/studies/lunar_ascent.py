"""Lunar ascent studies (notebook 01): the minimum time against the smoothing of the speed."""

from __future__ import annotations

import pandas as pd

from ocpkit import HLGL

from ..problems.lunar_ascent import lunar_ascent


def smoothing_study(smoothings, segments: int = 20, ipopt_options: dict | None = None):
    """Minimum time of the lunar ascent for each speed smoothing eps (HLGL, fixed mesh).

    Returns a DataFrame with eps, tf, the change of tf from the smallest eps,
    IPOPT iterations and the re-integration error.
    """
    rows = []
    for eps in smoothings:
        sol = HLGL(lunar_ascent(float(eps)), segments).solve(ipopt_options=ipopt_options)
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
