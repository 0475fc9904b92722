"""The hyper-sensitive problem (Rao & Mease 2000; the test problem of GPOPS-II and of Patterson, Hager & Rao's
ph mesh refinement method): a long horizon with boundary layers at both ends.

    minimise  1/2 int_0^tf (x^2 + u^2) dt,   x' = -x^3 + u,   x(0) = 1.5,   x(tf) = 1.

For a long horizon the solution decays from 1.5 to near 0 within a few time units, stays there, and rises to 1 in
the last few: a uniform mesh wastes its points in the middle.
"""

from __future__ import annotations

from ocpkit import Control, OptimalControlProblem, State


def hyper_sensitive(tf: float = 10000.0) -> OptimalControlProblem:
    if not tf > 0:
        raise ValueError(f"tf must be positive, got {tf!r}")
    return OptimalControlProblem(
        "hyper_sensitive",
        states=[State("x", initial=1.5, final=1.0)],
        controls=[Control("u")],
        dynamics=lambda x, u, t: -(x[0] ** 3) + u[0],
        tf=float(tf),
        lagrange=lambda x, u, t: (x[0] ** 2 + u[0] ** 2) / 2,
    )
