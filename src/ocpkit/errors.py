"""Exceptions raised by ocpkit."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .outcome import Outcome


class SolverError(RuntimeError):
    """An NLP or shooting solve did not converge.

    The message names the solver's own status string, the effort spent
    (``iterations``, counted in ``unit``: IPOPT iterations, integration steps,
    shooting-function evaluations) and what to do about it. ``result`` holds the
    last iterate (a :class:`~ocpkit.Solution` or a shooting result) when there is
    one: never a converged answer, but what a diagnosis needs. A failure inside mesh
    refinement also carries ``best``, the most accurate converged solution of the
    meshes before (None if the first mesh failed), with its ``mesh_history``.

    An indirect solve's error (shooting, multiple and arc shooting, a certificate, a
    continuation) also carries its ``outcome`` (:class:`~ocpkit.Outcome`; None for the
    direct solvers, whose ``status`` is IPOPT's), and its message ends with the outcome's
    remedy. ``status`` is the solver's own words.
    """

    def __init__(
        self,
        solver: str,
        status: str,
        iterations: int | None = None,
        detail: str = "",
        unit: str = "iterations",
        result: Any = None,
        best: Any = None,
        *,
        outcome: Outcome | None = None,
    ) -> None:
        self.solver = solver
        self.status = status
        self.iterations = iterations
        self.result = result
        self.best = best
        self.detail = detail
        self.unit = unit
        self.outcome = outcome
        # a refinement's meshes before the failure (set by refinement; empty otherwise)
        self.mesh_history: list[Any] = []
        msg = f"{solver} failed with status {status!r}"
        if iterations is not None:
            msg += f" after {iterations} {unit}"
        if detail:
            msg += f": {detail}"
        if outcome is not None and outcome.remedy:
            msg += f"; {outcome}: {outcome.remedy}"
        super().__init__(msg)

    def with_detail(self, detail: str) -> SolverError:
        """The same failure (solver, status, effort, iterate, best solution, outcome) with ``detail`` for its
        detail: what a caller adds to a failure it passes on."""
        error = SolverError(
            self.solver, self.status, self.iterations, detail, self.unit, self.result, self.best, outcome=self.outcome
        )
        error.mesh_history = list(self.mesh_history)
        return error
