"""The COPS gas-oil fit: three rate constants of catalytic cracking estimated from 21 measurements.

Dolan, Moré & Munson, COPS 3.0 (ANL/MCS-TM-273, 2004), "Catalytic cracking of gas oil":

    minimise    sum_j |y(t_j) - z_j|^2              (21 measurements z_j at times t_j, data/problems/cops_gasoil.csv)
    subject to  y1' = -(theta1 + theta3) y1^2
                y2' = theta1 y1^2 - theta2 y2,       y(0) = (1, 0),  theta >= 0,  t in [0, 0.95].

The cost sits at the measurement times: the problem is cut there into linked phases (``Program.split``)
whose rate constants are one parameter of the trajectory, and the cost is a sum over the cut times.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ocpkit import FreeParameter, OptimalControlProblem, Program, State

from ..paths import problem_data_dir

if TYPE_CHECKING:
    import pandas as pd


def gasoil_measurements() -> pd.DataFrame:
    """The measurement table: columns ``t``, ``y1``, ``y2`` (with its provenance in the file's header)."""
    import pandas as pd  # here, not at import: the other problems need no pandas

    return pd.read_csv(problem_data_dir() / "cops_gasoil.csv", comment="#")


def gasoil(theta_upper: float = 100.0) -> OptimalControlProblem:
    """The gas-oil kinetics on [0, 0.95] with free rate constants ``theta1..3`` in [0, theta_upper] (no cost: it
    lies at the measurement times, :func:`gasoil_fit`)."""
    data = gasoil_measurements()
    first, last = data.iloc[0], data.iloc[-1]
    return OptimalControlProblem(
        "gasoil",
        states=[
            State("y1", initial=float(first.y1), guess=(float(first.y1), float(last.y1))),
            State("y2", initial=float(first.y2), guess=(float(first.y2), float(last.y2))),
        ],
        controls=[],
        dynamics=lambda x, u, t, p: [
            -(p["theta1"] + p["theta3"]) * x["y1"] ** 2,
            p["theta1"] * x["y1"] ** 2 - p["theta2"] * x["y2"],
        ],
        t0=float(first.t),
        tf=float(last.t),
        free_parameters=[FreeParameter(f"theta{k}", 0.0, theta_upper, guess=1.0) for k in (1, 2, 3)],
    )


def least_squares(data: pd.DataFrame):
    """The cost ``sum_rows sum_columns (x[column](t) - value)^2`` over a measurement table (column ``t`` and state
    columns), for :meth:`ocpkit.Program.split` (``ends.at(t)`` is the state at a cut time)."""
    columns = [c for c in data.columns if c != "t"]

    def cost(ends):
        return sum(
            (ends.at(float(row.t))[c] - float(getattr(row, c))) ** 2 for row in data.itertuples() for c in columns
        )

    return cost


def gasoil_fit(scheme, **options) -> Program:
    """The gas-oil problem cut at the measurement times, each piece transcribed by ``scheme``, with the least-squares
    cost at those times; ``options`` go to :meth:`ocpkit.Program.split` (``local_parameters=["theta1", ...]``
    gives each piece its own constants: the mistake of a statement where static parameters are per phase)."""
    data = gasoil_measurements()
    return Program.split(gasoil(), data.t.to_numpy(), scheme, cost=least_squares(data), **options)
