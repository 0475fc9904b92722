"""Simple shooting for the boundary-value problem of Pontryagin's principle.

Unknowns ``z = p(t0)`` (and ``tf`` when it is free); the state starts at the
problem's fixed initial state. The shooting function collects, at ``tf``:

* ``x_i(tf) - x_i^f`` for every state with a fixed final value;
* ``p_i(tf) - d phi / d x_i(tf)`` for every free final state (transversality);
* ``H(tf) + d phi / d tf`` when ``tf`` is free (H is constant along an autonomous flow).

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
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
from scipy.optimize import root

from ..errors import SolverError
from ..problem import FreeFinalTime, OptimalControlProblem
from .compiled import DETECTION_MODES, CompiledSystem, Integration
from .hamiltonian import ControlLaw, HamiltonianSystem

JACOBIANS = ("fd", "variational")
SOLVERS = ("hybr", "newton")


@dataclass
class ShootingResult:
    """A shooting run: unknowns, residual, effort and the final trajectory's statistics."""

    z: np.ndarray
    p0: np.ndarray
    tf: float
    residual: np.ndarray
    norm: float
    converged: bool
    message: str
    n_shooting: int
    n_jacobian: int
    n_integrations: int
    cpu_s: float
    objective: float
    detection: str
    jacobian: str
    parameters: np.ndarray
    trajectory: Integration = field(repr=False)

    def summary(self) -> dict:
        tr = self.trajectory
        return {
            "detection": self.detection, "jacobian": self.jacobian, "objective": self.objective,
            "norm_S": self.norm, "converged": self.converged, "n_S": self.n_shooting, "n_jac": self.n_jacobian,
            "integrations": self.n_integrations, "cpu_s": self.cpu_s, "switchings": tr.switchings,
            "accepted": tr.accepted, "rejected": tr.rejected, "steps": tr.steps,
            "rejected_pct": 100 * tr.rejected_ratio, "hamiltonian_drift": tr.hamiltonian_drift,
        }


class Shooting:
    """Shooting for ``problem`` with a control law (see :func:`ocpkit.shooting.control_law`).

    Parameters
    ----------
    problem : OptimalControlProblem
        Autonomous, every initial state fixed, final states fixed or free.
    law : ControlLaw
    detection : ``"none" | "detection" | "correction"``
    jacobian : ``"fd" | "variational"``
    rtol, atol : integrator tolerances.
    interior_check : bool
        Also detect a pair of switchings inside one integration step (a short arc); see
        :meth:`CompiledSystem.integrate`. Off: the sign test at the step's ends only.
    fd_step : float, optional
        Relative step of the finite-difference Jacobian; default ``sqrt(rtol)`` without
        switching detection and ``sqrt(eps)`` with it (see the module docstring).
    system : CompiledSystem, optional
        Reuse an already compiled system for the same problem and law.
    """

    def __init__(self, problem: OptimalControlProblem, law: ControlLaw, *, detection: str = "correction",
                 jacobian: str = "variational", rtol: float = 1e-8, atol: float = 1e-8,
                 system: CompiledSystem | None = None, max_steps: int = 2_000_000, interior_check: bool = True,
                 fd_step: float | None = None):
        if detection not in DETECTION_MODES:
            raise ValueError(f"detection must be one of {DETECTION_MODES}, got {detection!r}")
        if jacobian not in JACOBIANS:
            raise ValueError(f"jacobian must be one of {JACOBIANS}, got {jacobian!r}")
        if not (rtol > 0 and atol > 0):
            raise ValueError(f"tolerances must be positive, got rtol={rtol}, atol={atol}")
        self.problem, self.law = problem, law
        self.detection, self.jacobian = detection, jacobian
        self.rtol, self.atol, self.max_steps = rtol, atol, max_steps
        self.interior_check = bool(interior_check)
        noise = max(rtol, np.finfo(float).eps) if detection == "none" else np.finfo(float).eps
        self.fd_step = float(np.sqrt(noise)) if fd_step is None else float(fd_step)
        if not (self.fd_step > 0 and np.isfinite(self.fd_step)):
            raise ValueError(f"fd_step must be positive, got {fd_step!r}")
        nx = problem.nx
        x0 = []
        for s in problem.states:
            if s.initial is None or isinstance(s.initial, (tuple, list)):
                raise ValueError(f"shooting needs a fixed initial value for state {s.name!r}")
            x0.append(float(s.initial))
        self.x0 = np.array(x0)
        self.fixed_final = []
        for i, s in enumerate(problem.states):
            if isinstance(s.final, (tuple, list)):
                raise ValueError(f"shooting supports fixed or free final states, not the interval of {s.name!r}")
            self.fixed_final.append(s.final is not None)
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
        xf, pf = yf[:nx], yf[nx:2 * nx]
        phi = problem.mayer_p(ca.DM(self.x0), xf, problem.t0, tf, P) if problem.mayer_p is not None else ca.SX(0)
        dphi = ca.gradient(phi, xf)
        rows = []
        for i, s in enumerate(problem.states):
            rows.append(xf[i] - float(s.final) if self.fixed_final[i] else pf[i] - dphi[i])
        if self.free_tf:
            rows.append(sysm.hamiltonian(yf, mode, P) + ca.gradient(phi, tf))
        S = ca.vertcat(*rows)
        self._S = ca.Function("S", [yf, tf, mode, P], [S, ca.jacobian(S, yf), ca.jacobian(S, tf)])
        self.counts = {"S": 0, "jac": 0, "integrations": 0}

    # -- shooting function ------------------------------------------------------------------
    def _split(self, z):
        z = np.asarray(z, dtype=float).ravel()
        if z.size != self.nz:
            raise ValueError(f"z must have {self.nz} entries (initial costates{' and tf' if self.free_tf else ''})")
        tf = z[-1] if self.free_tf else float(self.problem.tf)
        if not tf > self.problem.t0:
            raise ValueError(f"final time {tf} must exceed t0 = {self.problem.t0}")
        return z[:self.problem.nx], tf

    def integrate(self, z, parameters=None, *, variational: bool = False, record: bool = False) -> Integration:
        """The trajectory from the initial state and the costates (and tf) in ``z``.

        ``parameters``: the problem's parameter vector; default, this problem's values
        (not those of the problem the shared compiled system was built from).
        """
        P = self._params(parameters)
        p0, tf = self._split(z)
        nx, sysm = self.problem.nx, self.compiled.system
        y0 = np.concatenate([self.x0, p0, [0.0]])
        Psi0 = None
        if variational:
            Psi0 = np.zeros((sysm.n, nx))
            Psi0[nx:2 * nx] = np.eye(nx)
        self.counts["integrations"] += 1
        res = self.compiled.integrate(y0, self.problem.t0, tf, P, detection=self.detection,
                                      rtol=self.rtol, atol=self.atol, Psi0=Psi0, record=record,
                                      max_steps=self.max_steps, interior_check=self.interior_check)
        if res.status != "ok":
            raise SolverError("Dormand-Prince integrator", res.status, res.accepted + res.rejected,
                              f"at z = {np.array2string(np.asarray(z), precision=6)}", unit="steps")
        return res

    def _params(self, parameters):
        P = self.problem.parameter_values if parameters is None else np.array(parameters, dtype=float)
        if P.shape != (len(self.problem.parameters),):
            raise ValueError(f"expected {len(self.problem.parameters)} parameters {list(self.problem.parameters)}, "
                             f"got {P.shape}")
        return P

    def residual(self, z, parameters=None, integration: Integration | None = None) -> np.ndarray:
        """S(z)."""
        P = self._params(parameters)
        res = integration if integration is not None else self.integrate(z, P)
        _, tf = self._split(z)
        mode = self.compiled.system.mode_at(res.y, P)
        return np.asarray(self._S(res.y, tf, mode, P)[0]).ravel()

    def jacobian_matrix(self, z, parameters=None, method: str | None = None,
                        S0: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(S(z), dS/dz)`` by ``method`` (default: this run's): variational, forward or central differences.

        ``S0``: S(z) when already known, spared by the finite differences.
        """
        method = method or self.jacobian
        P = self._params(parameters)
        z = np.asarray(z, dtype=float).ravel()
        if method == "variational":
            res = self.integrate(z, P, variational=True)
            _, tf = self._split(z)
            sysm = self.compiled.system
            mode = sysm.mode_at(res.y, P)
            S, dSdy, dSdtf = (np.asarray(v) for v in self._S(res.y, tf, mode, P))
            J = dSdy @ res.Psi
            if self.free_tf:
                ydot = np.asarray(sysm.flow(res.y, mode, P)).ravel()
                J = np.hstack([J, (dSdy @ ydot + dSdtf.ravel())[:, None]])
            return S.ravel(), J
        S0 = self.residual(z, P) if S0 is None else np.asarray(S0, dtype=float)
        J = np.empty((S0.size, z.size))
        for j in range(z.size):
            h = self.fd_step * max(abs(z[j]), 1.0)
            zp = z.copy()
            zp[j] += h
            if method == "fd":
                J[:, j] = (self.residual(zp, P) - S0) / h
            elif method == "central":
                zm = z.copy()
                zm[j] -= h
                J[:, j] = (self.residual(zp, P) - self.residual(zm, P)) / (2 * h)
            else:
                raise ValueError(f"unknown Jacobian method {method!r}")
        return S0, J

    # -- solve ------------------------------------------------------------------------------------
    def solve(self, z0, parameters=None, *, solver: str = "hybr", stol: float = 1e-8, xtol: float = 1e-14,
              maxfev: int = 400, factor: float = 100.0, raise_on_failure: bool = True,
              record: bool = True) -> ShootingResult:
        """Solve S(z) = 0 from ``z0``; raise :class:`~ocpkit.SolverError` (with |S| and counts) on failure.

        Converged means ``|S| <= stol`` at the returned point, whatever MINPACK's own
        status (which stops on ``xtol`` and can stall at a residual of 1e-16 or
        succeed at one of 1e-3). With ``raise_on_failure=False`` a non-converged run
        is returned with ``converged=False`` (for tables that report failures, as the
        source does). ``solver``: ``"hybr"`` (MINPACK; ``factor`` is its initial
        trust-region bound ``factor * |diag * z0|``, ``xtol`` its step tolerance) or
        ``"newton"`` (damped Newton; a Jacobian every iteration, until |S| stops
        decreasing below ``stol`` or ``maxfev`` evaluations). With the variational
        Jacobian the first notes only which detection mode places the switchings;
        with ``detection="none"`` the variational equations carry no jump terms.
        """
        if not stol > 0:
            raise ValueError(f"stol must be positive, got {stol}")
        if solver not in SOLVERS:
            raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
        P = self._params(parameters)
        z0 = np.asarray(z0, dtype=float).ravel()
        if z0.size != self.nz:
            raise ValueError(f"z0 must have {self.nz} entries, got {z0.size}")
        self.counts = {"S": 0, "jac": 0, "integrations": 0}
        # the solvers ask for S and J at the same points more than once (scipy checks the shapes at z0,
        # Newton evaluates S where it took J): each is computed once per point; counts are the requests
        last_S, last_J = {}, {}

        def fun(z):
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

        def jac(z):
            self.counts["jac"] += 1
            key = z.tobytes()
            if key not in last_J:
                S, J = self.jacobian_matrix(z, P, S0=last_S.get(key))
                if not np.all(np.isfinite(J)):
                    raise SolverError("shooting", "the Jacobian is not finite (a grazing switching?)",
                                      self.counts["S"], unit="shooting-function evaluations")
                last_S.clear()
                last_S[key] = S
                last_J.clear()
                last_J[key] = J
            return last_J[key]

        t = time.process_time()
        try:
            if solver == "hybr":
                sol = root(fun, z0, jac=jac, method="hybr", options={"xtol": xtol, "maxfev": maxfev, "factor": factor})
                z, message = sol.x, " ".join(sol.message.split())
            else:
                z, message = self._newton(z0, fun, jac, stol, maxfev)
        except SolverError as exc:
            if raise_on_failure:
                raise
            z, message = z0, str(exc)
        cpu = time.process_time() - t
        counts = dict(self.counts)
        final = self.integrate(z, P, record=record)
        S = self.residual(z, P, final)
        norm = float(np.linalg.norm(S))
        ok = bool(np.isfinite(norm) and norm <= stol)
        if not ok and raise_on_failure:
            name = "MINPACK hybrid" if solver == "hybr" else "damped Newton"
            raise SolverError(f"shooting ({name})", message, counts["S"],
                              f"|S| = {norm:.3e} > stol = {stol:g} after {counts['S']} shooting-function and "
                              f"{counts['jac']} Jacobian evaluations", unit="shooting-function evaluations")
        p0, tf = self._split(z)
        return ShootingResult(
            z=z, p0=p0, tf=tf, residual=S, norm=norm, converged=ok, message=message,
            n_shooting=counts["S"], n_jacobian=counts["jac"], n_integrations=counts["integrations"],
            cpu_s=cpu, objective=self._objective(final, tf, P), detection=self.detection,
            jacobian=self.jacobian, parameters=P, trajectory=final,
        )

    @staticmethod
    def _newton(z0, fun, jac, stol: float, maxfev: int):
        """Damped Newton: least-squares Newton step, halved until |S|^2 decreases (Armijo, c = 1e-4).

        Stops at the first |S| <= 1e-15, when no step length down to 2^-14 decreases |S|
        (the integrator's noise floor, or a failure far from a solution), when |S| is
        below ``stol`` and the last step gained less than a factor 10, or after
        ``maxfev`` shooting-function evaluations. Returns the best point seen.
        """
        z = np.asarray(z0, dtype=float)
        J = jac(z)
        S = fun(z)
        best = (np.linalg.norm(S), z)
        evaluations = 1
        message = "maximum number of evaluations reached"
        while evaluations < maxfev:
            norm = np.linalg.norm(S)
            if norm <= 1e-15:
                message = "residual at machine precision"
                break
            try:
                step = np.linalg.lstsq(J, -S, rcond=None)[0]
            except np.linalg.LinAlgError:
                message = "the Newton step could not be computed"
                break
            a, accepted = 1.0, False
            while a >= 2.0 ** -14 and evaluations < maxfev:
                trial = z + a * step
                St = fun(trial)
                evaluations += 1
                if np.linalg.norm(St) ** 2 <= (1 - 1e-4 * a) * norm**2:
                    accepted = True
                    break
                a *= 0.5
            if not accepted:
                message = "no step length decreases |S| (noise floor or stagnation)"
                break
            z = trial
            J = jac(z)
            S = fun(z)
            new = np.linalg.norm(S)
            if new < best[0]:
                best = (new, z)
            if new <= stol and new > 0.1 * norm:
                message = "converged: |S| below stol and no longer decreasing quadratically"
                break
        return best[1], message

    def _objective(self, res: Integration, tf: float, P) -> float:
        """Running cost (integrated along the trajectory) plus the Mayer term."""
        nx = self.problem.nx
        J = float(res.y[2 * nx])
        if self.problem.mayer_p is not None:
            J += float(self.problem.mayer_p(self.x0, res.y[:nx], self.problem.t0, tf, P))
        return J


def homotopy(regularized: Shooting, lambdas, z0, *, parameter: str = "lam", final: Shooting | None = None,
             **solve_options) -> list[ShootingResult]:
    """Continuation on a cost parameter: solve for each value of ``lambdas`` in turn, each warm-starting the next.

    ``regularized`` solves the problems with ``parameter`` in ``lambdas``; ``final``
    (typically the bang-bang law at the end value) solves once more from the last
    solution. Returns every solve's result; a solve that fails raises :class:`~ocpkit.SolverError`.
    """
    problem = regularized.problem
    if parameter not in problem.parameters:
        raise KeyError(f"{problem.name!r} has no parameter {parameter!r}; it has {sorted(problem.parameters)}")
    solve_options = {**solve_options, "raise_on_failure": True}
    names = list(problem.parameters)
    results, z = [], np.asarray(z0, dtype=float)
    P = problem.parameter_values.copy()
    for lam in lambdas:
        P[names.index(parameter)] = lam
        results.append(regularized.solve(z, P.copy(), **solve_options))
        z = results[-1].z
    if final is not None:
        Pf = final.problem.parameter_values.copy()
        results.append(final.solve(z, Pf, **solve_options))
    return results
