"""Automatic scaling: every variable, constraint and the cost of order one in the NLP, from bounds and the guess.

IPOPT's steps, its barrier and its convergence tests all act on the NLP's numbers, so a state in metres next to
one in radians, or a cost of 10^4, costs iterations or the solve (the hang glider without its scales: 180 IPOPT
iterations on Radau 4 x 50, 99 under MUMPS's QAMD ordering; autoscaled 31, scaled by hand 30). :func:`autoscale` chooses what a user would write by
hand, the
way GPOPS-II scales from bounds and Dymos from ``ref``/``ref0``:

* a state, control or free parameter with both bounds finite is shifted to their midpoint and scaled by their
  width (the NLP variable lies in [-1/2, 1/2]); with a bound missing, it is scaled by the largest magnitude of
  its finite bounds, boundary conditions and guess (at 21 points), not shifted;
* a free final (or initial) time by the magnitude of its guess;
* a path or boundary constraint by the largest magnitude of its finite bounds (1 where they are 0);
* the cost by its magnitude at the guess (Mayer term at the guessed ends plus the trapezoidal running cost on 41
  points), when that is not zero.

Whatever the user set (a scale other than 1, a shift other than 0, an ``objective_scale`` other than 1) is kept:
the automatic choice fills in the defaults only. Scaling changes the NLP, not the problem: the solution is the
same optimum, in the same units.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from .statement import Constraint, FreeFinalTime, Guess, OptimalControlProblem, Variable

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["autoscale"]


def _magnitude(values: ArrayLike) -> float:
    finite = np.abs(np.asarray([v for v in np.ravel(values) if np.isfinite(v)], dtype=float))
    return float(finite.max()) if finite.size else 0.0


def _scaled_variable(v: Variable, samples: ArrayLike) -> Variable:
    if v.scale != 1.0 or v.shift != 0.0:
        return v
    lo, hi = float(v.lower), float(v.upper)
    if math.isfinite(lo) and math.isfinite(hi) and hi > lo:
        return dataclasses.replace(v, scale=hi - lo, shift=0.5 * (lo + hi))
    ends: list[float] = []
    for which in ("initial", "final"):
        spec = getattr(v, which, None)
        if spec is not None:
            ends += list(np.ravel(spec))
    size = _magnitude([lo, hi, *ends, *np.ravel(samples)])
    return dataclasses.replace(v, scale=size) if size > 0 else v


def _scaled_constraint(c: Constraint) -> Constraint:
    if c.scale != 1.0:
        return c
    size = _magnitude([*np.ravel(c.lower), *np.ravel(c.upper)])
    return dataclasses.replace(c, scale=size) if size > 0 else c


def _guess_cost(problem: OptimalControlProblem) -> float:
    tf, xs, us = Guess().functions(problem)
    t = np.linspace(problem.t0, tf, 41)
    X, U = xs(t), us(t)
    P = problem.full_parameters
    cost = 0.0
    if problem.L is not None:
        L = np.array([float(problem.L(X[k], U[k], t[k], P)) for k in range(t.size)])
        cost += float(np.sum(0.5 * (L[1:] + L[:-1]) * np.diff(t)))
    if problem.phi is not None:
        cost += float(problem.phi(X[0], X[-1], problem.t0, tf, P))
    return cost


def autoscale(problem: OptimalControlProblem) -> OptimalControlProblem:
    """``problem`` with the scaling of the module docstring filled in where it was left at its default."""
    tf, xs, us = Guess().functions(problem)
    t = np.linspace(problem.t0, tf, 21)
    X, U = xs(t), us(t)
    states = [_scaled_variable(v, X[:, i]) for i, v in enumerate(problem.states)]
    controls = [_scaled_variable(v, U[:, i]) for i, v in enumerate(problem.controls)]
    free = [_scaled_variable(v, [v.guess_value]) for v in problem.free_parameters]
    changes: dict[str, Any] = dict(states=states, controls=controls, free_parameters=free)
    changes["path_constraints"] = [_scaled_constraint(c) for c in problem.path_constraints]
    changes["boundary_constraints"] = [_scaled_constraint(c) for c in problem.boundary_constraints]
    for key, value in (("tf", problem.tf), ("t0", problem.initial_time)):
        if isinstance(value, FreeFinalTime) and value.scale == 1.0 and abs(value.guess) > 0:
            changes[key] = dataclasses.replace(value, scale=abs(value.guess))
    if problem.objective_scale == 1.0:
        cost = abs(_guess_cost(problem))
        if cost > 0 and math.isfinite(cost):
            changes["objective_scale"] = cost
    return problem.replace(**changes)
