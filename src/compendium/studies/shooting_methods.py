"""Comparing the switching treatments and Jacobians on one shooting problem (the slides' tables)."""

from __future__ import annotations

import pandas as pd

from ocpkit.shooting import CompiledSystem, HamiltonianSystem, Shooting

#: (detection, jacobian) pairs of Martinon & Gergaud's tables; no detection only with finite differences
COMBINATIONS = [
    ("none", "fd"),
    ("detection", "fd"),
    ("correction", "fd"),
    ("detection", "variational"),
    ("correction", "variational"),
]
#: every detection mode with both Jacobians (no detection with the variational Jacobian: no jump terms)
ALL_COMBINATIONS = [(d, j) for j in ("fd", "variational") for d in ("none", "detection", "correction")]


def compare_methods(
    problem,
    law,
    z0,
    parameters=None,
    *,
    combinations=COMBINATIONS,
    rtol: float = 1e-8,
    atol: float = 1e-8,
    system: CompiledSystem | None = None,
    **solve_options,
):
    """Shoot from ``z0`` with every (detection, jacobian) combination; failures are reported, not raised.

    Returns ``(table, results)``: one row per combination (objective, |S|, S and
    Jacobian evaluations, CPU s, switchings, steps, rejected %, Hamiltonian drift),
    and the :class:`ShootingResult` objects by combination.
    """
    system = system or CompiledSystem(HamiltonianSystem(problem, law))
    rows, results = [], {}
    for detection, jacobian in combinations:
        s = Shooting(problem, law, switching=detection, jacobian=jacobian, rtol=rtol, atol=atol, system=system)
        r = s.solve(z0, parameters, raise_on_failure=False, **solve_options)
        results[(detection, jacobian)] = r
        rows.append(r.summary())
    return pd.DataFrame(rows), results
