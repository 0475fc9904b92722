"""State constraints that only the final state can reach: a budget, read as the terminal condition it is.

A pure state constraint ``c(x) <= 0`` whose derivative along the flow, ``Dc = c_x f + c_t``, depends on the controls
only, affinely, and is nonnegative on the whole control box never decreases along any admissible trajectory. Then

    c(x(t)) <= 0 on [t0, tf]   <=>   c(x(tf)) <= 0,

the drug budget of the tumour anti-angiogenesis problem (``y' = u >= 0``, ``y <= A``; Ledzewicz & Schättler 2008,
and GPOPS-II's example states it so: the final ``y`` at most ``A``) and any other resource spent at a nonnegative
rate. Once such a constraint is active it stays active with ``Dc = 0``, which, for a ``Dc`` in one control, holds
that control at one value; where that value is one of its bounds (nothing is spent while the control is off), the
direct solution's "boundary arc" is a bang arc of that control, and the maximum principle's costate jump at its
entry (Maurer 1977; the direct adjoining form's measure) is the terminal multiplier of ``c(x(tf)) <= 0`` in the
equivalent statement, where the costate is continuous.

:func:`as_terminal` rewrites a problem and a detected structure that way for :func:`ocpkit.indirect.to_extremal`:
the bound stays in the problem (the certificate checks it along the extremal), ``c(x(tf)) = 0`` is added as a
boundary equality with its multiplier (active: the direct solution ends on it), and the multiplier's sign, which
says that the budget binds, is checked (``terminal_multiplier_sign``).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from .statement import Constraint, Control, OptimalControlProblem
from .structure import Arc, Inequality, Structure, inequalities

if TYPE_CHECKING:
    from .trajectory import Trajectory

#: how far from 0 a direct solution's ``c(x)``, relative to the constraint's range along it, may lie for the
#: constraint to count as active; and the last share of the horizon over which it must be (a budget spent at the
#: final instant only, reached by full thrust throughout, is no boundary arc: its equality would be degenerate)
ACTIVE, FINAL = 1e-6, 0.01


def monotone_constraints(problem: OptimalControlProblem) -> dict[str, tuple[int, float]]:
    """``{name: (control index, value)}`` for each pure state constraint of ``problem`` that never decreases (module
    docstring) and whose ``Dc`` depends on one control: the control's value that holds ``Dc = 0``."""
    ham = problem.functions.hamiltonian
    x, u, t, P = ham.x, ham.u, ham.t, ham.P
    P0 = ca.DM(np.asarray(problem.full_parameters, dtype=float).reshape(-1, 1)) if P.numel() else ca.DM(0, 1)
    out = {}
    for q in inequalities(problem):
        if not q.pure or q.order != 1 or len(q.controls) != 1:
            continue
        c = q.function(x, u, t, P)
        rate = ca.substitute(ca.jtimes(c, x, ham.f) + ca.jacobian(c, t), P, P0)
        i = q.controls[0]
        if ca.depends_on(rate, ca.vertcat(x, t)) or ca.depends_on(ca.jacobian(rate, u), u):
            continue  # Dc depends on the state or time, or is not affine in the controls
        lo, hi = problem.controls[i].lower, problem.controls[i].upper
        if not (np.isfinite(lo) and np.isfinite(hi)):
            continue
        at = ca.Function("rate", [u[i]], [rate])  # Dc in the one control it depends on, affinely
        ends = [float(at(lo)), float(at(hi))]
        if min(ends) < -1e-12 * max(1.0, *map(abs, ends)):
            continue  # c can decrease: the constraint can bind before tf
        if ends[0] == ends[1]:
            continue
        out[q.name] = (i, lo - ends[0] * (hi - lo) / (ends[1] - ends[0]))
    return out


def as_terminal(
    problem: OptimalControlProblem, structure: Structure, solution: Trajectory
) -> tuple[OptimalControlProblem, Structure, list[str]]:
    """``(problem, structure, converted)``: each non-decreasing state constraint (module docstring) that the direct
    ``solution`` ends on, active over the last :data:`FINAL` of the horizon at least, rewritten as the terminal
    equality ``<name>_at_tf``, and its boundary arcs in ``structure`` as bang arcs of the control that holds
    ``Dc = 0`` there (neighbouring arcs of one kind merged; a boundary arc whose control that value leaves inside
    its bounds stays as it was). ``converted`` lists the names of the
    terminal equalities added, at the end of the problem's boundary constraints; unchanged ``problem`` and
    ``structure`` where there is none."""
    candidates = monotone_constraints(problem)
    if not candidates:
        return problem, structure, []
    ineq = {q.name: q for q in inequalities(problem)}
    t = np.array([solution.t0, solution.tf - FINAL * (solution.tf - solution.t0), solution.tf])
    X, U = solution.state(t), solution.control(t)
    P = np.asarray(problem.full_parameters, dtype=float).ravel()
    relabelled, added = list(structure.arcs), []
    for name, (i, value) in candidates.items():
        c0, before, cf = (float(ineq[name].function(X[k], U[k], t[k], P)) for k in range(3))
        if max(abs(before), abs(cf)) > ACTIVE * max(1.0, abs(cf - c0)):
            continue  # not active over a last stretch of the horizon: it binds nowhere, or at the final instant only
        control = problem.controls[i]
        kind = _bang(control, value)
        if kind is not None:
            relabelled = [
                replace(a, kind=kind, constraint=None) if a.constraint == name and a.control == control.name else a
                for a in relabelled
            ]
        added.append(_terminal(problem, ineq[name], f"{name.replace('.', '_')}_at_tf"))
    if not added:
        return problem, structure, []
    merged: list[Arc] = []
    for a in relabelled:
        last = merged[-1] if merged else None
        if last is not None and (last.control, last.kind, last.constraint) == (a.control, a.kind, a.constraint):
            merged[-1] = replace(last, end=a.end)
        else:
            merged.append(a)
    restated = problem.replace(boundary_constraints=[*problem.boundary_constraints, *added])
    return restated, Structure(tuple(merged), structure.touches), [c.name for c in added]


def _bang(control: Control, value: float) -> str | None:
    """The bang kind of a control held at ``value``, or None where ``value`` is inside its bounds."""
    span = max(1.0, float(control.upper - control.lower))
    for kind, bound in (("lower", control.lower), ("upper", control.upper)):
        if abs(value - bound) <= 1e-12 * span:
            return kind
    return None


def _terminal(problem: OptimalControlProblem, q: Inequality, name: str) -> Constraint:
    """``c(x(tf)) = 0`` for the pure state constraint ``q`` (its value at the final state and time)."""
    nu = problem.nu

    def at_tf(x0: ca.SX, xf: ca.SX, t0: ca.SX, tf: ca.SX, p: Any = None) -> ca.SX:
        P = p.column if p is not None and hasattr(p, "column") else ca.SX(0, 1)
        return q.function(xf, ca.SX.zeros(nu), tf, P)

    return Constraint(name, at_tf, lower=0.0, upper=0.0)


__all__ = ["as_terminal", "monotone_constraints"]
