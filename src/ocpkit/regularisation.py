"""Regularisation of singular and bang-bang controls: a small quadratic penalty on the control.

On a singular arc the Hamiltonian is linear in the control and the control does not appear in
the necessary conditions' first-order stationarity, so a direct transcription's NLP has (nearly)
flat directions there: IPOPT returns a control that chatters between mesh points, and more so as
the mesh is refined, while the states and the cost barely change. Adding

    eps * int_t0^tf sum_i ((u_i - shift_i) / scale_i)^2 dt

(each control in its NLP scaling, :class:`ocpkit.Control`'s ``shift`` and ``scale``) makes the
Hamiltonian strictly convex in ``u``: the control becomes a continuous function of the states and
costates, unique, smooth on the former singular arc, and saturating smoothly instead of jumping at
a switch. The price is a change of the optimum of order ``eps`` (measure it: solve at a few
values of ``eps`` and compare the unpenalised cost). This is the L2 regularisation of singular and
bang-bang problems (e.g. Bonnans, Martinon & Trélat, "Singular arcs in the generalized Goddard's
problem", JOTA 139, 2008; the L2-L1 homotopy of Martinon & Gergaud's minimum-fuel transfers).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import casadi as ca

from .statement import OptimalControlProblem


def penalise_control(
    problem: OptimalControlProblem, weight: float, controls: Sequence[str] | None = None
) -> OptimalControlProblem:
    """``problem`` with ``weight * int sum ((u - shift) / scale)^2 dt`` added to its cost (module docstring).

    ``controls``: the names of the controls to penalise (default: all). The returned problem's
    Lagrange term includes the penalty; ``problem``'s own cost of a solution is its objective less
    the penalty, or re-evaluate it on ``problem``.
    """
    weight = float(weight)
    if not weight >= 0 or weight == float("inf"):
        raise ValueError(f"the regularisation weight must be a finite non-negative number, got {weight!r}")
    names = problem.control_names
    chosen = list(names) if controls is None else list(controls)
    unknown = sorted(set(chosen) - set(names))
    if unknown or not chosen:
        raise ValueError(f"controls to penalise must be some of {list(names)}, got {chosen!r}")
    index = [names.index(n) for n in chosen]
    shift = [problem.controls[i].shift for i in index]
    scale = [problem.controls[i].scale for i in index]
    base = problem.functions.L  # the problem's own running cost, L(x, u, t, P), whatever its callable's signature

    def lagrange(x: Any, u: Any, t: Any, p: Any = None) -> Any:
        penalty = sum(((u[i] - s) / c) ** 2 for i, s, c in zip(index, shift, scale))
        own = 0 if base is None else base(x, u, t, ca.SX(0, 1) if p is None else p.column)
        return own + weight * penalty

    return problem.replace(
        lagrange=lagrange,
        name=f"{problem.name}_regularised",
        description=f"{problem.description} (control penalty {weight:g} on {', '.join(chosen)})".strip(),
    )
