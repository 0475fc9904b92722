"""A box for unbounded controls that run away: the solve of a problem such as COPS's hanging chain as published.

A control left unbounded (no finite ``lower`` or ``upper``) whose statement gives it a guess can make the
transcribed NLP exploitable where the problem is not: COPS's hanging chain (``x1' = u``, ``x3' = sqrt(1 + u^2)`` a
length, ``u`` free) puts a near-vertical jump of the chain at one point with ``u`` in the hundreds, whose length the
quadrature charges at the height of that one point, below the jump's mean height; the NLP's energy then falls below
the catenary's (HLGL 20: 4.927 against 5.06848, ``u = 304`` at one node), and IPOPT started at the catenary itself
walks away from it, which is therefore a saddle of the discrete problem, not a minimum. No scaling or guess removes
a descent direction; a bound does (and COPS's trapezoidal rule, whose node charges a jump at its midpoint, does not
have it).

So a solve whose iterate takes such a control beyond :data:`SAFEGUARD_FACTOR` times its magnitude at the guess
(the largest of its guess at 21 points; nothing where that is 0 or the guess not given) is solved again from the
same start with the control held in ``[-m, m]``, ``m`` that multiple. A solution off that box is a KKT point of the
unbounded NLP too (the box's multipliers are zero): the same solution. On a coarse mesh the exploit pushes the
control to the box, where it pays ``h m`` of length at most, so mesh refinement removes it; a solution that still
ends on the box is the bounded problem's, and its verdict says so (:func:`held_controls`, a note naming the
control and the bound to declare).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..statement import Control, Guess

if TYPE_CHECKING:
    from ..solution import Solution
    from .program import Program

__all__ = ["SAFEGUARD_FACTOR", "ControlSafeguard", "control_safeguard", "held_controls"]

#: the box of a runaway unbounded control, in multiples of its magnitude at the guess
SAFEGUARD_FACTOR = 5.0


@dataclass(frozen=True)
class ControlSafeguard:
    """The box of a program's guessed, unbounded controls: their NLP ``indices``, the box in the NLP's scaled
    numbers (``lower``, ``upper``), and each control's ``name`` and physical ``limit`` (the box is ``[-limit,
    limit]``), index by index."""

    indices: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    names: tuple[str, ...]
    limits: tuple[float, ...]

    def exceeded(self, w: np.ndarray) -> bool:
        """Whether the NLP vector ``w`` takes a control beyond its box (or is not finite there)."""
        values = np.asarray(w, dtype=float)[self.indices]
        return bool(np.any(~np.isfinite(values) | (values < self.lower) | (values > self.upper)))

    def reaches(self, w: np.ndarray, rtol: float = 1e-2) -> bool:
        """Whether ``w`` takes a control to within ``rtol`` of its limit, or beyond it."""
        values = np.asarray(w, dtype=float)[self.indices]
        margin = rtol * (self.upper - self.lower) / 2
        return bool(np.any(~np.isfinite(values) | (values < self.lower + margin) | (values > self.upper - margin)))

    def bounds(self, lbw: np.ndarray, ubw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The NLP's variable bounds ``lbw, ubw`` with the box added."""
        lb, ub = np.array(lbw, dtype=float), np.array(ubw, dtype=float)
        lb[self.indices] = np.maximum(lb[self.indices], self.lower)
        ub[self.indices] = np.minimum(ub[self.indices], self.upper)
        return lb, ub

    def on_box(self, w: np.ndarray, rtol: float = 1e-6) -> dict[str, float]:
        """The controls that ``w`` holds at their box (within ``rtol`` of its width), name -> limit; none where ``w``
        lies beyond the box (an unbounded solve's solution, kept)."""
        values = np.asarray(w, dtype=float)[self.indices]
        margin = rtol * (self.upper - self.lower)
        if np.any((values < self.lower - margin) | (values > self.upper + margin)):
            return {}
        hit = (values <= self.lower + margin) | (values >= self.upper - margin)
        return {self.names[k]: self.limits[k] for k in np.flatnonzero(hit)}


def control_safeguard(program: Program, factor: float = SAFEGUARD_FACTOR) -> ControlSafeguard | None:
    """The box of the module docstring for ``program``'s controls that have neither bound and a guess of nonzero
    magnitude, else None."""
    indices: list[np.ndarray] = []
    lower: list[np.ndarray] = []
    upper: list[np.ndarray] = []
    names: list[str] = []
    limits: list[float] = []
    for phase in program.phases:
        problem = phase.problem
        _, _, controls = Guess().functions(problem)
        guessed = controls(np.linspace(problem.t0, problem.tf_guess, 21))
        for group, table in zip(phase.layout.groups, phase.layout.tables):
            for j, v in enumerate(group.variables):
                if not isinstance(v, Control) or v.guess is None or v.period is not None:
                    continue  # an angle runs by whole turns
                if np.isfinite(v.lower) or np.isfinite(v.upper):
                    continue
                column = problem.control_names.index(v.name)
                size = float(np.max(np.abs(guessed[:, column])))
                if not (np.isfinite(size) and size > 0):
                    continue
                limit = factor * size
                where = phase.to_global[np.asarray(table[j])].ravel()
                indices.append(where)
                lower.append(np.full(where.size, (-limit - v.shift) / v.scale))
                upper.append(np.full(where.size, (limit - v.shift) / v.scale))
                names += [v.name] * where.size
                limits += [limit] * where.size
    if not indices:
        return None
    return ControlSafeguard(
        np.concatenate(indices), np.concatenate(lower), np.concatenate(upper), tuple(names), tuple(limits)
    )


def held_controls(solution: Solution) -> dict[str, float]:
    """The controls ``solution`` holds on their safeguard box, name -> limit (none where it has no box, did not
    converge, or lies off it): the solution is then the bounded problem's, not the unbounded one's, which its
    verdict notes (:attr:`~ocpkit.Solution.held_controls`)."""
    guard = control_safeguard(solution.program)
    if guard is None or not solution.converged:
        return {}
    return guard.on_box(solution.nlp_result.w)
