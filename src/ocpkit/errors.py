"""Exceptions raised by ocpkit."""

from __future__ import annotations


class SolverError(RuntimeError):
    """An NLP or shooting solve did not converge.

    The message names the solver's own status string and the effort spent
    (``iterations``, counted in ``unit``: IPOPT iterations, integration steps,
    shooting-function evaluations); the attributes keep what is needed to
    diagnose the failure, but no result is ever returned from it.
    """

    def __init__(self, solver: str, status: str, iterations: int | None = None, detail: str = "",
                 unit: str = "iterations"):
        self.solver = solver
        self.status = status
        self.iterations = iterations
        msg = f"{solver} failed with status {status!r}"
        if iterations is not None:
            msg += f" after {iterations} {unit}"
        if detail:
            msg += f": {detail}"
        super().__init__(msg)
