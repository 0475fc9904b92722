"""Exceptions raised by ocpkit."""

from __future__ import annotations


class SolverError(RuntimeError):
    """An NLP or shooting solve did not converge.

    The message names the solver's own status string; the attributes keep what
    is needed to diagnose the failure, but no result is ever returned from it.
    """

    def __init__(self, solver: str, status: str, iterations: int | None = None, detail: str = ""):
        self.solver = solver
        self.status = status
        self.iterations = iterations
        msg = f"{solver} failed with status {status!r}"
        if iterations is not None:
            msg += f" after {iterations} iterations"
        if detail:
            msg += f": {detail}"
        super().__init__(msg)
