"""Refinement on published problems beyond the seeds (notebook 07, section 5).

Each case is a problem, a starting mesh and a published value (``data/paper/beyond_the_seeds.csv``, or a closed
form); :func:`run_case` refines it to a tolerance and reports the outcome: ``met`` (every part of the estimate,
:class:`ocpkit.accuracy.Accuracy`, at most the tolerance), ``stalled`` or ``not met`` (with the warning's reason),
or IPOPT's status when a mesh's solve failed (then only the outcome is reported: no number of a failed solve).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ocpkit import SolverError, autoscale, scheme
from ocpkit.accuracy import AccuracyWarning

from ..paper import paper_table
from ..problems import (
    bryson_denham,
    bryson_denham_solution,
    catalyst_mixing,
    free_flying_robot,
    hang_glider,
    miser3_state_constraint,
    orbit_raising,
    shuttle_reentry,
    tumour,
)


@dataclass(frozen=True)
class Case:
    """A problem, how to start (``scheme``: ``"HLGL"`` or ``"Radau"``, ``start``: segments, or nodes and intervals)
    and the published value its result is compared with (``published``: problem and quantity in
    ``data/paper/beyond_the_seeds.csv``, or a number from a closed form); ``value``: the compared quantity of a
    solution in the published value's units and sense (default its objective); ``discretisation``: where the
    published value is the optimum of its source's own discretised problem (COPS prints its NLP's), how far from it
    (relative) the continuous optimum may lie, which :meth:`reach` allows."""

    problem: str
    make: Callable
    scheme: str
    start: tuple
    published: tuple | float
    value: Callable | None = None
    discretisation: float = 0.0

    @property
    def label(self) -> str:
        return f"{self.scheme} {' x '.join(str(s) for s in self.start)}"

    def transcription(self):
        """The case's scheme (by its name, :data:`ocpkit.transcription.SCHEMES`) on its problem, from its start."""
        return scheme(self.scheme, self.make(), *self.start)

    def measured(self, solution) -> float:
        return float(solution.objective if self.value is None else self.value(solution))

    def _rows(self):
        table = paper_table("beyond_the_seeds")
        problem, quantity = self.published
        return table[(table.problem == problem) & table.quantity.str.startswith(quantity)], quantity

    def published_value(self) -> float:
        if not isinstance(self.published, tuple):
            return float(self.published)
        rows, quantity = self._rows()
        return float(rows[rows.quantity == quantity].value.iloc[0])

    def published_spread(self) -> float:
        """How far (relative) the sources of the published value disagree: rows of the same problem whose quantity
        starts with the compared one (``objective``, ``objective_gpops2``); 0 with one source."""
        if not isinstance(self.published, tuple):
            return 0.0
        values = self._rows()[0].value.to_numpy(float)
        return float((values.max() - values.min()) / abs(self.published_value())) if values.size else 0.0

    def published_rounding(self) -> float:
        """Half a unit in the last digit the source prints, relative to the value (0 for a closed form)."""
        if not isinstance(self.published, tuple):
            return 0.0
        rows, quantity = self._rows()
        row = rows[rows.quantity == quantity].iloc[0]
        value = abs(float(row.value))
        return 0.5 * 10.0 ** (np.floor(np.log10(value)) - int(row.digits) + 1) / value

    def reach(self, tolerance: float) -> float:
        """How close a result refined to ``tolerance`` can be shown to agree with the published value: the
        tolerance, the sources' spread, the printed digits' rounding or the source's discretisation, whichever is
        largest."""
        return max(tolerance, self.published_spread(), self.published_rounding(), self.discretisation)


def _final_latitude_deg(solution) -> float:
    return float(np.degrees(solution.state(solution.tf)[2]))


def _final_radius(solution) -> float:
    return float(solution.state(solution.tf)[0])


CASES = [
    Case("hang glider", hang_glider, "HLGL", (50,), ("hang_glider", "final_range_m"), lambda s: -s.objective),
    Case("hang glider", hang_glider, "Radau", (4, 50), ("hang_glider", "final_range_m"), lambda s: -s.objective),
    Case("hang glider", hang_glider, "Radau", (60, 1), ("hang_glider", "final_range_m"), lambda s: -s.objective),
    Case("tumour", tumour, "HLGL", (10,), ("tumour_anti_angiogenesis", "final_tumour_volume")),
    Case("tumour", tumour, "Radau", (4, 10), ("tumour_anti_angiogenesis", "final_tumour_volume")),
    Case("free-flying robot", free_flying_robot, "HLGL", (10,), ("free_flying_robot", "objective")),
    Case("free-flying robot", free_flying_robot, "Radau", (4, 10), ("free_flying_robot", "objective")),
    Case("catalyst mixing", catalyst_mixing, "HLGL", (10,), ("catalyst_mixing", "objective")),
    Case("catalyst mixing", catalyst_mixing, "Radau", (4, 10), ("catalyst_mixing", "objective")),
    Case("Bryson-Denham", bryson_denham, "HLGL", (10,), bryson_denham_solution(np.zeros(1))["J"]),
    Case("MISER3 state constraint", miser3_state_constraint, "HLGL", (50,), ("miser3_state_constraint", "objective")),
    Case("MISER3 state constraint", miser3_state_constraint, "Radau", (4, 50), ("miser3_state_constraint", "objective")),
    Case("shuttle reentry", shuttle_reentry, "Radau", (4, 40), ("shuttle_reentry", "final_latitude_deg"),
         _final_latitude_deg),
    Case("shuttle reentry, q <= 70", lambda: shuttle_reentry(70.0), "HLGL", (40,),
         ("shuttle_reentry_heating", "final_latitude_deg"), _final_latitude_deg),
    Case("shuttle reentry, q <= 70", lambda: shuttle_reentry(70.0), "Radau", (4, 40),
         ("shuttle_reentry_heating", "final_latitude_deg"), _final_latitude_deg),
    Case("shuttle reentry, q <= 70, unscaled + autoscale", lambda: autoscale(shuttle_reentry(70.0, scaled=False)),
         "Radau", (4, 40), ("shuttle_reentry_heating", "final_latitude_deg"), _final_latitude_deg),
    Case("orbit raising", orbit_raising, "Radau", (4, 20), ("orbit_raising", "final_radius"), _final_radius),
    Case("orbit raising, angle not declared periodic", lambda: orbit_raising(periodic=False), "Radau", (4, 20),
         ("orbit_raising", "final_radius"), _final_radius),
]  # fmt: skip


#: COPS 3.0's own statement of the hang glider (its rounded constants, bounds and starting point, unscaled), from the
#: starts of :data:`CASES`: its coarse meshes hold spurious optima that every mesh refined from them inherits, which
#: the refinement's recoveries leave (:data:`ocpkit.program.solve.RECOVERIES`). Refined in notebook 07's published run
#: only (``cops_statements``: minutes). COPS prints the optimum of its discretised NLP (1247.98); the statement's
#: continuous optimum lies within 1e-5 of it, the reach allowed.
COPS_CASES = [
    Case("hang glider, COPS statement", lambda: hang_glider(cops=True), name, start,
         ("hang_glider_cops", "final_range_m"), lambda s: -s.objective, discretisation=1e-5)
    for name, start in (("HLGL", (50,)), ("Radau", (4, 50)), ("Radau", (60, 1)))
]  # fmt: skip


def run_case(case: Case, tolerance: float, max_mesh_iterations: int = 25) -> dict:
    """One refinement: a row of the section's table, and the solution (None when a mesh failed)."""
    start = time.perf_counter()
    row = {
        "problem": case.problem,
        "start": case.label,
        "published": case.published_value(),
        "published_spread": case.published_spread(),
        "published_reach": case.reach(tolerance),
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)  # the solution says how its refinement ended
        try:
            sol = case.transcription().solve(mesh_tolerance=tolerance, max_mesh_iterations=max_mesh_iterations)
        except SolverError as exc:
            row.update(
                outcome=exc.status, met=False, reason=str(exc), mesh_iterations=len(getattr(exc, "mesh_history", []))
            )
            row["total_s"] = time.perf_counter() - start
            return row | {"solution": None}
    accuracy = sol.accuracy
    met = sol.refinement_outcome == "met" and not accuracy.failing(tolerance)
    value = case.measured(sol)
    row.update(
        outcome=sol.refinement_outcome,
        met=met,
        reason=sol.refinement_reason,
        mesh_iterations=len(sol.mesh_history),
        collocation_points=sol.mesh_history[-1].collocation_points,
        state_error=accuracy.state,
        objective_error=accuracy.objective,
        path_violation=max(accuracy.path.values(), default=float("nan")),
        objective=value,
        relative_difference=abs(value - row["published"]) / abs(row["published"]),
        total_s=time.perf_counter() - start,
    )
    return row | {"solution": sol}


def run_cases(tolerance: float, max_mesh_iterations: int = 25, cases=CASES):
    """Every case: ``(rows, solutions)``, the solutions by ``(problem, start)`` (None where a mesh failed)."""
    rows, solutions = [], {}
    for case in cases:
        row = run_case(case, tolerance, max_mesh_iterations)
        solutions[case.problem, case.label] = row.pop("solution")
        rows.append(row)
    return rows, solutions


__all__ = ["CASES", "COPS_CASES", "Case", "run_case", "run_cases"]
