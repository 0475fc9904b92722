"""One result contract for the indirect engines: :class:`IndirectResult`.

:class:`~ocpkit.shooting.ShootingResult`, :class:`~ocpkit.shooting.MultipleShootingResult` and
:class:`~ocpkit.shooting.arcs.ArcResult` share its fields, and :class:`~ocpkit.indirect.Extremal` exposes the same
names (read from its run and its certificate). ``converged``, ``status``, ``iterations``, ``objective`` and
``trajectory`` carry the names they have on a direct :class:`~ocpkit.Solution`; ``status`` is an
:class:`~ocpkit.Outcome` (a ``str``), where a direct solution's is IPOPT's string.

Every engine sets ``converged`` to whether ``norm`` is finite and at most ``tol``, and ``status`` to
:attr:`~ocpkit.Outcome.CONVERGED` exactly then; otherwise to the reason it stopped (a solver's claim of
convergence above ``tol`` is :attr:`~ocpkit.Outcome.STALLED`). ``detail`` is the solver's own words.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .._deprecation import renamed
from ..outcome import Outcome

if TYPE_CHECKING:
    from ..trajectory import Trajectory


@dataclass(kw_only=True)
class IndirectResult:
    """What every indirect run reports (module docstring); its fields are keyword-only.

    ``z`` the unknowns at the returned point, ``residual`` and ``norm`` the shooting function there and its norm
    (for multiple shooting, R and ``|R|``), ``tol`` the tolerance asked for, ``converged`` whether ``norm <= tol``
    (finite), ``status`` how the run ended (:class:`~ocpkit.Outcome`, its ``remedy`` what to try next), ``detail``
    the solver's own words, ``iterations`` the Jacobian evaluations (one per Newton iteration; MINPACK's hybrid
    method evaluates fewer Jacobians than it iterates), ``evaluations`` the shooting-function evaluations,
    ``cpu_s`` the process time of the solve, ``objective`` the cost of the returned point (NaN where it cannot be
    integrated), ``free_parameters`` the solved free parameters by name, and :attr:`trajectory` the extremal as
    functions of time. ``message``, ``n_shooting`` and ``n_jacobian`` are the deprecated names of ``detail``,
    ``evaluations`` and ``iterations``.
    """

    z: np.ndarray
    residual: np.ndarray
    norm: float
    tol: float
    converged: bool
    status: Outcome
    detail: str
    iterations: int
    evaluations: int
    cpu_s: float
    objective: float
    #: the solved free parameters by name (states of the shooting's problem,
    #: :meth:`~ocpkit.OptimalControlProblem.parameters_as_states`)
    free_parameters: dict[str, float] = field(default_factory=dict)

    @property
    def trajectory(self) -> Trajectory:
        """The extremal as functions of time (state, control, costates); a ValueError where the run has none (its
        last iterate could not be integrated)."""
        raise ValueError(f"this run has no trajectory: {self.status}: {self.detail}")

    @property
    def message(self) -> str:
        """Deprecated name of ``detail``."""
        renamed(f"{type(self).__name__}.message", f"{type(self).__name__}.detail")
        return self.detail

    @property
    def n_shooting(self) -> int:
        """Deprecated name of ``evaluations``."""
        renamed(f"{type(self).__name__}.n_shooting", f"{type(self).__name__}.evaluations")
        return self.evaluations

    @property
    def n_jacobian(self) -> int:
        """Deprecated name of ``iterations``."""
        renamed(f"{type(self).__name__}.n_jacobian", f"{type(self).__name__}.iterations")
        return self.iterations


def settled(norm: float, tol: float, claimed: Outcome | None) -> tuple[bool, Outcome]:
    """``(converged, status)`` of a run that ended at ``|S| = norm``, its solver having stopped for ``claimed``
    (None: a solver that does not say): converged exactly where ``norm`` is finite and at most ``tol``; otherwise
    the solver's reason, a claim of convergence being a stall, and no reason a solver failure."""
    if np.isfinite(norm) and norm <= tol:
        return True, Outcome.CONVERGED
    if claimed is None:
        return False, Outcome.SOLVER_FAILED
    return False, Outcome.STALLED if claimed is Outcome.CONVERGED else claimed


__all__ = ["IndirectResult", "settled"]
