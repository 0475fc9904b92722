"""What every continuation of the transfer shares: a solve that tries several solvers, a thrust schedule
(:func:`ocpkit.shooting.follow` does the stepping)."""

from __future__ import annotations

from ocpkit import SolverError
from ocpkit.shooting import Shooting


def solve_robustly(shooting: Shooting, z, *, solvers=("hybr", "newton"), maxfev: int = 200, **options):
    """The first converged solve among ``solvers`` (raises the last :class:`SolverError`)."""
    error = None
    for solver in solvers:
        try:
            return shooting.solve(z, solver=solver, maxfev=maxfev, **options)
        except SolverError as exc:
            error = exc
    raise error


def thrust_schedule(start: float, targets, factor: float = 0.8) -> list[float]:
    """Thrusts from ``start`` down to ``min(targets)`` by ratios of at most ``factor``, through every target."""
    targets = sorted({float(t) for t in targets}, reverse=True)
    out, T = [], float(start)
    lowest = targets[-1]
    while T > lowest * (1 + 1e-12):
        Tn = max(T * factor, lowest)
        for tgt in targets:
            if Tn < tgt < T * (1 - 1e-12):
                Tn = tgt
        out.append(Tn)
        T = Tn
    return out
