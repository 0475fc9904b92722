"""Simple shooting for the boundary-value problem of Pontryagin's principle.

Unknowns ``z = p(t0)`` (and ``tf`` when it is free); the state starts at the
problem's fixed initial state. The shooting function collects, at ``tf``:

* ``x_i(tf) - x_i^f`` for every state with a fixed final value;
* ``p_i(tf) - d phi / d x_i(tf)`` for every free final state (transversality);
* ``H(tf) + d phi / d tf`` when ``tf`` is free (H is constant along an autonomous flow).

The multiplier of the cost is normal, ``p^0 = 1``: ``H = L + p'f`` (``L = 0`` without a
running cost); abnormal extremals (``p^0 = 0``) are not sought. Minimum time may be
stated either way, with the same costates and extremal:

* as a Mayer term ``phi = tf`` (``mayer=lambda x0, xf, t0, tf: tf``, no running cost):
  ``H = p'f`` and the condition reads ``H(tf) + 1 = 0``;
* as a running cost ``L = 1`` (``lagrange=lambda x, u, t: 1``): ``H = 1 + p'f`` and
  ``H(tf) = 0``.

Either needs a control law minimising ``p'f`` over the controls: derived when it is
affine in bounded controls (bang-bang, :func:`~ocpkit.shooting.control_law` ``"box"``
or ``"ball"``), else given, ``control_law(problem, u_star)`` (a brachistochrone).

``S(z) = 0`` is solved with MINPACK's hybrid method (``scipy.optimize.root``,
``hybr``; the source's solver) or a damped Newton method (Armijo backtracking on
``|S|``), given a Jacobian either by forward finite differences (step
``sqrt(eta) max(|z_j|, 1)`` with ``eta`` the relative noise of S, the rule of Dennis &
Schnabel, *Numerical Methods for Unconstrained Optimization*, Sec. 5.4, and MINPACK's
``epsfcn``: the integrator's tolerance without switching detection, whose error
enters S at every switching, and the machine precision with detection or correction,
MINPACK's default) or
from the variational equations integrated alongside (``dy/dz`` with its jump at
each switching).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any, cast

import casadi as ca
import numpy as np

from .._deprecation import renamed, renamed_argument
from ..errors import SolverError
from ..outcome import Outcome
from ..statement import FreeFinalTime, OptimalControlProblem
from .compiled import CompiledSystem, Integration
from .grazing import closest_approach
from .hamiltonian import ControlLaw, HamiltonianSystem, control_law
from .result import IndirectResult, noise_floor, settled, stall_advice
from .strategies import SWITCHING_MODES, MinpackHybrid, jacobian_strategy, run_solver, solver_strategy
from .trajectory import ShootingTrajectory

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def _where(at: ArrayLike | None, t0: float, tf: float) -> str:
    """Where a failed integration started: the unknowns ``at``, else its interval."""
    return f"at z = {np.array2string(np.asarray(at), precision=6)}" if at is not None else f"on [{t0:.6g}, {tf:.6g}]"


@dataclass
class ShootingResult(IndirectResult):
    """A shooting run: the fields every indirect run has (:class:`~ocpkit.shooting.result.IndirectResult`: ``z``,
    ``residual``, ``norm``, ``tol``, ``converged``, ``status``, ``detail``, ``iterations``, ``evaluations``,
    ``cpu_s``, ``objective``, ``free_parameters``, :attr:`trajectory`), and the shooting's own.

    ``z`` the unknowns (per state its initial costate, or its initial value where free; ``tf`` the final time),
    ``p0`` the initial costates (0 for a free initial state), ``tf`` the final time, ``iterations`` and
    ``evaluations`` the Jacobian and shooting-function evaluations, ``n_integrations`` the integrations,
    ``parameters`` the problem parameters, ``integration`` the recorded final integration (steps, switchings, the
    Hamiltonian along it) and :attr:`trajectory` the state, control and costates as functions of time.
    """

    p0: np.ndarray
    tf: float
    n_integrations: int
    #: the switching treatment of the run (a name in :data:`~ocpkit.shooting.SWITCHING_MODES`); ``detection`` is its
    #: deprecated name
    switching: str
    jacobian: str
    parameters: np.ndarray
    #: None where the integration at the last iterate failed (``solve(raise_on_failure=False)``)
    integration: Integration | None = field(repr=False)
    system: HamiltonianSystem | None = field(repr=False, default=None)

    @property
    def detection(self) -> str:
        """Deprecated name of :attr:`switching`."""
        renamed("ShootingResult.detection", "ShootingResult.switching")
        return self.switching

    @property
    def trajectory(self) -> ShootingTrajectory:
        """The solution as functions of time (state, control, costates; re-integration, differences)."""
        if self.integration is None:
            raise ValueError(f"this run has no trajectory: {self.status}: {self.detail}")
        if "_trajectory" not in self.__dict__:
            system = cast(HamiltonianSystem, self.system)  # (set by the shooting that made this result)
            self.__dict__["_trajectory"] = ShootingTrajectory(self.integration, system, self.objective)
        return self.__dict__["_trajectory"]

    def summary(self) -> dict[str, Any]:
        """The result as a table row; the switching treatment under ``"detection"``, the column of Martinon &
        Gergaud's tables (and of ``data/paper/switching_detection.csv``), the shooting-function and Jacobian
        evaluations under ``"n_S"`` and ``"n_jac"`` (the published tables' columns)."""
        tr: Any = self.integration
        if tr is None:  # the integration at the last iterate failed
            nan = float("nan")
            tr = SimpleNamespace(
                switchings=nan, accepted=nan, rejected=nan, steps=nan, rejected_ratio=nan, hamiltonian_drift=nan
            )
        return {
            "detection": self.switching,
            "jacobian": self.jacobian,
            "objective": self.objective,
            "norm_S": self.norm,
            "converged": self.converged,
            "n_S": self.evaluations,
            "n_jac": self.iterations,
            "integrations": self.n_integrations,
            "cpu_s": self.cpu_s,
            "switchings": tr.switchings,
            "accepted": tr.accepted,
            "rejected": tr.rejected,
            "steps": tr.steps,
            "rejected_pct": 100 * tr.rejected_ratio,
            "hamiltonian_drift": tr.hamiltonian_drift,
        }


def residual_noise(
    residual: Callable[[np.ndarray], np.ndarray],
    jacobian: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    z: ArrayLike,
    *,
    samples: int = 12,
    relative: float = 1e-12,
    seed: int = 0,
) -> float:
    """How noisy a shooting function is at ``z``: the level below which its norm is chance.

    The median of ``|S(z + dz) - S(z) - J dz|`` over random ``dz`` of relative size ``relative``, with ``(S(z), J)
    = jacobian(z)`` exact (variational): what is left once the smooth response is removed is the discontinuity of
    S (step-size decisions, switchings crossing step ends, arcs located or missed). A root-finder cannot push ``|S|``
    below it but by luck. ``residual(z)`` evaluates S alone.
    """
    z = np.asarray(z, dtype=float)
    rng = np.random.default_rng(seed)
    S0, J = jacobian(z)
    diffs = []
    for _ in range(samples):
        dz = relative * np.abs(z) * rng.standard_normal(z.size)
        diffs.append(np.linalg.norm(residual(z + dz) - S0 - J @ dz))
    return float(np.median(diffs))


class Shooting:
    """Shooting for ``problem`` with a control law (see :func:`ocpkit.shooting.control_law`).

    Parameters
    ----------
    problem : OptimalControlProblem
        Autonomous, initial and final states fixed or free (a free initial state is an unknown whose costate
        starts at 0). Free parameters become states of zero dynamics free at both ends
        (:meth:`~ocpkit.OptimalControlProblem.parameters_as_states`: :attr:`problem` is that statement, and a
        derived box law is derived again for it); the solved ones are the result's ``free_parameters``.
    law : ControlLaw
        ``control_law(problem, "box" | "ball", ...)`` (derived) or ``control_law(problem, u_star)``
        (the user's minimiser of H: one smooth mode, for which ``switching`` changes nothing).
    switching : str
        ``"none"``, ``"detection"`` or ``"correction"`` (default): how the integrator meets a switching
        (:data:`~ocpkit.shooting.SWITCHING_MODES`), not at all, located (switching detection), or located and the
        step corrected onto it (Martinon & Gergaud). ``detection`` is its deprecated name.
    jacobian : str or callable
        ``"fd"``, ``"central"`` or ``"variational"`` (default), a name in :data:`~ocpkit.shooting.JACOBIANS`, or a
        Jacobian strategy object (:mod:`ocpkit.shooting.strategies`).
    rtol, atol : float
        Integrator tolerances.
    interior_check : bool
        Also detect a pair of switchings inside one integration step (a short arc); see
        :meth:`CompiledSystem.integrate`. Off: the sign test at the step's ends only.
    fd_step : float, optional
        Relative step of the finite-difference Jacobian; default ``sqrt(rtol)`` without
        switching detection and ``sqrt(eps)`` with it (see the module docstring).
    system : CompiledSystem, optional
        Reuse an already compiled system for the same problem and law.

    Attributes
    ----------
    problem : OptimalControlProblem
        The statement shot: ``problem``, or, where it has free parameters, its
        :meth:`~ocpkit.OptimalControlProblem.parameters_as_states`.
    switching : str
        How the integrator meets a switching (a name in :data:`~ocpkit.shooting.SWITCHING_MODES`); ``detection``
        is its deprecated name.
    """

    @property
    def detection(self) -> str:
        """Deprecated name of :attr:`switching`."""
        renamed("Shooting.detection", "Shooting.switching")
        return self.switching

    def __init__(
        self,
        problem: OptimalControlProblem,
        law: ControlLaw,
        *,
        switching: str | None = None,
        jacobian: str | Callable[..., tuple[np.ndarray, np.ndarray]] = "variational",
        rtol: float = 1e-8,
        atol: float = 1e-8,
        system: CompiledSystem | None = None,
        max_steps: int = 2_000_000,
        interior_check: bool = True,
        fd_step: float | None = None,
        detection: str | None = None,
    ) -> None:
        switching = renamed_argument("detection", "switching", detection, switching, "correction", "Shooting")
        if switching not in SWITCHING_MODES:
            raise ValueError(f"switching must be one of {SWITCHING_MODES}, got {switching!r}")
        self._jacobian = jacobian_strategy(jacobian)
        if not (rtol > 0 and atol > 0):
            raise ValueError(f"tolerances must be positive, got rtol={rtol}, atol={atol}")
        self.statement = problem
        if problem.free_parameters:
            problem = problem.parameters_as_states()
            if law.hamiltonian is not None and law.hamiltonian.x.numel() != problem.nx:
                if law.control_set != "box":
                    raise ValueError(
                        f"{problem.name!r} has free parameters, which shooting treats as states (their costates "
                        "start and end at their transversality conditions): derive the law for "
                        "problem.parameters_as_states()"
                    )
                law = control_law(problem, "box", regularized=law.regularized)
        self.problem, self.law = problem, law
        self.switching = switching
        self.jacobian = jacobian if isinstance(jacobian, str) else getattr(jacobian, "name", type(jacobian).__name__)
        self.rtol, self.atol, self.max_steps = rtol, atol, max_steps
        self.interior_check = bool(interior_check)
        noise = max(rtol, np.finfo(float).eps) if switching == "none" else np.finfo(float).eps
        self.fd_step = float(np.sqrt(noise)) if fd_step is None else float(fd_step)
        if not (self.fd_step > 0 and np.isfinite(self.fd_step)):
            raise ValueError(f"fd_step must be positive, got {fd_step!r}")
        nx = problem.nx
        if problem.free_initial_time:
            raise ValueError(
                f"the shooting engine integrates from a fixed t0; {problem.name!r} has a free one: solve it with a "
                "direct transcription (HLGL, Radau)"
            )
        constrained = [c.name for c in (*problem.path_constraints, *problem.boundary_constraints)]
        if constrained:
            raise ValueError(
                f"the shooting engine does not treat path or boundary constraints ({constrained} of {problem.name!r}); "
                "solve the problem with a direct transcription (HLGL, Radau)"
            )
        for s in problem.states:
            if s.initial is not None and s.fixed_initial is None:
                raise ValueError(f"shooting supports fixed or free initial states, not the interval of {s.name!r}")
            if s.final is not None and s.fixed_final is None:
                raise ValueError(f"shooting supports fixed or free final states, not the interval of {s.name!r}")
        # a free initial state is an unknown of the shooting, its costate starting at 0 (transversality); the
        # unknowns z: per state, its initial costate (fixed initial value) or its initial value (free), then tf
        self.free_initial = np.array([s.initial is None for s in problem.states])
        self.x0 = np.array([0.0 if s.initial is None else s.fixed_initial for s in problem.states])
        self.fixed_final = [s.fixed_final is not None for s in problem.states]
        self.free_tf = isinstance(problem.tf, FreeFinalTime)
        self.nz = nx + int(self.free_tf)
        self.compiled = system if system is not None else CompiledSystem(HamiltonianSystem(problem, law))
        sysm = self.compiled.system
        if sysm.n_variational != nx:
            raise ValueError("the compiled system must carry nx variational columns")
        # boundary conditions S(y_f, tf, mode, P) and their derivatives
        yf = ca.SX.sym("yf", sysm.n)
        tf = ca.SX.sym("tf")
        mode = ca.SX.sym("mode")
        P = ca.SX.sym("P", len(problem.parameters))
        xf, pf = yf[:nx], yf[nx : 2 * nx]
        x0 = ca.SX.sym("x0", nx)
        phi = problem.phi(x0, xf, problem.t0, tf, P) if problem.phi is not None else ca.SX(0)
        if np.any(self.free_initial) and ca.depends_on(phi, x0[np.flatnonzero(self.free_initial).tolist()]):
            raise ValueError(f"{problem.name!r}: shooting needs a Mayer term independent of the free initial states")
        phi = ca.substitute(phi, x0, ca.DM(self.x0))
        dphi = ca.gradient(phi, xf)
        rows = []
        for i, s in enumerate(problem.states):
            rows.append(xf[i] - cast(float, s.fixed_final) if self.fixed_final[i] else pf[i] - dphi[i])
        if self.free_tf:
            rows.append(sysm.hamiltonian(yf, mode, P) + ca.gradient(phi, tf))
        S = ca.vertcat(*rows)
        #: ``(S, dS/dy(tf), dS/dtf)`` of the final point ``y(tf)``, ``tf``, the control's mode there and ``P``: the
        #: shooting function's terminal conditions
        self.terminal = ca.Function("S", [yf, tf, mode, P], [S, ca.jacobian(S, yf), ca.jacobian(S, tf)])
        self.counts = {"S": 0, "jac": 0, "integrations": 0}

    # -- shooting function ------------------------------------------------------------------
    def split_unknowns(self, z: ArrayLike) -> tuple[np.ndarray, float]:
        """``(unknowns at t0, tf)`` of the shooting's unknowns ``z`` (tf: the problem's where it is fixed)."""
        z = np.asarray(z, dtype=float).ravel()
        if z.size != self.nz:
            raise ValueError(
                f"z must have {self.nz} entries (per state its initial costate, or its initial value where it is "
                f"free{', then tf' if self.free_tf else ''})"
            )
        tf = z[-1] if self.free_tf else float(cast(float, self.problem.tf))
        if not tf > self.problem.t0:
            raise ValueError(f"final time {tf} must exceed t0 = {self.problem.t0}")
        return z[: self.problem.nx], tf

    def integrate(
        self,
        z: ArrayLike,
        parameters: Mapping[str, float] | ArrayLike | None = None,
        *,
        variational: bool = False,
        record: bool = False,
    ) -> Integration:
        """The trajectory from the initial state and the costates (and tf) in ``z``.

        ``parameters``: the problem's parameter vector; default, this problem's values
        (not those of the problem the shared compiled system was built from).
        """
        P = self.parameter_vector(parameters)
        unknowns, tf = self.split_unknowns(z)
        nx, sysm = self.problem.nx, self.compiled.system
        x0, p0 = self.initial_values(unknowns)
        y0 = np.concatenate([x0, p0, [0.0]])
        Psi0 = None
        if variational:
            Psi0 = np.zeros((sysm.n, nx))
            rows = np.where(self.free_initial, np.arange(nx), nx + np.arange(nx))
            Psi0[rows, np.arange(nx)] = 1.0
        self.counts["integrations"] += 1
        return self.flow(y0, self.problem.t0, tf, P, Psi0=Psi0, record=record, at=z)

    def flow(
        self,
        y0: ArrayLike,
        t0: float,
        tf: float,
        P: Mapping[str, float] | ArrayLike | None,
        *,
        Psi0: ArrayLike | None = None,
        record: bool = False,
        system: CompiledSystem | None = None,
        where: str = "",
        at: ArrayLike | None = None,
    ) -> Integration:
        """The integration of ``y = (x, p, J)`` from ``y0`` at ``t0`` to ``tf`` as this shooting integrates (its
        switching treatment, tolerances, step cap and interior check), by ``system`` (default its compiled system;
        :class:`~ocpkit.shooting.multiple.MultipleShooting` passes one with more variational columns). A failed
        integration raises a :class:`~ocpkit.SolverError` naming its status and ``where``, else the unknowns
        ``at``, else the interval (written only then: a shooting integrates thousands of times)."""
        res = (self.compiled if system is None else system).integrate(
            y0,
            t0,
            tf,
            P,
            switching=self.switching,
            rtol=self.rtol,
            atol=self.atol,
            Psi0=Psi0,
            record=record,
            max_steps=self.max_steps,
            interior_check=self.interior_check,
        )
        if res.status != "ok":
            raise SolverError(
                "Dormand-Prince integrator",
                res.status,
                res.accepted + res.rejected,
                where or _where(at, t0, tf),
                unit="steps",
                outcome=Outcome.INTEGRATION_FAILED,
            )
        return res

    def initial_values(self, unknowns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The initial state and costates from the unknowns (initial costates, or initial values of free states)."""
        x0 = np.where(self.free_initial, unknowns, self.x0)
        p0 = np.where(self.free_initial, 0.0, unknowns)
        return x0, p0

    def parameter_vector(self, parameters: Mapping[str, float] | ArrayLike | None) -> np.ndarray:
        """The problem's parameter vector, some values replaced by ``parameters`` (by name, or a whole vector)."""
        return self.problem.parameter_vector(parameters)

    def solved_free_parameters(self, x0: np.ndarray) -> dict[str, float]:
        """The free parameters by name in the initial state ``x0`` of the shooting's problem (they are states)."""
        return {v.name: float(x0[self.problem.state_index(v.name)]) for v in self.statement.free_parameters}

    def residual(
        self,
        z: ArrayLike,
        parameters: Mapping[str, float] | ArrayLike | None = None,
        integration: Integration | None = None,
    ) -> np.ndarray:
        """S(z)."""
        P = self.parameter_vector(parameters)
        res = integration if integration is not None else self.integrate(z, P)
        _, tf = self.split_unknowns(z)
        mode = self.compiled.system.mode_at(res.y, P)
        return np.asarray(self.terminal(res.y, tf, mode, P)[0]).ravel()

    def residual_and_derivatives(
        self, z: ArrayLike, P: np.ndarray, integration: Integration, variational: bool = True
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(S(z), dS/dz)`` from an integration that carried the variational columns ``Psi = dy/dz``."""
        _, tf = self.split_unknowns(z)
        sysm = self.compiled.system
        mode = sysm.mode_at(integration.y, P)
        S, dSdy, dSdtf = (np.asarray(v) for v in self.terminal(integration.y, tf, mode, P))
        J = dSdy @ cast(np.ndarray, integration.Psi)  # (integrated with the variational columns)
        if self.free_tf:
            ydot = np.asarray(sysm.flow(integration.y, mode, P)).ravel()
            J = np.hstack([J, (dSdy @ ydot + dSdtf.ravel())[:, None]])
        return S.ravel(), J

    def jacobian_matrix(
        self,
        z: ArrayLike,
        parameters: Mapping[str, float] | ArrayLike | None = None,
        method: str | Callable[..., tuple[np.ndarray, np.ndarray]] | None = None,
        S0: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(S(z), dS/dz)`` by ``method`` (a name in :data:`~ocpkit.shooting.strategies.JACOBIANS` or a
        strategy object; default: this run's).

        ``S0``: S(z) when already known, spared by the finite differences.
        """
        strategy = self._jacobian if method is None else jacobian_strategy(method)
        P = self.parameter_vector(parameters)
        z = np.asarray(z, dtype=float).ravel()
        return strategy(self, z, P, S0)

    def noise(self, z: ArrayLike, parameters: Mapping[str, float] | ArrayLike | None = None, **options: Any) -> float:
        """The level below which ``|S(z)|`` is chance (:func:`residual_noise`; ``options``: its ``samples``,
        ``relative``, ``seed``)."""
        P = self.parameter_vector(parameters)
        return residual_noise(
            lambda y: self.residual(y, P), lambda y: self.jacobian_matrix(y, P, method="variational"), z, **options
        )

    # -- solve ------------------------------------------------------------------------------------
    def solve(
        self,
        z0: ArrayLike,
        parameters: Mapping[str, float] | ArrayLike | None = None,
        *,
        solver: str | Callable[..., tuple[Any, ...]] = "hybr",
        tol: float | None = None,
        maxfev: int = 400,
        raise_on_failure: bool = True,
        record: bool = True,
        xtol: float | None = None,
        factor: float | None = None,
        stol: float | None = None,
        diagnose: bool = True,
    ) -> ShootingResult:
        """Solve S(z) = 0 from ``z0`` to ``|S| <= tol`` (default 1e-8); raise :class:`~ocpkit.SolverError` (with
        ``|S|``, counts and the :class:`~ocpkit.Outcome`) on failure.

        Converged means ``|S| <= tol`` at the returned point, whatever MINPACK's own
        status (which stops on ``xtol`` and can stall at a residual of 1e-16 or
        succeed at one of 1e-3; its success above ``tol`` is the status ``STALLED``).
        With ``raise_on_failure=False`` a non-converged run is returned with
        ``converged=False`` and its ``status`` (for tables that report failures, as the
        source does), also when the integration at the last iterate fails (then its
        ``integration`` is None, its status ``INTEGRATION_FAILED`` and ``detail`` says
        why). ``solver``: ``"hybr"`` (MINPACK with its defaults), ``"newton"`` (damped
        Newton; a Jacobian every iteration, until ``|S|`` stops decreasing below ``tol`` or
        ``maxfev`` evaluations), or a root-solver object holding its own options
        (:mod:`ocpkit.shooting.strategies`: ``MinpackHybrid(xtol=..., factor=...)``).
        ``xtol`` and ``factor`` here are deprecated (MINPACK's options, which other solvers
        ignored), and so is ``stol``, the old name of ``tol``. With the variational
        Jacobian the first notes only which switching mode places the switchings;
        with ``switching="none"`` the variational equations carry no jump terms.

        ``diagnose``: where the run stalls above ``tol``, measure why (the noise floor of S at the last iterate, 27
        integrations, and a switching function's closest approach to zero along the last flight, integrated once
        more where ``record`` is False: the result's ``noise`` and ``grazing``, and the advice in its error); False
        leaves them None, for a caller that keeps only whether the run converged (restarts from many starts).
        """
        tol = renamed_argument("stol", "tol", stol, tol, 1e-8, "Shooting.solve")
        if not tol > 0:
            raise ValueError(f"tol must be positive, got {tol}")
        if xtol is not None or factor is not None:
            if solver != "hybr":
                raise TypeError(
                    "xtol and factor are MINPACK's options, which belong to its solver object: give "
                    "solver=MinpackHybrid(xtol=..., factor=...) (another solver does not take them)"
                )
            renamed("Shooting.solve(xtol=..., factor=...)", "solver=MinpackHybrid(xtol=..., factor=...)")
            defaults = MinpackHybrid()
            solver = MinpackHybrid(
                xtol=defaults.xtol if xtol is None else xtol, factor=defaults.factor if factor is None else factor
            )
        method = solver_strategy(solver)
        P = self.parameter_vector(parameters)
        z0 = np.asarray(z0, dtype=float).ravel()
        if z0.size != self.nz:
            raise ValueError(f"z0 must have {self.nz} entries, got {z0.size}")
        self.counts = {"S": 0, "jac": 0, "integrations": 0}
        # the solvers ask for S and J at the same points more than once (scipy checks the shapes at z0,
        # Newton evaluates S where it took J): each is computed once per point; counts are the requests
        last_S: dict[bytes, np.ndarray] = {}
        last_J: dict[bytes, np.ndarray] = {}

        def fun(z: np.ndarray) -> np.ndarray:
            self.counts["S"] += 1
            key = z.tobytes()
            if key not in last_S:
                try:
                    S = self.residual(z, P)
                except (SolverError, ValueError):
                    # an iterate outside the domain (tf <= t0, an integration that fails): a large
                    # residual makes MINPACK's trust region shrink back towards the last good point
                    return np.full(self.nz, 1e10)
                if not np.all(np.isfinite(S)):
                    return np.full(self.nz, 1e10)
                last_S.clear()
                last_S[key] = S
            return last_S[key]

        def jac(z: np.ndarray) -> np.ndarray:
            self.counts["jac"] += 1
            key = z.tobytes()
            if key not in last_J:
                try:
                    S, J = self.jacobian_matrix(z, P, S0=last_S.get(key))
                except ValueError as exc:  # an iterate outside the domain (tf <= t0), as fun reports it
                    raise SolverError(
                        "shooting",
                        f"the Jacobian at an iterate outside the domain: {exc}",
                        self.counts["S"],
                        unit="shooting-function evaluations",
                        outcome=Outcome.INTEGRATION_FAILED,
                    ) from exc
                if not np.all(np.isfinite(J)):
                    raise SolverError(
                        "shooting",
                        "the Jacobian is not finite (a grazing switching?)",
                        self.counts["S"],
                        unit="shooting-function evaluations",
                        outcome=Outcome.SINGULAR_JACOBIAN,
                    )
                last_S.clear()
                last_S[key] = S
                last_J.clear()
                last_J[key] = J
            return last_J[key]

        t = time.process_time()
        claimed: Outcome | None
        try:
            z, message, claimed = run_solver(method, fun, jac, z0, tol=tol, maxfev=maxfev)
        except SolverError as exc:
            if raise_on_failure:
                raise
            z, message, claimed = z0, str(exc), exc.outcome or Outcome.SOLVER_FAILED
        cpu = time.process_time() - t
        counts = dict(self.counts)
        try:
            final = self.integrate(z, P, record=record)
            S = self.residual(z, P, final)
        except (SolverError, ValueError, RuntimeError) as exc:  # the one failure policy: raise, or report it
            if raise_on_failure:
                raise
            final, S = None, np.full(self.nz, np.nan)
            message = f"{message}; the integration at the last iterate failed: {exc}"
            claimed = Outcome.INTEGRATION_FAILED
        norm = float(np.linalg.norm(S))
        ok, status = settled(norm, tol, claimed)
        noise, grazing, advice = None, None, ""
        if diagnose and status is Outcome.STALLED and np.isfinite(norm):  # the integrator's noise, or not: said
            noise = noise_floor(lambda y: self.residual(y, P), z)
            if norm > 10.0 * noise and final is not None:  # not the noise: a grazing switching, or not
                try:
                    flight = final if record else self.integrate(z, P, record=True)
                    grazing = closest_approach(ShootingTrajectory(flight, self.compiled.system))
                except (SolverError, ValueError, RuntimeError, ArithmeticError):  # (a history cut at its capacity)
                    grazing = None  # not measured: the failure is reported as it is
            advice = stall_advice(norm, tol, noise, grazing)
        if final is None:  # the last iterate may lie outside the domain (tf <= t0): reported as it is
            unknowns, tf = z[: self.problem.nx], (z[-1] if self.free_tf else float(cast(float, self.problem.tf)))
        else:
            unknowns, tf = self.split_unknowns(z)
        x0, p0 = self.initial_values(unknowns)
        result = ShootingResult(
            z=z,
            p0=p0,
            tf=tf,
            residual=S,
            norm=norm,
            tol=tol,
            converged=ok,
            status=status,
            detail=message,
            evaluations=counts["S"],
            iterations=counts["jac"],
            n_integrations=counts["integrations"],
            cpu_s=cpu,
            objective=self.objective_of(final, tf, P) if final is not None else float("nan"),
            switching=self.switching,
            jacobian=self.jacobian,
            parameters=P,
            integration=final,
            system=self.compiled.system,
            free_parameters=self.solved_free_parameters(x0),
            noise=noise,
            grazing=grazing,
        )
        if not ok and raise_on_failure:
            name = {"hybr": "MINPACK hybrid", "newton": "damped Newton"}.get(
                getattr(method, "name", ""), type(method).__name__
            )
            raise SolverError(
                f"shooting ({name})",
                message,
                counts["S"],
                f"|S| = {norm:.3e} > tol = {tol:g} after {counts['S']} shooting-function and "
                f"{counts['jac']} Jacobian evaluations{'; ' + advice if advice else ''}; the last iterate is the "
                "error's .result, solve(raise_on_failure=False) returns it",
                unit="shooting-function evaluations",
                result=result,
                outcome=status,
            )
        return result

    def objective_of(self, res: Integration, tf: float, P: np.ndarray) -> float:
        """Running cost (integrated along the trajectory) plus the Mayer term."""
        nx = self.problem.nx
        J = float(res.y[2 * nx])
        if self.problem.phi is not None:
            J += float(self.problem.phi(self.x0, res.y[:nx], self.problem.t0, tf, P))  # independent of free x0
        return J
