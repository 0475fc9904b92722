"""Exceptions raised by ocpkit."""

from __future__ import annotations

from typing import Any


class SolverError(RuntimeError):
    """An NLP or shooting solve did not converge.

    The message names the solver's own status string, the effort spent
    (``iterations``, counted in ``unit``: IPOPT iterations, integration steps,
    shooting-function evaluations) and what to do about it. ``result`` holds the
    last iterate (a :class:`~ocpkit.Solution` or a shooting result) when there is
    one: never a converged answer, but what a diagnosis needs. A failure inside mesh
    refinement also carries ``best``, the most accurate converged solution of the
    meshes before (None if the first mesh failed), with its ``mesh_history``.
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
    ) -> None:
        self.solver = solver
        self.status = status
        self.iterations = iterations
        self.result = result
        self.best = best
        self.detail = detail
        self.unit = unit
        # a refinement's meshes before the failure (set by refinement; empty otherwise)
        self.mesh_history: list[Any] = []
        msg = f"{solver} failed with status {status!r}"
        if iterations is not None:
            msg += f" after {iterations} {unit}"
        if detail:
            msg += f": {detail}"
        super().__init__(msg)
