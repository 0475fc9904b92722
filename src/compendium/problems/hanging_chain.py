"""The hanging chain of COPS 3.0, as COPS states it (constants in ``data/problems/hanging_chain.toml``).

    minimise x2(1)   subject to   x1' = u,   x2' = x1 sqrt(1 + u^2),   x3' = sqrt(1 + u^2),
        x1(0) = a,  x1(1) = b,  x2(0) = x3(0) = 0,  x3(1) = L,   u free,

the potential energy of a chain of length ``L`` hung between heights ``a`` and ``b``: the height ``x1`` as a
function of the horizontal position ``t``, its slope ``u`` the control, unbounded, as COPS has it, with COPS's
own starting point (:func:`hanging_chain`). Its minimiser is a catenary, :func:`catenary` in closed form.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ocpkit import Control, OptimalControlProblem, State

from ._data import load_problem_data


def hanging_chain() -> OptimalControlProblem:
    """COPS's hanging chain, its statement and its starting point as published (module docstring)."""
    d = load_problem_data("hanging_chain")
    c, tmin = d["constants"], d["guess"]["tmin"]
    a, b, length = c["a"], c["b"], c["L"]
    slope = 4 * abs(b - a)

    def u_guess(t):
        return slope * (np.asarray(t, dtype=float) - tmin)

    def x1_guess(t):
        t = np.asarray(t, dtype=float)
        return slope * t * (t / 2 - tmin) + a

    def dynamics(x, u, t):
        ds = ca.sqrt(1 + u[0] ** 2)
        return ca.vertcat(u[0], x[0] * ds, ds)

    return OptimalControlProblem(
        "hanging_chain",
        states=[
            State("x1", initial=a, final=b, guess=x1_guess),
            State("x2", initial=0.0, guess=lambda t: x1_guess(t) * u_guess(t)),
            State("x3", initial=0.0, final=length, guess=u_guess),
        ],
        controls=[Control("u", guess=u_guess)],
        dynamics=dynamics,
        tf=1.0,
        mayer=lambda x0, xf, t0, tf: xf[1],
        description="Hanging chain, minimum potential energy (COPS 3.0)",
    )


def catenary() -> dict[str, float]:
    """The exact minimiser, ``x1 = D + C cosh((t - t_m) / C)`` through ``(0, a)`` and ``(1, b)`` with length ``L``,
    and its energy ``J = D L + C (1/2 + C (sinh(2 (1 - t_m) / C) + sinh(2 t_m / C)) / 4)``."""
    from scipy.optimize import fsolve  # here: posing a compendium problem loads no scipy

    c = load_problem_data("hanging_chain")["constants"]
    a, b, length = c["a"], c["b"], c["L"]

    def residual(z):
        C, tm, D = z
        return [
            D + C * np.cosh(-tm / C) - a,
            D + C * np.cosh((1 - tm) / C) - b,
            C * (np.sinh((1 - tm) / C) + np.sinh(tm / C)) - length,
        ]

    C, tm, D = fsolve(residual, [0.5, 0.0, 0.0], xtol=1e-12)
    if np.max(np.abs(residual([C, tm, D]))) > 1e-12:
        raise RuntimeError("the catenary's equations did not solve")
    J = D * length + C * (0.5 + C * (np.sinh(2 * (1 - tm) / C) + np.sinh(2 * tm / C)) / 4)
    return {"C": float(C), "t_m": float(tm), "D": float(D), "J": float(J)}


__all__ = ["catenary", "hanging_chain"]
