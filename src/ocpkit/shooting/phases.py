"""Multiple shooting of a multi-phase boundary value problem over each phase's arcs: the maximum principle of a
:class:`~ocpkit.MultiPhaseProblem` (each phase its own dynamics, running cost, bounds and constraints; links,
linkage constraints and a cost of the trajectory at the phases' ends).

Each phase ``k`` is shot over its arcs as one problem is (:class:`~ocpkit.shooting.arcs.ArcShooting` with
``phase=True``: its flows, junctions, entries and jumps, its times inputs). What joins the phases is the endpoint
function of the whole trajectory (Bryson & Ho, *Applied Optimal Control*, sec. 3.7, interior-point constraints;
Betts, *Practical Methods*, sec. 4.11, multi-phase problems),

    l = sum_k Phi_k(x0_k, xf_k, t0_k, tf_k) + J_trajectory(e) + nu' psi(e),

``e`` every phase's ``(x0, xf, t0, tf)`` and ``psi`` every equality at the ends: each phase's boundary equalities,
each link ``x_after(t0) - x_before(tf) - jump`` (and ``t0_after - tf_before`` where the times are free), each
linkage constraint. A phase's fixed initial and final states are held, as in one phase; every other end value
has its transversality condition,

    p_k(t0_k) = -dl/dx0_k,    p_k(tf_k) = dl/dxf_k,    H_k(t0_k) = dl/dt0_k,    H_k(tf_k) = -dl/dtf_k,

so that across a link with nothing else at its ends the costate is continuous (both equal the link's multiplier),
an interior point whose state is fixed lets it jump by what that condition needs, and where the link's time is
free the Hamiltonian is continuous. Equalities that the fixed values already satisfy (a link between two phases
that both fix the state there) are dropped; ones they violate are named. The unknowns are every phase's (its free
initial states, initial costates, junctions, jumps, implicit controls), each free phase time, and ``nu``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, cast

import casadi as ca
import numpy as np

from ..trajectory import Trajectory
from .arcs import ArcResult, ArcShooting, ArcTrajectory, ArcType, block, newton
from .result import IndirectResult

if TYPE_CHECKING:
    from ..statement import OptimalControlProblem
    from ..statement.phases import MultiPhaseProblem


@dataclass(kw_only=True)
class PhasedArcResult(IndirectResult):
    """A multi-phase arc-shooting run: the fields every indirect run has (``objective`` the whole trajectory's
    cost), the endpoint multipliers ``multipliers`` (:attr:`PhasedArcShooting.psi_labels` names them), and each
    phase's run as an :class:`~ocpkit.shooting.arcs.ArcResult` (``phases``, by name; its ``objective`` the phase's
    own cost, its ``norm`` the whole system's)."""

    multipliers: np.ndarray
    #: what each of ``multipliers`` belongs to (:attr:`PhasedArcShooting.psi_labels`: ``"link burn -> coast: r"``)
    labels: list[str] = field(default_factory=list)
    phases: dict[str, ArcResult] = field(default_factory=dict)

    @property
    def trajectory(self) -> Trajectory:
        """The phases' extremals as one trajectory where they make one (:class:`PhasedTrajectory`)."""
        if not self.phases:
            raise ValueError(f"this run has no trajectory: {self.status}: {self.detail}")
        out = PhasedTrajectory({name: run.trajectory for name, run in self.phases.items()})
        out.objective = float(self.objective)
        return out


class PhasedArcShooting:
    """Multiple shooting of the multi-phase problem ``problem`` over each phase's arcs (``arcs[k]`` as
    :func:`~ocpkit.shooting.arcs.arc_sequence` gives them for phase ``k``); module docstring.

    Attributes
    ----------
    phases : list[ArcShooting]
        Each phase's shooting (``phase=True``), in the problem's order.
    layout : list[tuple[str, int]]
        The unknowns block by block: each phase's blocks prefixed with its name (``"burn.p0"``), its free times
        (``"burn.t0"``, ``"burn.tf"``), then ``nu``.
    psi_labels : list[str]
        What each endpoint equality is, in the order of ``nu``.
    ends : casadi.SX
        The symbols of every phase's ``[x0, xf, t0, tf, P]``, in the phases' order (``e``; the layout of
        :meth:`~ocpkit.MultiPhaseProblem.ends_layout`).
    psi : casadi.SX
        The endpoint equalities ``psi(e)`` kept (those the fixed end values do not settle).
    mayer, trajectory_cost : casadi.SX
        Every phase's Mayer term with the trajectory's cost, and the trajectory's cost alone, in ``e``.
    """

    def __init__(
        self,
        problem: MultiPhaseProblem,
        arcs: Sequence[Sequence[tuple[ArcType, float, float]]],
        *,
        rtol: float = 1e-12,
        atol: float = 1e-12,
    ) -> None:
        if len(arcs) != len(problem):
            raise ValueError(f"one arc sequence per phase: {len(problem)} phases, {len(arcs)} sequences")
        self.problem = problem
        self.names = list(problem.names)
        self.phases = []
        for name, pr, seq in zip(self.names, problem.problems, arcs):
            try:
                self.phases.append(ArcShooting(pr, seq, rtol=rtol, atol=atol, phase=True))
            except ValueError as exc:
                raise ValueError(f"phase {name!r}: {exc}") from exc
        self._build()

    # -- the shooting function ---------------------------------------------------------------------------------
    def _build(self) -> None:
        problem, phases = self.problem, self.phases
        layout: list[tuple[str, int]] = []
        for name, sh, pr in zip(self.names, phases, problem.problems):
            layout += [(f"{name}.{label}", n) for label, n in sh.layout]
            layout += [
                (f"{name}.{end}", 1) for end, free in (("t0", pr.free_initial_time), ("tf", pr.free_final_time)) if free
            ]
        self.P = np.concatenate([np.asarray(pr.full_parameters, dtype=float).ravel() for pr in problem.problems])
        psi, labels = self._endpoint_equalities()
        self.psi_labels = labels
        layout.append(("nu", len(labels)))
        self.layout = layout
        nz = sum(n for _, n in layout)
        z = ca.MX.sym("z", nz)
        parts: dict[str, ca.MX] = {}
        offset = 0
        for name, n in layout:
            parts[name] = z[offset : offset + n] if n else ca.MX(0, 1)
            offset += n
        # every phase's interior, at its times
        E, nu = self.ends, ca.SX.sym("nu", len(labels))
        ell = self.mayer + (ca.dot(nu, psi) if labels else 0)
        G = ca.Function("endpoint", [E, nu], [ca.gradient(ell, E), psi])
        out: list[dict[str, ca.MX]] = []
        ends: list[ca.MX] = []
        p_offset = 0
        times: list[ca.MX] = []
        for name, sh, pr in zip(self.names, phases, problem.problems):
            P = ca.MX(self.P[p_offset : p_offset + sh.flows.P.numel()])
            p_offset += sh.flows.P.numel()
            t0 = parts[f"{name}.t0"] if pr.free_initial_time else ca.MX(float(pr.t0))
            tf = parts[f"{name}.tf"] if pr.free_final_time else ca.MX(float(cast(float, pr.tf)))
            zk = ca.vertcat(*[parts[f"{name}.{label}"] for label, n in sh.layout if n]) if sh.nz else ca.MX(0, 1)
            res = sh.interior(z=zk, P=P, t0=t0, tf=tf)
            res["t0"], res["tf"], res["P"] = t0, tf, P
            if pr.phi is not None:  # the phase's own share of the cost, as a direct phase reports it
                res["cost"] = res["cost"] + pr.phi(res["x0"], res["xf"], t0, tf, P)
            out.append(res)
            ends.append(ca.vertcat(res["x0"], res["xf"], t0, tf, P))
            times.append(ca.vertcat(t0, *[parts[f"{name}.t{j}"] for j in range(1, len(sh.kinds))], tf))
        grad, psi_v = G(ca.vertcat(*ends), parts["nu"])
        rows: list[ca.MX] = []
        offset = 0
        for sh, pr, res, end in zip(phases, problem.problems, out, ends):
            nx = pr.nx
            g = grad[offset : offset + end.numel()]
            offset += end.numel()
            g0, gf, gt0, gtf = g[:nx], g[nx : 2 * nx], g[2 * nx], g[2 * nx + 1]
            rows.append(res["rows"])
            for i, s in enumerate(pr.states):
                rows.append(res["xf"][i] - cast(float, s.fixed_final) if s.final is not None else res["pf"][i] - gf[i])
                if sh.free_initial[i]:
                    rows.append(res["p0"][i] + g0[i])
            if pr.free_initial_time:
                rows.append(res["H0"] - gt0)
            if pr.free_final_time:
                rows.append(res["Hf"] + gtf)
        rows.append(psi_v)
        S = ca.vertcat(*rows)
        if S.numel() < nz:
            raise ValueError(
                f"the phases' arcs give {S.numel()} conditions for {nz} unknowns: a structure the derived junction "
                "conditions do not close; keep the direct solution"
            )
        trajectory_cost = ca.Function("trajectory_cost", [E], [self.trajectory_cost])
        objective = trajectory_cost(ca.vertcat(*ends)) + sum(res["cost"] for res in out)
        self.S = ca.Function("S", [z], [S])
        self.SJ = ca.Function("SJ", [z], [S, ca.jacobian(S, z)])
        self._phase_out = ca.Function("phases", [z], [v for res, t in zip(out, times) for v in (t, res["cost"])])
        self._phase_times = ca.Function("phase_times", [z], times)
        self.objective = ca.Function("objective", [z], [objective])
        self.nz = nz

    def _endpoint_equalities(self) -> tuple[ca.SX, list[str]]:
        """``psi(e)`` (module docstring) and its rows' labels; stores ``e`` (:attr:`ends`), :attr:`mayer`,
        :attr:`trajectory_cost` and :attr:`psi`.
        Rows constant at the fixed end values (fixed states and times, the parameters) are dropped, or named where
        they do not vanish."""
        problem = self.problem
        E = ca.SX.sym("e", sum(2 * pr.nx + 2 + _npar(pr) for pr in problem.problems))
        pieces: list[tuple[ca.SX, ca.SX, ca.SX, ca.SX, ca.SX]] = []
        fixed: dict[int, float] = {}
        offset = 0
        for pr in problem.problems:
            nx, npar = pr.nx, _npar(pr)
            x0, xf = E[offset : offset + nx], E[offset + nx : offset + 2 * nx]
            t0, tf, P = E[offset + 2 * nx], E[offset + 2 * nx + 1], E[offset + 2 * nx + 2 : offset + 2 * nx + 2 + npar]
            pieces.append((x0, xf, t0, tf, P))
            for i, s in enumerate(pr.states):
                if s.fixed_initial is not None:
                    fixed[offset + i] = float(s.fixed_initial)
                if s.fixed_final is not None:
                    fixed[offset + nx + i] = float(s.fixed_final)
            if not pr.free_initial_time:
                fixed[offset + 2 * nx] = float(pr.t0)
            if not pr.free_final_time:
                fixed[offset + 2 * nx + 1] = float(cast(float, pr.tf))
            for j, v in enumerate(np.asarray(pr.full_parameters, dtype=float).ravel()):
                fixed[offset + 2 * nx + 2 + j] = float(v)
            offset += 2 * nx + 2 + npar
        mayer = ca.SX(0)
        rows: list[ca.SX] = []
        labels: list[str] = []
        for name, pr, (x0, xf, t0, tf, P) in zip(problem.names, problem.problems, pieces):
            if pr.phi is not None:
                mayer += pr.phi(x0, xf, t0, tf, P)
            bc = pr.functions.boundary
            if bc is None:
                continue
            if np.any(bc.lower != bc.upper):
                raise ValueError(f"phase {name!r}: arc shooting takes boundary equalities only, not inequalities")
            rows.append(bc.function(x0, xf, t0, tf, P) - ca.DM(bc.lower))
            labels += [f"{name}: {label}" for label in bc.labels]
        for link in problem.links:
            before, after = pieces[link.before], pieces[link.after]
            a, b = problem.names[link.before], problem.names[link.after]
            for ib, ia, state, jump in link.states:
                rows.append(after[0][ia] - before[1][ib] - jump)
                labels.append(f"link {a} -> {b}: {state}")
            if link.time == "constraint":
                rows.append(after[2] - before[3])
                labels.append(f"link {a} -> {b}: time")
        trajectory_cost = problem.cost(E) if problem.cost is not None else ca.SX(0)
        mayer += trajectory_cost
        if problem.linkage is not None:
            linkage = problem.linkage
            if np.any(linkage.lower != linkage.upper):
                raise ValueError(
                    f"the linkage constraints {linkage.labels} include inequalities: the multi-phase arc shooting "
                    "takes equalities only"
                )
            rows.append(linkage.function(E, ca.SX(0, 1)) - ca.DM(linkage.lower))
            labels += [f"linkage: {label}" for label in linkage.labels]
        psi = ca.vertcat(*rows) if rows else ca.SX(0, 1)
        keep = self._informative(psi, labels, E, fixed)
        self.ends, self.mayer, self.trajectory_cost = E, mayer, trajectory_cost
        self.psi = ca.vertcat(*[psi[i] for i in keep]) if keep else ca.SX(0, 1)
        return self.psi, [labels[i] for i in keep]

    @staticmethod
    def _informative(psi: ca.SX, labels: list[str], E: ca.SX, fixed: dict[int, float]) -> list[int]:
        """The rows of ``psi`` that depend on an unknown end value; a row the fixed values violate is named."""
        if psi.numel() == 0:
            return []
        idx = sorted(fixed)
        at = ca.substitute(psi, ca.vertcat(*[E[i] for i in idx]), ca.DM([fixed[i] for i in idx]))
        rows, cols = ca.jacobian(psi, E).sparsity().get_triplet()
        keep = []
        for r in range(psi.numel()):
            if ca.depends_on(at[r], E):
                keep.append(r)
                continue
            value = float(ca.evalf(at[r]))
            size = max((abs(fixed[c]) for r_, c in zip(rows, cols) if r_ == r and c in fixed), default=0.0)
            if abs(value) > 1e-9 * (1.0 + size):
                raise ValueError(f"{labels[r]}: the fixed values at the phases' ends violate it by {value:.3g}")
        return keep

    # -- the guess ---------------------------------------------------------------------------------------------
    def guess(self, trajectories: Sequence[Trajectory]) -> np.ndarray:
        """The unknowns from each phase's trajectory with costates (a direct solution's phases): each phase's
        (:meth:`ArcShooting.guess <ocpkit.shooting.arcs.ArcShooting.guess>`), its free times, and ``nu`` by least
        squares on the transversality conditions at the direct solution's ends."""
        blocks: list[np.ndarray] = []
        ends: list[np.ndarray] = []
        costates: list[tuple[np.ndarray, np.ndarray, float, float]] = []
        for sh, pr, tr in zip(self.phases, self.problem.problems, trajectories):
            blocks.append(sh.guess(tr))
            blocks.append(np.array([tr.t0] if pr.free_initial_time else []))
            blocks.append(np.array([tr.tf] if pr.free_final_time else []))
            x = tr.state(np.array([tr.t0, tr.tf]))
            lam = tr.costate(np.array([tr.t0, tr.tf]))
            P = np.asarray(pr.full_parameters, dtype=float).ravel()
            ends.append(np.concatenate([x[0], x[1], [tr.t0, tr.tf], P]))
            H = self._hamiltonians(sh, tr, P)
            costates.append((lam[0], lam[1], *H))
        blocks.append(self._multiplier_guess(np.concatenate(ends), costates))
        return np.concatenate([np.ravel(b) for b in blocks]).astype(float)

    @staticmethod
    def _hamiltonians(sh: ArcShooting, tr: Trajectory, P: np.ndarray) -> tuple[float, float]:
        """H at a trajectory's two ends, from its states, costates and controls."""
        ham = sh.problem.functions.hamiltonian
        H = ca.Function("H", [ham.x, ham.p, ham.u, ham.t, ham.P], [ham.H])
        t = np.array([tr.t0, tr.tf])
        X, L, U = tr.state(t), tr.costate(t), tr.control(t)
        start, end = (float(H(X[i], L[i], U[i], t[i], P)) for i in range(2))
        return start, end

    def _multiplier_guess(
        self, e: np.ndarray, costates: list[tuple[np.ndarray, np.ndarray, float, float]]
    ) -> np.ndarray:
        """``nu`` from the transversality rows of the free end values, linear in it: ``A' nu = b``."""
        n = len(self.psi_labels)
        if n == 0:
            return np.zeros(0)
        E = self.ends
        grad_mayer = ca.Function("gm", [E], [ca.gradient(self.mayer, E)])
        A = np.asarray(ca.Function("A", [E], [ca.jacobian(self.psi, E)])(e))
        g = np.asarray(grad_mayer(e)).ravel()
        rows: list[np.ndarray] = []
        rhs: list[float] = []
        offset = 0
        for sh, pr, (p0, pf, H0, Hf) in zip(self.phases, self.problem.problems, costates):
            nx = pr.nx
            for i, s in enumerate(pr.states):
                if s.final is None:  # pf = dl/dxf
                    rows.append(A[:, offset + nx + i])
                    rhs.append(pf[i] - g[offset + nx + i])
                if sh.free_initial[i]:  # p0 = -dl/dx0
                    rows.append(A[:, offset + i])
                    rhs.append(-p0[i] - g[offset + i])
            if pr.free_initial_time:  # H0 = dl/dt0
                rows.append(A[:, offset + 2 * nx])
                rhs.append(H0 - g[offset + 2 * nx])
            if pr.free_final_time:  # Hf = -dl/dtf
                rows.append(A[:, offset + 2 * nx + 1])
                rhs.append(-Hf - g[offset + 2 * nx + 1])
            offset += 2 * nx + 2 + _npar(pr)
        if not rows:
            return np.zeros(n)
        return np.linalg.lstsq(np.vstack(rows), np.asarray(rhs), rcond=None)[0]

    # -- solve ---------------------------------------------------------------------------------------------------
    def solve(
        self, z0: np.ndarray, *, tol: float = 1e-10, max_iterations: int = 50, raise_on_failure: bool = True
    ) -> PhasedArcResult:
        """Newton's method on ``S(z) = 0`` from ``z0`` (:func:`~ocpkit.shooting.arcs.newton`; each phase's times
        kept in order). A failure raises a :class:`~ocpkit.SolverError` naming it, the last iterate's result
        attached (``raise_on_failure=False``: returns it)."""
        z = np.asarray(z0, dtype=float).copy()
        if z.size != self.nz:
            raise ValueError(f"z0 must have {self.nz} entries (layout {self.layout})")
        start = time.process_time()
        run = newton(lambda z: self.S(z), lambda z: self.SJ(z), self._ordered, z, tol, max_iterations)
        z, norm = run.z, run.norm
        try:
            objective = float(np.asarray(self.objective(z)).ravel()[0])
        except RuntimeError:  # the arcs cannot be integrated from the last iterate
            objective = float("nan")
        result = PhasedArcResult(
            **run.fields(tol, time.process_time() - start),
            objective=objective,
            multipliers=self._part(z, "nu"),
            labels=list(self.psi_labels),
        )
        if np.isfinite(norm) and np.isfinite(objective) and self._ordered(z):
            try:
                result.phases = self._phase_results(result)
            except RuntimeError:  # the arcs cannot be integrated densely from the last iterate: no trajectory
                result.phases = {}
        if raise_on_failure:
            run.raise_unless_converged("multi-phase arc shooting", result, tol)
        return result

    def _ordered(self, z: np.ndarray) -> bool:
        """Whether every phase's arcs keep their order (its start, junctions, end increasing)."""
        return all(np.all(np.diff(np.asarray(t).ravel()) > 0) for t in self._phase_times(z))

    def _phase_results(self, whole: PhasedArcResult) -> dict[str, ArcResult]:
        """Each phase's run as an :class:`ArcResult` with its trajectory (:class:`ArcTrajectory`)."""
        out = self._phase_out(whole.z)
        # the whole run's fields: one system, one residual, one Newton iteration count
        shared = {f.name: getattr(whole, f.name) for f in fields(IndirectResult) if f.name not in ("z", "objective")}
        results: dict[str, ArcResult] = {}
        p_offset = 0
        for k, (name, sh) in enumerate(zip(self.names, self.phases)):
            times = np.asarray(out[2 * k]).ravel()
            cost = float(np.asarray(out[2 * k + 1]).ravel()[0])
            zk = np.concatenate(
                [self._part(whole.z, f"{name}.{label}") for label, n in sh.layout if n] or [np.zeros(0)]
            )
            P = self.P[p_offset : p_offset + sh.flows.P.numel()]
            p_offset += sh.flows.P.numel()
            run = ArcResult(
                **{**shared, "z": zk},
                objective=cost,
                times=times,
                multipliers=np.zeros(0),
                arcs=list(sh.kinds),
                jumps=[(float(times[j]), c, float(sh._part(zk, f"jump{j}")[0])) for j, c in sh.jumps.items()],
            )
            run._trajectory = ArcTrajectory(sh, zk, P, times, cost)
            results[name] = run
        return results

    def _part(self, z: np.ndarray, name: str) -> np.ndarray:
        return block(self.layout, z, name)


def phase_name(names: Sequence[str], key: str | int) -> str:
    """The name of the phase ``key`` (a name or an index) among ``names``; a KeyError names the phases."""
    if isinstance(key, str) and key in names:
        return key
    if isinstance(key, (int, np.integer)) and not isinstance(key, bool) and -len(names) <= key < len(names):
        return names[int(key)]
    raise KeyError(f"unknown phase {key!r}; the phases are {list(names)} (or indices 0 to {len(names) - 1})")


def _npar(problem: OptimalControlProblem) -> int:
    """The length of a phase's parameter vector (its ends' ``P``)."""
    return int(np.asarray(problem.full_parameters, dtype=float).size)


class PhasedTrajectory(Trajectory):
    """The phases' extremals (``phases``: name -> :class:`~ocpkit.Trajectory`, in time order) as one trajectory
    where they make one: every phase with the first's states and controls, each starting where the one before
    ends. It is then evaluated in the phase a time falls in (the later one at a link); otherwise every field that is
    a phase's raises, naming :meth:`phase`, as a multi-phase :class:`~ocpkit.Solution` does."""

    def __init__(self, phases: dict[str, Trajectory]) -> None:
        self.phases = dict(phases)
        parts = list(self.phases.values())
        self.t0, self.tf = float(parts[0].t0), float(parts[-1].tf)
        self.objective = float("nan")
        first = parts[0].problem
        self.joined = all(
            (p.problem.state_names, p.problem.control_names) == (first.state_names, first.control_names) for p in parts
        ) and all(abs(b.t0 - a.tf) <= 1e-12 * (1.0 + abs(a.tf)) for a, b in zip(parts[:-1], parts[1:]))
        self.breakpoints = np.unique(np.concatenate([np.asarray(p.breakpoints, dtype=float) for p in parts]))
        self._starts = np.array([p.t0 for p in parts])

    def phase(self, key: str | int) -> Trajectory:
        """A phase's extremal by name or index."""
        return self.phases[phase_name(list(self.phases), key)]

    def _only(self, what: str) -> list[Trajectory]:
        if not self.joined:
            raise AttributeError(
                f"the {len(self.phases)} phases {list(self.phases)} do not make one trajectory (other states or "
                f"controls, or a gap in time): ask phase(name).{what}"
            )
        return list(self.phases.values())

    @property
    # a property where Trajectory declares an attribute: the phases' problem is read, never set
    def problem(self) -> OptimalControlProblem:  # type: ignore[override]
        """The first phase's problem, whose states and controls every phase has (where the phases make one)."""
        return self._only("problem")[0].problem

    @property
    def has_costates(self) -> bool:
        return all(p.has_costates for p in self.phases.values())

    def _dispatch(self, t: np.ndarray, what: str) -> np.ndarray:
        parts = self._only(what)
        flat = np.asarray(t, dtype=float).ravel()
        which = np.clip(np.searchsorted(self._starts, flat, side="right") - 1, 0, len(parts) - 1)
        out: np.ndarray | None = None
        for k in np.unique(which):
            sel = which == k
            part = parts[int(k)]
            values = getattr(part, what)(np.clip(flat[sel], part.t0, part.tf))
            if out is None:
                out = np.empty((flat.size, values.shape[-1]))
            out[sel] = values
        assert out is not None
        return out.reshape(np.shape(t) + (out.shape[-1],))

    def _state(self, t: np.ndarray) -> np.ndarray:
        return self._dispatch(t, "state")

    def _control(self, t: np.ndarray) -> np.ndarray:
        return self._dispatch(t, "control")

    def _costate(self, t: np.ndarray) -> np.ndarray:
        return self._dispatch(t, "costate")


__all__ = ["PhasedArcResult", "PhasedArcShooting", "PhasedTrajectory", "phase_name"]
