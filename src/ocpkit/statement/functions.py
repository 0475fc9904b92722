"""A statement's compiled CasADi functions and its Hamiltonian."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

import casadi as ca

if TYPE_CHECKING:
    from .constraints import ConstraintSet


@dataclass(frozen=True)
class ProblemFunctions:
    """A problem's CasADi functions, built once; the parameter vector ``P`` is the last input of each.

    ``f(x, u, t, P)`` the dynamics, ``L(x, u, t, P)`` the running cost (None without
    one), ``phi(x0, xf, t0, tf, P)`` the Mayer term (None without one), ``path``
    (``g(x, u, t, P)``) and ``boundary`` (``psi(x0, xf, t0, tf, P)``) the constraints
    (None without); and, for the indirect side, the Hamiltonian ``H = L + p' f``
    (:attr:`hamiltonian`).
    """

    f: ca.Function
    L: ca.Function | None
    phi: ca.Function | None
    path: ConstraintSet | None = None
    boundary: ConstraintSet | None = None

    @cached_property
    def hamiltonian(self) -> Hamiltonian:
        """The Hamiltonian ``H = L + p' f`` of these functions (:class:`Hamiltonian`, on its own symbols), built
        once."""
        return Hamiltonian.of(self)

    @cached_property
    def derived(self) -> dict[Any, Any]:
        """Functions built from these once and kept for every copy of the problem that shares them (e.g. the
        integrator of :func:`ocpkit.flight.fly`), keyed by what else they depend on."""
        return {}


@dataclass(frozen=True)
class Hamiltonian:
    """``H(x, p, u, t, P) = L + p' f`` as symbols and expressions (Pontryagin's principle).

    ``x, p, u, t, P`` are the SX symbols, ``f`` and ``L`` the dynamics and running
    cost in them (``L`` is 0 without a running cost), ``H`` the Hamiltonian; the
    costate equations are ``dp/dt = -dH/dx``.
    """

    x: ca.SX
    p: ca.SX
    u: ca.SX
    t: ca.SX
    P: ca.SX
    f: ca.SX
    L: ca.SX
    H: ca.SX

    @classmethod
    def of(
        cls, functions: ProblemFunctions, x: ca.SX | None = None, p: ca.SX | None = None, P: ca.SX | None = None
    ) -> Hamiltonian:
        """The Hamiltonian of ``functions``, on new symbols or on given ``x, p, P`` (with new ``u, t``).

        On given symbols it is a second expression graph of the same definition: the
        shooting engine's flows use one beside the control law's, as they always have,
        so that derivatives through the law's control keep their association order
        (and the compendium's published numbers their last bits).
        """
        f_fun = functions.f
        nx, nu, nP = f_fun.size1_in(0), f_fun.size1_in(1), f_fun.size1_in(3)
        x = ca.SX.sym("x", nx) if x is None else x
        p = ca.SX.sym("p", nx) if p is None else p
        u = ca.SX.sym("u", nu)
        P = ca.SX.sym("P", nP) if P is None else P
        t = ca.SX.sym("t")
        f = f_fun(x, u, t, P)
        L = functions.L(x, u, t, P) if functions.L is not None else ca.SX(0)
        return cls(x, p, u, t, P, f, L, L + ca.dot(p, f))
