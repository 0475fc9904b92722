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

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .._deprecation import renamed
from ..outcome import Outcome

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ..trajectory import Trajectory
    from .grazing import Approach


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
    #: where the run stalled above ``tol``: the noise floor of S measured at the last iterate (:func:`noise_floor`),
    #: which :attr:`remedy` compares with ``tol`` (:func:`stall_advice`); None where it was not measured
    noise: float | None = None
    #: where the run stalled above ``tol``, away from the integrator's noise: the switching functions' nearest
    #: approach to zero without a crossing at the last iterate (:func:`~ocpkit.shooting.grazing.closest_approach`),
    #: a grazing switching where it is within :data:`~ocpkit.shooting.grazing.GRAZING` of their range; None where
    #: it was not measured
    grazing: Approach | None = None

    @property
    def remedy(self) -> str:
        """What to try next, the ``status``'s remedy, after the measured noise and the ``tol`` that would pass where
        the run stalled (:func:`stall_advice`)."""
        if self.noise is None:
            return self.status.remedy
        return f"{stall_advice(self.norm, self.tol, self.noise, self.grazing)}; {self.status.remedy}"

    @property
    def trajectory(self) -> Trajectory:
        """The extremal as functions of time (state, control, costates); a ValueError where the run has none (its
        last iterate could not be integrated)."""
        raise ValueError(f"this run has no trajectory: {self.status}: {self.detail}")

    def plot(
        self,
        which: str | Sequence[str] | None = None,
        *,
        names: str | Sequence[str] | None = None,
        n: int = 401,
        figsize: tuple[float, float] | None = None,
        fig: Figure | None = None,
    ) -> Figure:
        """A matplotlib figure of the run's :attr:`trajectory` (:meth:`Trajectory.plot
        <ocpkit.trajectory.Trajectory.plot>`, the same arguments: states, controls, costates, the switching times
        and junctions dotted), titled with the problem, the run's status, its objective and ``|S|``."""
        from ..plotting import trajectory_figure

        tr = self.trajectory
        title = f"{tr.problem.name}, {type(self).__name__} ({self.status}): objective {self.objective:.8g}, "
        title += f"|S| = {self.norm:.1e}"
        return trajectory_figure(tr, which, names=names, n=n, figsize=figsize, fig=fig, title=title)

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


def noise_floor(
    residual: Callable[[np.ndarray], np.ndarray],
    z: np.ndarray,
    *,
    relative: float = 1e-9,
    points: int = 9,
    directions: int = 3,
    seed: int = 0,
) -> float:
    """The noise floor of a shooting function at ``z``: how far ``S`` scatters about a straight line through ``z``.

    Along each of ``directions`` random directions ``dz`` (entry ``j`` of size ``relative max(|z_j|, 1)``), S at
    ``z + s dz`` for ``points`` values of ``s`` in [-1, 1]; a straight line fitted per component by least squares;
    the norm over the components of the scatter about it (root mean square), the median over the directions. Over
    such small changes S is linear to rounding, so what is left is what the integrator adds: step-size decisions,
    switchings crossing step ends. Unlike :func:`~ocpkit.shooting.shooting.residual_noise` it needs no Jacobian (an
    integrated Jacobian's own error would count as noise). On the Goddard rocket stated in feet, 2.5e-8 for relative
    sizes from 1e-12 to 1e-7 alike; a root-finder cannot push ``|S|`` below it but by chance. An evaluation that
    fails counts as no scatter of that direction (it is skipped)."""
    z = np.asarray(z, dtype=float)
    rng = np.random.default_rng(seed)
    s = np.linspace(-1.0, 1.0, points)
    line = np.column_stack([np.ones(points), s])
    spreads = []
    for _ in range(directions):
        dz = relative * np.maximum(np.abs(z), 1.0) * rng.standard_normal(z.size)
        try:
            Y = np.array([np.asarray(residual(z + si * dz), dtype=float).ravel() for si in s])
        except (RuntimeError, ValueError, ArithmeticError):
            continue
        if not np.all(np.isfinite(Y)):
            continue
        scatter = Y - line @ np.linalg.lstsq(line, Y, rcond=None)[0]
        spreads.append(float(np.linalg.norm(np.sqrt(np.mean(scatter**2, axis=0)))))
    return float(np.median(spreads)) if spreads else float("nan")


def stall_advice(norm: float, tol: float, noise: float, grazing: Approach | None = None) -> str:
    """What a run that stalled at ``|S| = norm`` above ``tol`` tells its user, given S's ``noise`` floor
    (:func:`noise_floor`). Where ``|S|`` is within ten times the noise, the stall is the integrator's: the sentence
    names the noise and the ``tol`` that would pass (the power of ten at or above both ``|S|`` and the noise; a tol
    below the noise is met only by chance), and how to lower the noise. Otherwise it says the stall is not the
    noise's, and, where ``grazing`` (the switching functions' nearest approach to zero without a crossing,
    :func:`~ocpkit.shooting.grazing.closest_approach`) is a grazing switching, where, and what gets past it."""
    if not np.isfinite(noise):
        return f"the noise of S could not be measured here (S fails near the last iterate); |S| = {norm:.2g}"
    if norm <= 10.0 * noise:
        passing = 10.0 ** np.ceil(np.log10(max(norm, noise, 1e-300)))
        return (
            f"|S| = {norm:.2g} stalled at the integrator's noise: S scatters by {noise:.2g} about its linear part "
            f"under relative changes of 1e-9 of the unknowns, above tol = {tol:g}; tol={passing:.0e} would pass "
            "(a tol below the noise is met only by chance), or lower the noise: state the problem in units where "
            "the states and costates are of order one (a condition of size 1e4 carries 1e4 times the rounding of "
            "one of size 1), or tighten the integrator's rtol/atol"
        )
    said = (
        f"|S| = {norm:.2g} is {norm / max(noise, 1e-300):.2g} times S's noise ({noise:.2g}): not the integrator's "
        "noise; far from a solution, or another switching structure"
    )
    if grazing is not None and grazing.grazing:
        said += (
            f"; at the last iterate {grazing.describe()}: a grazing switching, an arc appearing or vanishing there, "
            "where S is not differentiable and the Jacobian does not see the arc; start nearer the solution (a "
            "continuation), or take another path to it (solver='newton', a tighter integrator rtol/atol)"
        )
    return said


__all__ = ["IndirectResult", "noise_floor", "settled", "stall_advice"]
