"""Entry-landing post-processing (notebook 03): physical units and the landing summary."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..problems.entry_landing import entry_landing_constants


def physical_histories(solution, t=None, n: int = 501):
    """Time histories of an entry-landing solution in physical units (DataFrame).

    Columns: t_s, altitude_m, downrange_m, velocity_m_s, flight_path_angle_deg,
    mass_kg, lift_fraction, thrust_fraction, thrust_kN, thrust_angle_deg.
    """
    c = entry_landing_constants()
    col = solution.to_dataframe(t=t, n=n)
    return pd.DataFrame(
        {
            "t_s": col["t"] * c["time_unit_s"],
            "altitude_m": (col["r"] - 1.0) * c["R0_m"],
            "downrange_m": col["s"] * c["R0_m"],
            "velocity_m_s": col["V"] * c["velocity_unit_m_s"],
            "flight_path_angle_deg": np.degrees(col["gamma"]),
            "mass_kg": col["m"] * c["m0_kg"],
            "lift_fraction": col["u_L"],
            "thrust_fraction": col["u_T"],
            "thrust_kN": col["u_T"] * c["Tmax"] * c["m0_kg"] * c["g0"] / 1e3,
            "thrust_angle_deg": np.degrees(col["eps"]),
        }
    )


def landing_summary(solution) -> dict:
    """Final mass (m0 units), fuel (kg) and final downrange (m) of a solution."""
    c = entry_landing_constants()
    xf = solution.state_values[-1]
    mf = float(xf[solution.problem.state_index("m")])
    return {
        "final_mass": mf,
        "fuel_kg": (c["m_initial"] - mf) * c["m0_kg"],
        "final_downrange_m": float(xf[solution.problem.state_index("s")]) * c["R0_m"],
    }


class EntryLandingSolves:
    """Radau solves of the entry landing, each mesh and set of problem options solved once.

    ``defaults`` are the problem options of the notebook (aerodynamic model, downrange,
    thrust-angle rate); :meth:`solve` overrides them per call.
    """

    def __init__(self, **defaults):
        self.defaults = defaults
        self._cache = {}

    def solve(self, nodes: int, intervals: int, **options):
        from ocpkit import Radau

        from ..problems.entry_landing import entry_landing

        key = (nodes, intervals, tuple(sorted({**self.defaults, **options}.items())))
        if key not in self._cache:
            self._cache[key] = Radau(entry_landing(**dict(key[2])), nodes, intervals).solve()
        return self._cache[key]


def position_error_m(solution, controls: str = "bounded") -> float:
    """Largest position error (m) of the re-integrated landing (radius or downrange)."""
    e = solution.reintegrate(controls=controls).max_error_by_state
    return max(e["r"], e["s"]) * entry_landing_constants()["R0_m"]
