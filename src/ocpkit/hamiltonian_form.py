"""The form of a Hamiltonian in its controls, as the switching-structure analysis reads it::

    H(x, p, u, t) = H0(x, p, t) + psi(x, p, t) . u + w(x, p, t) |u| + b(x, p, t) |u|^2

(``|u|`` per component for a box, the Euclidean norm for a ball). ``psi`` is the switching function of a control
(its bang arcs switch where ``psi`` crosses ``-w`` or ``w``), ``w`` the weight of an L1 cost (a control with
``w != 0`` has "off" arcs at zero between its bang arcs) and ``b`` a quadratic cost's (``b > 0``: the saturated
linear law of the energy-to-L1 homotopy).

:func:`decompose` extracts ``H0``, ``psi``, ``w`` and ``b`` exactly, by evaluating H at ``u = 0, +-e_i, 2 e_i``;
whether H has the form at all is checked at random points by the functions that rely on it: :func:`l1_controls`
(which controls have an L1 cost, read by :mod:`ocpkit.structure` and :mod:`ocpkit.shooting.arcs`) and
:func:`has_quadratic_term` (which law :func:`ocpkit.indirect.to_extremal` derives), the control laws of
:func:`ocpkit.shooting.control_law` and the switching functions of :func:`ocpkit.structure.control_structure`.
:func:`sample_value` gives each state the value at which such random checks evaluate it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import casadi as ca
import numpy as np

if TYPE_CHECKING:
    from .statement import OptimalControlProblem, State


class HamiltonianForm(NamedTuple):
    """``H0``, and per control ``psi``, ``w`` and ``b``, of ``H = H0 + psi u + w |u| + b u^2`` (CasADi expressions
    in H's symbols; module docstring)."""

    H0: ca.SX
    psi: list[ca.SX]
    w: list[ca.SX]
    b: list[ca.SX]


def decompose(H: ca.SX, u: ca.SX, nu: int) -> HamiltonianForm:
    """``(H0, psi, w, b)`` of ``H`` in the controls ``u`` (``nu`` of them), from H at ``u = 0, e_i, -e_i, 2 e_i``:
    ``psi_i = (H(e_i) - H(-e_i)) / 2``, ``w_i + b_i = (H(e_i) + H(-e_i)) / 2 - H0``, ``b_i`` from ``H(2 e_i)``.
    Exact where H has the form; where it has not, the terms are still defined, and the callers check the form."""
    zero = ca.DM.zeros(nu)
    H0 = ca.substitute(H, u, zero)
    psi: list[ca.SX] = []
    w: list[ca.SX] = []
    b: list[ca.SX] = []
    for i in range(nu):
        e = ca.DM.zeros(nu)
        e[i] = 1.0
        hp = ca.substitute(H, u, e) - H0
        hm = ca.substitute(H, u, -e) - H0
        h2 = ca.substitute(H, u, 2 * e) - H0
        psi_i = (hp - hm) / 2
        s = (hp + hm) / 2  # w + b
        b_i = (h2 - 2 * psi_i) / 2 - s
        psi.append(psi_i)
        b.append(b_i)
        w.append(s - b_i)
    return HamiltonianForm(H0, psi, w, b)


def l1_controls(problem: OptimalControlProblem) -> set[int]:
    """The indices of the controls with a ``w |u|`` term in H (an L1 cost), whose arcs at zero are "off" arcs: H of
    the form ``H0 + psi u + w |u| + b u^2`` in the control (checked at random points) with ``w`` not zero."""
    ham = problem.functions.hamiltonian
    H0, psi, w, b = decompose(ham.H, ham.u, problem.nu)
    rng = np.random.default_rng(3)
    P = np.asarray(problem.full_parameters, dtype=float).ravel()
    out = set()
    for i in range(problem.nu):
        others = ca.vertcat(*[ham.u[j] for j in range(problem.nu) if j != i]) if problem.nu > 1 else ca.SX(0, 1)
        zero = ca.DM.zeros(others.numel())
        model = H0 + psi[i] * ham.u[i] + w[i] * ca.fabs(ham.u[i]) + b[i] * ham.u[i] ** 2
        f = ca.Function("l1", [ham.x, ham.p, ham.u, ham.t, ham.P], [ca.substitute(ham.H - model, others, zero), w[i]])
        values = [
            f(rng.normal(size=problem.nx), rng.normal(size=problem.nx), rng.uniform(-1, 1, problem.nu), 0.3, P)
            for _ in range(4)
        ]
        form = all(abs(float(r)) <= 1e-9 * (1 + abs(float(h))) for r, h in values)
        if form and max(abs(float(h)) for _, h in values) > 1e-12:
            out.add(i)
    return out


def piecewise_affine_controls(problem: OptimalControlProblem) -> set[int]:
    """The controls with an L1 cost (:func:`l1_controls`) in which H is affine on each side of zero, whatever the
    other controls: no quadratic term (``b = 0``) and no norm of several controls. Inside their bounds and off
    zero they are singular (``psi = -w`` or ``+w``). Checked at random points: the second difference of H in the
    control at ``0, a, 2a`` vanishes for ``a`` of either sign, the other controls nonzero."""
    l1 = l1_controls(problem)
    if not l1:
        return set()
    ham = problem.functions.hamiltonian
    Hf = ca.Function("H", [ham.x, ham.p, ham.u, ham.t, ham.P], [ham.H])
    rng = np.random.default_rng(5)
    P = np.asarray(problem.full_parameters, dtype=float).ravel()
    out = set()
    for i in l1:
        affine = True
        for _ in range(3):
            x, p, u = rng.normal(size=problem.nx), rng.normal(size=problem.nx), rng.uniform(0.2, 1.0, problem.nu)
            for a in (0.3, -0.3):
                values = []
                for k in (0, 1, 2):
                    v = u.copy()
                    v[i] = k * a
                    values.append(float(Hf(x, p, v, 0.3, P)))
                second = values[2] - 2 * values[1] + values[0]
                affine &= abs(second) <= 1e-9 * (1 + max(abs(h) for h in values))
        if affine:
            out.add(i)
    return out


def has_quadratic_term(problem: OptimalControlProblem) -> bool:
    """Whether some control has a quadratic term ``b u^2`` in H (then the saturated linear law, not bang-off-bang):
    ``b`` at three random points, with the problem's parameter values (free ones at their guesses)."""
    ham = problem.functions.hamiltonian
    b = decompose(ham.H, ham.u, problem.nu).b
    f = ca.Function("b", [ham.x, ham.p, ham.t, ham.P], [ca.vertcat(*b)])
    rng = np.random.default_rng(1)
    P = problem.full_parameters  # the problem's parameter values (free ones at their guesses): b may depend on them
    values = [np.asarray(f(rng.normal(size=problem.nx), rng.normal(size=problem.nx), 0.0, P)) for _ in range(3)]
    return bool(np.max(np.abs(values)) > 1e-12)


def sample_value(state: State) -> float:
    """A value of ``state`` at which a form is checked numerically: inside its bounds (three quarters up a finite
    range), one plus its magnitude beyond a single finite bound, 0.7 without bounds."""
    lo, hi = state.lower, state.upper
    if np.isfinite(lo) and np.isfinite(hi):
        return 0.5 * (lo + hi) + 0.25 * (hi - lo)
    if np.isfinite(lo):
        return lo + 1.0 + abs(lo)
    if np.isfinite(hi):
        return hi - 1.0 - abs(hi)
    return 0.7


__all__ = [
    "HamiltonianForm",
    "decompose",
    "has_quadratic_term",
    "l1_controls",
    "piecewise_affine_controls",
    "sample_value",
]
