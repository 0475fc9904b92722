"""Minimum-fuel control of a double integrator and of a harmonic oscillator (shooting validation).

Cost ``lam |u| + (1 - lam) u^2`` with ``|u| <= 1`` (parameter ``lam``): the energy
problem at ``lam = 0``, the fuel (L1) problem at ``lam = 1``. Constants from
``data/problems/minimum_fuel.toml``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca

from ocpkit import Control, OptimalControlProblem, State

from ._data import load_problem_data


def _cost(x, u, t, P):
    return P["lam"] * ca.fabs(u[0]) + (1 - P["lam"]) * u[0] ** 2


def double_integrator(lam: float = 1.0, x0=None, horizon: float | None = None) -> OptimalControlProblem:
    """x1' = x2, x2' = u, |u| <= 1, from ``x0`` to the origin in ``horizon``, cost lam|u| + (1-lam)u^2."""
    d = load_problem_data("minimum_fuel")["double_integrator"]
    x0 = d["x0"] if x0 is None else list(x0)
    T = d["horizon"] if horizon is None else float(horizon)
    return OptimalControlProblem(
        "double_integrator_min_fuel",
        [State("x1", initial=x0[0], final=0.0), State("x2", initial=x0[1], final=0.0)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t, P: ca.vertcat(x[1], u[0]),
        tf=T,
        lagrange=_cost,
        parameters={"lam": lam},
        description="Minimum-fuel double integrator",
    )


def double_integrator_thrusters(x0=None, horizon: float | None = None) -> OptimalControlProblem:
    """The fuel-optimal double integrator as a direct method states it without ``|u|``: two thrusters, ``push`` and
    ``brake`` in [0, 1], ``x2' = push - brake``, cost ``push + brake`` (the same optimum as ``double_integrator(1)``:
    brake, coast, push, at the times of :func:`double_integrator_solution`)."""
    d = load_problem_data("minimum_fuel")["double_integrator"]
    x0 = d["x0"] if x0 is None else list(x0)
    T = d["horizon"] if horizon is None else float(horizon)
    return OptimalControlProblem(
        "double_integrator_thrusters",
        [State("x1", initial=x0[0], final=0.0), State("x2", initial=x0[1], final=0.0)],
        [Control("push", 0.0, 1.0), Control("brake", 0.0, 1.0)],
        lambda x, u, t: [x["x2"], u["push"] - u["brake"]],
        tf=T,
        lagrange=lambda x, u, t: u["push"] + u["brake"],
        description="Minimum-fuel double integrator, two thrusters",
    )


@dataclass(frozen=True)
class BangOffBang:
    """Closed-form fuel-optimal solution of the double integrator: u = -1, 0, +1 on [0, t1], [t1, t2], [t2, T]."""

    t1: float
    t2: float
    horizon: float
    p0: tuple

    @property
    def fuel(self) -> float:
        return self.t1 + (self.horizon - self.t2)


def double_integrator_solution(x0=None, horizon: float | None = None) -> BangOffBang:
    """Switching times and initial costates of the fuel-optimal double integrator (x1(0) > 0 case).

    With u = -1 until t1, coast to t2, u = +1 to T: x2(T) = 0 gives ``t2 = T - t1 + b``
    and x1(T) = 0 gives ``t1^2 - (T + b) t1 + a + b T + b^2 / 2 = 0`` (smaller root),
    for ``x0 = (a, b)``. The costates: ``p1 = c``, ``p2 = p2(0) - c t`` with
    ``p2(t1) = 1``, ``p2(t2) = -1``.
    """
    d = load_problem_data("minimum_fuel")["double_integrator"]
    a, b = d["x0"] if x0 is None else x0
    T = d["horizon"] if horizon is None else float(horizon)
    disc = (T + b) ** 2 - 4 * (a + b * T + b * b / 2)
    if disc < 0:
        raise ValueError(f"no bang-off-bang solution: horizon {T} is below the minimum time from {(a, b)}")
    t1 = ((T + b) - math.sqrt(disc)) / 2
    t2 = T - t1 + b
    if not (0 <= t1 < t2 <= T):
        raise ValueError(f"x0 = {(a, b)}, T = {T} has no (-1, 0, +1) bang-off-bang solution")
    c = 2.0 / (t2 - t1)
    return BangOffBang(t1, t2, T, (c, 1.0 + c * t1))


def harmonic_oscillator(lam: float = 1.0, x0=None, periods: float | None = None) -> OptimalControlProblem:
    """x1' = x2, x2' = -x1 + u, |u| <= 1, to the origin in ``periods`` periods, cost lam|u| + (1-lam)u^2."""
    d = load_problem_data("minimum_fuel")["harmonic_oscillator"]
    x0 = d["x0"] if x0 is None else list(x0)
    n = d["periods"] if periods is None else periods
    return OptimalControlProblem(
        "harmonic_oscillator_min_fuel",
        [State("x1", initial=x0[0], final=0.0), State("x2", initial=x0[1], final=0.0)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t, P: ca.vertcat(x[1], -x[0] + u[0]),
        tf=2 * math.pi * n,
        lagrange=_cost,
        parameters={"lam": lam},
        description="Minimum-fuel harmonic oscillator",
    )
