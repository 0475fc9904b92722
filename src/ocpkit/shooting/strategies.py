"""The choices of a shooting method as small objects, with registries of the names notebooks use.

* switching treatment (:data:`SWITCHING_MODES`): how the integrator meets a switching
  (``"none"``, ``"detection"``, ``"correction"``; implemented in ``dopri5.c``);
* Jacobian of the shooting function (:data:`JACOBIANS`): :class:`FiniteDifferences`
  (``"fd"``, ``"central"``) or :class:`Variational` (``"variational"``);
* root solver (:data:`SOLVERS`): :class:`MinpackHybrid` (``"hybr"``) or
  :class:`DampedNewton` (``"newton"``).

A :class:`~ocpkit.shooting.Shooting` takes either a name or an object; a new
strategy is a small class with the same method. A root solver is called as
``solver(fun, jac, z0, *, tol, maxfev)`` and returns ``(z, detail)`` or
``(z, detail, outcome)``, ``outcome`` the :class:`~ocpkit.Outcome` it stopped for
(:attr:`~ocpkit.Outcome.CONVERGED` where it claims convergence, which the shooting
checks against ``tol``); a solver that takes ``stol`` (the keyword's deprecated name)
is still called with it, with a warning.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._deprecation import renamed, renamed_argument
from ..outcome import Outcome

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from .shooting import Shooting

#: the ways the integrator meets a switching, by name, ``"none"`` (not at all), ``"detection"`` (located) or
#: ``"correction"`` (located and the step corrected onto it; Martinon & Gergaud), in the order ``dopri5.c`` numbers
#: them
SWITCHING_MODES = ("none", "detection", "correction")


def __getattr__(name: str) -> tuple[str, ...]:
    if name == "DETECTION_MODES":
        renamed("ocpkit.shooting.DETECTION_MODES", "SWITCHING_MODES")
        return SWITCHING_MODES
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# -- Jacobians of S(z) -----------------------------------------------------------------------------


@dataclass(frozen=True)
class FiniteDifferences:
    """Forward (or ``central``) differences with the relative step ``step``, default the shooting's ``fd_step``.

    The step for unknown ``j`` is ``step max(|z_j|, 1)``.
    """

    central: bool = False
    step: float | None = None

    name = "fd"

    def __call__(
        self, shooting: Shooting, z: np.ndarray, P: np.ndarray, S0: ArrayLike | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        step = shooting.fd_step if self.step is None else self.step
        S0 = shooting.residual(z, P) if S0 is None else np.asarray(S0, dtype=float)
        J = np.empty((S0.size, z.size))
        for j in range(z.size):
            h = step * max(abs(z[j]), 1.0)
            zp = z.copy()
            zp[j] += h
            if self.central:
                zm = z.copy()
                zm[j] -= h
                J[:, j] = (shooting.residual(zp, P) - shooting.residual(zm, P)) / (2 * h)
            else:
                J[:, j] = (shooting.residual(zp, P) - S0) / h
        return S0, J


@dataclass(frozen=True)
class Variational:
    """dS/dz from the variational equations integrated alongside the flow (with their jump at each switching).

    ``dS/dz = dS/dy Psi(tf)`` and, for a free final time, the column
    ``dS/dy dy/dt(tf) + dS/dtf``.
    """

    name = "variational"

    def __call__(
        self, shooting: Shooting, z: np.ndarray, P: np.ndarray, S0: ArrayLike | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        res = shooting.integrate(z, P, variational=True)
        return shooting.residual_and_derivatives(z, P, res, variational=True)


#: the Jacobian strategies by name, as a :class:`~ocpkit.shooting.Shooting` takes them (``jacobian="fd"``)
JACOBIANS: dict[str, FiniteDifferences | Variational] = {
    "fd": FiniteDifferences(),
    "central": FiniteDifferences(central=True),
    "variational": Variational(),
}


def jacobian_strategy(
    spec: str | Callable[..., tuple[np.ndarray, np.ndarray]],
) -> Callable[..., tuple[np.ndarray, np.ndarray]]:
    """A Jacobian strategy from its name in :data:`JACOBIANS` or an object."""
    if isinstance(spec, str):
        if spec not in JACOBIANS:
            raise ValueError(f"jacobian must be one of {tuple(JACOBIANS)}, got {spec!r}")
        return JACOBIANS[spec]
    if not callable(spec):
        raise TypeError(f"a Jacobian strategy must be callable (shooting, z, P, S0) -> (S, J), got {spec!r}")
    return spec


# -- root solvers ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class MinpackHybrid:
    """MINPACK's hybrid Powell method (``scipy.optimize.root(method="hybr")``; the slides' solver).

    ``factor``: the initial trust-region bound ``factor |diag z0|``; ``xtol``: the relative step tolerance. MINPACK
    stops on its step (``xtol``), not on ``|S|``: its success is a claim the shooting checks against ``tol``.
    """

    xtol: float = 1e-14
    factor: float = 100.0

    name = "hybr"

    #: MINPACK's ``info`` (scipy's ``status``) as an outcome: 1 the relative step below xtol (a claim of
    #: convergence), 2 the evaluations ran out, 3 xtol too small, 4 and 5 no progress
    OUTCOMES = {
        1: Outcome.CONVERGED,
        2: Outcome.MAX_ITERATIONS,
        3: Outcome.STALLED,
        4: Outcome.STALLED,
        5: Outcome.STALLED,
    }

    def __call__(
        self,
        fun: Callable[[np.ndarray], np.ndarray],
        jac: Callable[[np.ndarray], np.ndarray],
        z0: ArrayLike,
        *,
        tol: float | None = None,
        maxfev: int,
        stol: float | None = None,
    ) -> tuple[np.ndarray, str, Outcome]:
        from scipy.optimize import root

        renamed_argument("stol", "tol", stol, tol, 0.0, "MinpackHybrid.__call__")  # (MINPACK stops on xtol)
        sol = root(
            fun, z0, jac=jac, method="hybr", options={"xtol": self.xtol, "maxfev": maxfev, "factor": self.factor}
        )
        return sol.x, " ".join(sol.message.split()), self.OUTCOMES.get(int(sol.status), Outcome.SOLVER_FAILED)


@dataclass(frozen=True)
class DampedNewton:
    """Least-squares Newton steps, halved until ``|S|^2`` decreases (Armijo, c = 1e-4).

    Stops at the first ``|S|`` <= 1e-15, when no step length down to 2^-14 decreases ``|S|``
    (the integrator's noise floor, or a failure far from a solution: :attr:`~ocpkit.Outcome.STALLED`), when
    ``|S|`` is below ``tol`` and the last step gained less than a factor 10, when the step cannot be computed
    (:attr:`~ocpkit.Outcome.SINGULAR_JACOBIAN`), or after ``maxfev`` shooting-function evaluations
    (:attr:`~ocpkit.Outcome.MAX_ITERATIONS`). Returns the best point seen.
    """

    name = "newton"

    def __call__(
        self,
        fun: Callable[[np.ndarray], np.ndarray],
        jac: Callable[[np.ndarray], np.ndarray],
        z0: ArrayLike,
        *,
        tol: float | None = None,
        maxfev: int,
        stol: float | None = None,
    ) -> tuple[np.ndarray, str, Outcome]:
        tol = renamed_argument("stol", "tol", stol, tol, 1e-8, "DampedNewton.__call__")
        z = np.asarray(z0, dtype=float)
        J = jac(z)
        S = fun(z)
        best = (np.linalg.norm(S), z)
        evaluations = 1
        message, outcome = "maximum number of evaluations reached", Outcome.MAX_ITERATIONS
        while evaluations < maxfev:
            norm = np.linalg.norm(S)
            if norm <= 1e-15:
                message, outcome = "residual at machine precision", Outcome.CONVERGED
                break
            try:
                step = np.linalg.lstsq(J, -S, rcond=None)[0]
            except np.linalg.LinAlgError:
                message, outcome = "the Newton step could not be computed", Outcome.SINGULAR_JACOBIAN
                break
            a, accepted = 1.0, False
            while a >= 2.0**-14 and evaluations < maxfev:
                trial = z + a * step
                St = fun(trial)
                evaluations += 1
                if np.linalg.norm(St) ** 2 <= (1 - 1e-4 * a) * norm**2:
                    accepted = True
                    break
                a *= 0.5
            if not accepted:
                message, outcome = "no step length decreases |S| (noise floor or stagnation)", Outcome.STALLED
                break
            z = trial
            J = jac(z)
            S = fun(z)
            new = np.linalg.norm(S)
            if new < best[0]:
                best = (new, z)
            if new <= tol and new > 0.1 * norm:
                message = "converged: |S| below tol and no longer decreasing quadratically"
                outcome = Outcome.CONVERGED
                break
        return best[1], message, outcome


#: the root solvers by name, as :meth:`Shooting.solve <ocpkit.shooting.shooting.Shooting.solve>` takes them
#: (``solver="newton"``)
SOLVERS: dict[str, MinpackHybrid | DampedNewton] = {"hybr": MinpackHybrid(), "newton": DampedNewton()}


def solver_strategy(spec: str | Callable[..., tuple[Any, ...]]) -> Callable[..., tuple[Any, ...]]:
    """A root solver from its name in :data:`SOLVERS` or an object."""
    if isinstance(spec, str):
        if spec not in SOLVERS:
            raise ValueError(f"solver must be one of {tuple(SOLVERS)}, got {spec!r}")
        return SOLVERS[spec]
    if not callable(spec):
        raise TypeError(
            f"a root solver must be callable (fun, jac, z0, *, tol, maxfev) -> (z, detail[, outcome]), got {spec!r}"
        )
    return spec


def run_solver(
    solver: Callable[..., tuple[Any, ...]],
    fun: Callable[[np.ndarray], np.ndarray],
    jac: Callable[[np.ndarray], np.ndarray],
    z0: np.ndarray,
    *,
    tol: float,
    maxfev: int,
) -> tuple[np.ndarray, str, Outcome | None]:
    """``(z, detail, outcome)`` of a root solver's run (module docstring; ``outcome`` None where the solver does not
    say). A solver that takes ``stol`` and not ``tol`` is called with ``stol``, with a DeprecationWarning."""
    try:
        parameters = list(inspect.signature(solver).parameters.values())
    except (TypeError, ValueError):  # a callable without a signature: called as the protocol says
        parameters = []
    takes = {p.name for p in parameters}
    if "tol" not in takes and "stol" in takes and not any(p.kind is p.VAR_KEYWORD for p in parameters):
        renamed("a root solver's keyword stol", "tol", stacklevel=4)
        out = solver(fun, jac, z0, stol=tol, maxfev=maxfev)
    else:
        out = solver(fun, jac, z0, tol=tol, maxfev=maxfev)
    if len(out) == 2:
        return np.asarray(out[0], dtype=float), str(out[1]), None
    z, detail, outcome = out
    return np.asarray(z, dtype=float), str(detail), None if outcome is None else Outcome(outcome)
