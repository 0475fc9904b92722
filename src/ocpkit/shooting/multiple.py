"""Multiple shooting of the switching engine's boundary-value problem (Bock & Plitt 1984; Stoer & Bulirsch,
*Introduction to Numerical Analysis*, section 7.3.5).

Single shooting over a long horizon answers a change of its unknowns with the flow's sensitivity over the whole
horizon, so the integrator's rounding and step decisions set a floor under ``|S|`` (Martinon & Gergaud's 0.1 N
transfer, 1201 switchings: about 1e-7). Cut into ``K`` segments, each node is only as sensitive as one segment's flow.

For a :class:`~ocpkit.shooting.Shooting` with unknowns ``z`` (per state its initial costate, or its initial value
where free, then ``tf`` where free) and conditions ``S(y(tf), tf)``, the nodes are ``t_k = t0 + s_k (tf - t0)``
at fixed fractions ``s_k`` (a free ``tf`` moves them with it), and

    Z = (z, y_1, ..., y_{K-1}),   R(Z) = (S(y(t_K^-), tf), W_1 (y(t_1^-) - y_1), ..., W_{K-1} (y(t_{K-1}^-) - y_{K-1}))

with ``y = (x, p, J)`` (J the running cost so far), ``y(t_{k+1}^-)`` the flow of segment k from its node and
``W_k = diag(1 / (1 + |y_k|))`` at the solve's start (relative defects: the transfer's costates of 1e4 and its
states of order one weigh alike). R is square. Its Jacobian comes from each segment's variational equations
(``2 nx`` columns with respect to the node's x and p; the cost does not enter the flow) and, for a free ``tf``,
each segment end's velocity times the segment's share of the horizon (the flows are autonomous).
:meth:`MultipleShooting.solve` drives ``R`` to zero with the
shooting's root solvers (damped Newton by default).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from .._deprecation import renamed_argument
from ..errors import SolverError
from ..outcome import Outcome
from .compiled import CompiledSystem, Integration
from .hamiltonian import HamiltonianSystem
from .result import IndirectResult, settled
from .shooting import Shooting, residual_noise
from .strategies import run_solver, solver_strategy
from .trajectory import ShootingTrajectory

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


@dataclass
class MultipleShootingResult(IndirectResult):
    """A multiple-shooting run: the fields every indirect run has (:class:`~ocpkit.shooting.result.IndirectResult`),
    ``residual`` and ``norm`` being R and ``|R|``, ``z`` the single shooting's unknowns at the solution, and its own:
    ``nodes`` the interior nodes' ``y = (x, p, J)`` (rows), ``times`` the node times ``t_0 .. t_K``; ``terminal`` the
    norm of the single shooting's conditions S at tf (the slides' ``|S|``) and ``continuity`` the largest relative
    defect ``|y(t_k^-) - y_k| / (1 + |y_k|)`` at the interior nodes; the ``switchings`` and integration ``steps``
    summed over the segments, and the segments' recorded ``integrations``; :attr:`trajectory` the extremal as
    functions of time (the segments' recorded flows, one after the other)."""

    nodes: np.ndarray
    times: np.ndarray
    terminal: float
    continuity: float
    switchings: int
    steps: int
    integrations: list[Integration] = field(repr=False, default_factory=list)
    system: HamiltonianSystem | None = field(repr=False, default=None)

    @property
    def tf(self) -> float:
        return float(self.times[-1])

    @property
    def integration(self) -> Integration:
        """The segments' recorded integrations joined into one record from t0 to tf (each node's defect, below the
        solve's tolerance, is where one segment's record ends and the next one's begins)."""
        if "_integration" in self.__dict__:
            return self.__dict__["_integration"]
        runs = self.integrations
        if not runs or any(r.states.shape[0] < 2 for r in runs):
            raise ValueError("this run has no recorded integrations: its last evaluation was not recorded")

        def joined(name: str) -> np.ndarray:
            return np.concatenate([getattr(r, name) for r in runs])

        self.__dict__["_integration"] = Integration(
            y=runs[-1].y,
            Psi=None,
            status=runs[-1].status,
            accepted=sum(r.accepted for r in runs),
            rejected=sum(r.rejected for r in runs),
            rhs_evaluations=sum(r.rhs_evaluations for r in runs),
            switchings=sum(r.switchings for r in runs),
            interior_switchings=sum(r.interior_switchings for r in runs),
            step_times=joined("step_times"),
            step_sizes=joined("step_sizes"),
            hamiltonian=joined("hamiltonian"),
            rejected_times=joined("rejected_times"),
            rejected_sizes=joined("rejected_sizes"),
            switching_times=joined("switching_times"),
            switching_index=joined("switching_index"),
            states=np.vstack([r.states for r in runs]),
            truncated=any(r.truncated for r in runs),
            parameters=runs[-1].parameters,
        )
        return self.__dict__["_integration"]

    @property
    def trajectory(self) -> ShootingTrajectory:
        """The extremal as functions of time (:class:`~ocpkit.shooting.trajectory.ShootingTrajectory` of
        :attr:`integration`)."""
        if "_trajectory" not in self.__dict__:
            system = cast(HamiltonianSystem, self.system)  # (set by the multiple shooting that made this result)
            self.__dict__["_trajectory"] = ShootingTrajectory(self.integration, system, self.objective)
        return self.__dict__["_trajectory"]


#: the most unknowns :class:`MultipleShooting` takes: its Jacobian is dense (4000^2 doubles: 128 MB)
MAX_UNKNOWNS = 4000


class MultipleShooting:
    """Multiple shooting of ``shooting``'s problem and law over ``segments`` equal shares of the horizon (module
    docstring). The segments are integrated as the shooting integrates (its switching treatment, tolerances and
    interior check), by a system compiled with ``2 nx`` variational columns."""

    def __init__(self, shooting: Shooting, segments: int = 10) -> None:
        if not (isinstance(segments, (int, np.integer)) and segments >= 2):
            raise ValueError(f"segments must be an integer of at least 2, got {segments!r}")
        self.shooting = shooting
        self.segments = int(segments)
        self.fractions = np.linspace(0.0, 1.0, self.segments + 1)
        problem = shooting.problem
        self.nx, self.n = problem.nx, 2 * problem.nx + 1
        self.compiled = CompiledSystem(HamiltonianSystem(problem, shooting.law, n_variational=2 * problem.nx))
        self.nz = shooting.nz + (self.segments - 1) * self.n
        if self.nz > MAX_UNKNOWNS:
            raise ValueError(
                f"{self.segments} segments of {self.n} unknowns each make {self.nz} unknowns, more than the "
                f"{MAX_UNKNOWNS} whose dense Jacobian this Newton iteration factorises; use fewer segments"
            )
        #: the continuity rows' weights, ``1 / (1 + |y_k|)`` at the start of the last :meth:`solve` (relative defects:
        #: costates of thousands and states of order one weigh alike), fixed during a solve and kept after it, so
        #: that :meth:`evaluate` and :meth:`noise` measure the solved function
        self.weights = np.ones((self.segments - 1, self.n))

    # -- the multiple shooting function ----------------------------------------------------------------
    def node_times(self, tf: float) -> np.ndarray:
        """The nodes' times ``t_0 .. t_K`` for a final time ``tf`` (the segments' fractions of the horizon)."""
        t0 = float(self.shooting.problem.t0)
        return t0 + self.fractions * (tf - t0)

    def _integrate(
        self, y0: ArrayLike, ta: float, tb: float, P: np.ndarray, Psi0: ArrayLike | None = None, record: bool = False
    ) -> Integration:
        return self.shooting.flow(y0, ta, tb, P, Psi0=Psi0, record=record, system=self.compiled)

    def _start(self, z: ArrayLike) -> tuple[np.ndarray, float]:
        unknowns, tf = self.shooting.split_unknowns(z)
        x0, p0 = self.shooting.initial_values(unknowns)
        return np.concatenate([x0, p0, [0.0]]), tf

    def nodes(self, z: ArrayLike, parameters: Mapping[str, float] | ArrayLike | None = None) -> np.ndarray:
        """The multiple-shooting unknowns ``Z`` continuing a single shooting's ``z``: each node where the flow
        from the previous one arrives."""
        P = self.shooting.parameter_vector(parameters)
        z = np.asarray(z, dtype=float).ravel()
        y, tf = self._start(z)
        times, out = self.node_times(tf), [z]
        for k in range(self.segments - 1):
            y = self._integrate(y, times[k], times[k + 1], P).y
            out.append(y)
        return np.concatenate(out)

    def _split(self, Z: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        Z = np.asarray(Z, dtype=float).ravel()
        if Z.size != self.nz:
            raise ValueError(
                f"Z must have {self.nz} entries (z, then {self.segments - 1} nodes of {self.n}), got {Z.size}"
            )
        m = self.shooting.nz
        return Z[:m], Z[m:].reshape(self.segments - 1, self.n)

    def evaluate(
        self,
        Z: ArrayLike,
        parameters: Mapping[str, float] | ArrayLike | None = None,
        *,
        jacobian: bool = True,
        record: bool = False,
    ) -> tuple[np.ndarray, np.ndarray | None, list[Integration]]:
        """``(R, dR/dZ, integrations)`` at ``Z`` (``dR/dZ`` None without ``jacobian``)."""
        s, sysm = self.shooting, self.compiled.system
        P = s.parameter_vector(parameters)
        z, Y = self._split(Z)
        y0, tf = self._start(z)
        times, nx, n, m, K = self.node_times(tf), self.nx, self.n, s.nz, self.segments
        R = np.empty(self.nz)
        D = np.zeros((self.nz, self.nz)) if jacobian else None
        first = np.zeros((n, 2 * nx))  # the first segment's columns: z's unknowns (an initial costate or state)
        first[np.where(s.free_initial, np.arange(nx), nx + np.arange(nx)), np.arange(nx)] = 1.0
        node = np.eye(n)[:, : 2 * nx]
        runs = []
        for k in range(K):
            start = y0 if k == 0 else Y[k - 1]
            res = self._integrate(
                start, times[k], times[k + 1], P, (first if k == 0 else node) if jacobian else None, record
            )
            runs.append(res)
            yb = res.y
            mode = sysm.mode_at(yb, P)
            share = self.fractions[k + 1] - self.fractions[k]
            if k < K - 1:
                rows = slice(m + k * n, m + (k + 1) * n)
                R[rows] = (yb - Y[k]) * self.weights[k]
            else:
                S, dSdy, dSdtf = (np.asarray(v) for v in s.terminal(yb, tf, mode, P))
                rows = slice(0, m)
                R[rows] = S.ravel()
            if not jacobian:
                continue
            D = cast(np.ndarray, D)  # (allocated above: a Jacobian is asked for)
            Psi = cast(np.ndarray, res.Psi)  # (integrated with the variational columns)
            # d(segment end)/d(its start): the variational columns for x and p; the cost J only adds itself
            dend = np.zeros((n, n))
            dend[:, : 2 * nx] = Psi
            dend[2 * nx, 2 * nx] = 1.0
            velocity = np.asarray(sysm.flow(yb, mode, P)).ravel() * share
            outer = dSdy if k == K - 1 else np.diag(self.weights[k])
            if k == 0:
                D[rows, :nx] = outer @ Psi[:, :nx]
            else:
                cols = slice(m + (k - 1) * n, m + k * n)
                D[rows, cols] = outer @ dend
            if k < K - 1:
                D[rows, m + k * n : m + (k + 1) * n] -= np.diag(self.weights[k])
            if s.free_tf:
                D[rows, m - 1] += outer @ velocity + (dSdtf.ravel() if k == K - 1 else 0.0)
        return R, D, runs

    def noise(self, Z: ArrayLike, parameters: Mapping[str, float] | ArrayLike | None = None, **options: Any) -> float:
        """The level below which ``|R(Z)|`` is chance (:func:`~ocpkit.shooting.shooting.residual_noise`, with the
        continuity weights of the last :meth:`solve`; ``options``: its ``samples``, ``relative``, ``seed``)."""
        return residual_noise(
            lambda Y: self.evaluate(Y, parameters, jacobian=False)[0],
            lambda Y: cast("tuple[np.ndarray, np.ndarray]", self.evaluate(Y, parameters)[:2]),  # (with the Jacobian)
            np.asarray(Z, dtype=float).ravel(),
            **options,
        )

    # -- solve -----------------------------------------------------------------------------------------
    def solve(
        self,
        Z0: ArrayLike,
        parameters: Mapping[str, float] | ArrayLike | None = None,
        *,
        solver: str | Callable[..., tuple[Any, ...]] = "newton",
        tol: float | None = None,
        maxfev: int = 50,
        raise_on_failure: bool = True,
        stol: float | None = None,
    ) -> MultipleShootingResult:
        """Solve ``R(Z) = 0`` from ``Z0`` to ``|R| <= tol`` (default 1e-10): the multiple-shooting unknowns, or a
        single shooting's ``z`` (the nodes then continue its flow, :meth:`nodes`). ``solver``: a root solver of
        :mod:`ocpkit.shooting.strategies` (``"newton"``, ``"hybr"`` or an object). A run that ends with ``|R| >
        tol`` raises a :class:`~ocpkit.SolverError` carrying the result and its :class:`~ocpkit.Outcome`
        (``raise_on_failure=False``: returns it). ``stol`` is the deprecated name of ``tol``."""
        tol = renamed_argument("stol", "tol", stol, tol, 1e-10, "MultipleShooting.solve")
        if not tol > 0:
            raise ValueError(f"tol must be positive, got {tol}")
        method = solver_strategy(solver)
        Z0 = np.asarray(Z0, dtype=float).ravel()
        if Z0.size == self.shooting.nz:
            Z0 = self.nodes(Z0, parameters)
        self.weights = 1.0 / (1.0 + np.abs(self._split(Z0)[1]))
        counts = {"S": 0, "jac": 0}
        cache: dict[bytes, tuple[np.ndarray, np.ndarray | None]] = {}

        def evaluate(Z: np.ndarray, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
            key = Z.tobytes()
            if key not in cache or (jacobian and cache[key][1] is None):
                try:
                    R, D, _ = self.evaluate(Z, parameters, jacobian=jacobian)
                except (SolverError, ValueError):
                    return np.full(self.nz, 1e10), None
                cache.clear()
                cache[key] = (R, D)
            return cache[key]

        def fun(Z: np.ndarray) -> np.ndarray:
            counts["S"] += 1
            R = evaluate(Z, False)[0]
            return R if np.all(np.isfinite(R)) else np.full(self.nz, 1e10)

        def jac(Z: np.ndarray) -> np.ndarray:
            counts["jac"] += 1
            D = evaluate(Z, True)[1]
            if D is None or not np.all(np.isfinite(D)):  # not integrated from this iterate, or not finite
                raise SolverError(
                    "multiple shooting",
                    "the Jacobian failed at an iterate",
                    counts["S"],
                    unit="evaluations",
                    outcome=Outcome.INTEGRATION_FAILED if D is None else Outcome.SINGULAR_JACOBIAN,
                )
            return D

        start = time.process_time()
        claimed: Outcome | None
        try:
            Z, message, claimed = run_solver(method, fun, jac, Z0, tol=tol, maxfev=maxfev)
        except SolverError as exc:
            if raise_on_failure:
                raise
            Z, message, claimed = Z0, str(exc), exc.outcome or Outcome.SOLVER_FAILED
        cpu = time.process_time() - start
        runs: list[Integration] = []
        try:
            R, _, runs = self.evaluate(Z, parameters, jacobian=False, record=True)
        except (SolverError, ValueError) as exc:
            if raise_on_failure:
                raise
            message = f"{message}; the integration at the last iterate failed: {exc}"
            claimed = Outcome.INTEGRATION_FAILED
            try:  # the start reported instead, where it can be integrated
                R, _, runs = self.evaluate(Z0, parameters, jacobian=False, record=True)
                Z = Z0
            except (SolverError, ValueError) as again:
                message = f"{message}; and at the start: {again}"
                R = np.full(self.nz, np.nan)
        z, Y = self._split(Z)
        m, norm = self.shooting.nz, float(np.linalg.norm(R))
        defects = R[m:].reshape(-1, self.n) / self.weights
        continuity = float(np.max(np.abs(defects) / (1.0 + np.abs(Y)))) if defects.size else 0.0
        if runs:
            tf = self._start(z)[1]
        else:  # nothing integrated: tf as the unknowns say (it may lie outside the domain)
            tf = float(z[-1]) if self.shooting.free_tf else float(cast(float, self.shooting.problem.tf))
        objective = (
            self.shooting.objective_of(runs[-1], tf, self.shooting.parameter_vector(parameters)) if runs else np.nan
        )
        converged, status = settled(norm, tol, claimed)
        result = MultipleShootingResult(
            z=z,
            nodes=Y,
            times=self.node_times(tf),
            residual=R,
            norm=norm,
            tol=tol,
            terminal=float(np.linalg.norm(R[:m])),
            continuity=continuity,
            converged=converged,
            status=status,
            detail=message,
            evaluations=counts["S"],
            iterations=counts["jac"],
            cpu_s=cpu,
            objective=float(objective),
            switchings=int(sum(r.switchings for r in runs)),
            steps=int(sum(r.accepted + r.rejected for r in runs)),
            integrations=runs,
            system=self.compiled.system,
            free_parameters=self.shooting.solved_free_parameters(self.shooting.initial_values(z[: self.nx])[0]),
        )
        if not result.converged and raise_on_failure:
            raise SolverError(
                "multiple shooting",
                message,
                counts["S"],
                f"|R| = {norm:.3e} > tol = {tol:g}; the last iterate is the error's .result",
                unit="evaluations",
                result=result,
                outcome=status,
            )
        return result


__all__ = ["MultipleShooting", "MultipleShootingResult"]
