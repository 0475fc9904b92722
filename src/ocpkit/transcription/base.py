"""What every direct transcription shares: build once, solve, package the solution."""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Self, cast

import casadi as ca
import numpy as np

from ..accuracy import (
    control_switches,
    path_junctions,
    path_violations,
    periodic_control_hint,
    refinement_hint,
    warn_if_inaccurate,
    warn_if_path_violated,
)
from ..errors import SolverError
from ..nlp import DEFAULT_IPOPT_OPTIONS, Block, NLPResult, SeparableNLP, failure_hint
from ..solution import Solution
from ..statement import AffineScaling, Guess, OptimalControlProblem, State, Variable
from . import session
from .mesh import GlobalVariables, Mesh
from .session import STALL_FALL, STALL_GROWTH, STALL_MESHES, MeshIteration  # noqa: F401 (their home before)

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def settle(result: NLPResult, package: Callable[[NLPResult], Any], raise_on_failure: bool) -> Any:
    """The solution of an IPOPT result (``package(result)``), or :class:`SolverError` naming the status.

    A failed solve raises, with the last iterate attached, unless ``raise_on_failure`` is False
    (then the last iterate is returned, ``converged=False``); a non-finite iterate always raises.
    """
    solution = package(result) if np.all(np.isfinite(result.w)) else None
    if result.success:
        return solution
    if raise_on_failure or solution is None:
        detail = failure_hint(result.status) if solution is not None else "the last iterate is not finite"
        raise SolverError("IPOPT", result.status, result.iterations, detail, result=solution)
    return solution


def node_bounds(states: Sequence[State], n_nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Scaled bounds (n_nodes, len(states)) of states on a node set, with the boundary conditions at both ends."""
    sc = AffineScaling.of(states)
    lo = np.tile([s.lower for s in states], (n_nodes, 1)).reshape(n_nodes, len(states))
    hi = np.tile([s.upper for s in states], (n_nodes, 1)).reshape(n_nodes, len(states))
    lo[0], hi[0] = np.array([s.boundary_interval("initial") for s in states]).reshape(len(states), 2).T
    lf, hf = np.array([s.boundary_interval("final") for s in states]).reshape(len(states), 2).T
    lo[-1], hi[-1] = np.maximum(lo[-1], lf), np.minimum(hi[-1], hf)
    return sc.to_nlp(lo), sc.to_nlp(hi)


def point_bounds(controls: Sequence[Variable], n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Scaled bounds (n_points, len(controls)) of controls at their parameter points."""
    sc = AffineScaling.of(controls)
    lo = np.tile([c.lower for c in controls], (n_points, 1)).reshape(n_points, len(controls))
    hi = np.tile([c.upper for c in controls], (n_points, 1)).reshape(n_points, len(controls))
    return sc.to_nlp(lo), sc.to_nlp(hi)


@dataclass
class PathPoints:
    """Where a scheme holds states and controls, for its path constraints: ``count`` instances of ``k`` points.

    ``z`` and ``p`` are the symbols of one instance (its NLP variables and constants, the
    layout of ``variables`` (nz, count) and ``constants`` (np, count)); ``x``, ``u`` and
    ``t`` are lists of ``k`` expressions in them (state, control, time at each point);
    ``fractions`` (count, k) the normalised times (0..1) of the points.
    """

    z: ca.SX
    p: ca.SX
    x: list
    u: list
    t: list
    variables: np.ndarray
    constants: np.ndarray
    fractions: np.ndarray

    @property
    def count(self) -> int:
        return self.variables.shape[1]

    @property
    def k(self) -> int:
        return len(self.x)


@dataclass(frozen=True)
class VariableGroup:
    """A run of NLP variables: the values of ``variables`` at ``points`` points, point by point.

    State groups carry the boundary conditions at their first and last point.
    """

    name: str
    variables: tuple[Variable, ...]
    points: int

    @property
    def size(self) -> int:
        return self.points * len(self.variables)

    @property
    def is_state(self) -> bool:
        return bool(self.variables) and isinstance(self.variables[0], State)

    @property
    def scaling(self) -> AffineScaling:
        return AffineScaling.of(self.variables)


class Transcription(session.SolveSession[Solution], ABC):
    """A direct transcription of an :class:`~ocpkit.problem.OptimalControlProblem` into an NLP.

    Subclasses define the variable layout, the blocks and the interpolants;
    this class times the build, runs IPOPT and returns a :class:`~ocpkit.Solution`.
    """

    #: IPOPT options this scheme prefers over :data:`ocpkit.nlp.DEFAULT_IPOPT_OPTIONS` (user options win).
    ipopt_defaults: dict[str, Any] = {}

    #: Whether the NLP's Jacobian and Hessian blocks are compiled to C (``ocpkit._compiled_blocks``), ``"auto"``
    #: (where one evaluation is large, the compilation is repaid and a C compiler is found), True or False; set it on
    #: the object before its NLP is built (the meshes of a refinement from it keep it).
    compile: str | bool = "auto"

    def __init__(self, problem: OptimalControlProblem) -> None:
        if not isinstance(problem, OptimalControlProblem):
            raise TypeError(f"expected an OptimalControlProblem, got {type(problem).__name__}")
        self.problem = problem
        self._nlp: SeparableNLP | None = None
        self._solvers: dict[tuple[Any, ...], ca.Function] = {}
        self._nlp_build_s = 0.0
        self._solver_build_s = 0.0

    # -- to be provided by each scheme ------------------------------------------------
    @property
    @abstractmethod
    def label(self) -> str:
        """Short description, e.g. ``HLGL(intervals=20)``."""

    @abstractmethod
    def _groups(self) -> list[VariableGroup]:
        """The NLP variables in layout order (a free final time follows them)."""

    @property
    @abstractmethod
    def n_defects(self) -> int: ...

    @abstractmethod
    def _blocks(self) -> list[Block]: ...

    @abstractmethod
    def _initial_point(
        self,
        tf: float,
        states: Callable[[ArrayLike], np.ndarray],
        controls: Callable[[ArrayLike], np.ndarray],
        t0: float | None = None,
    ) -> np.ndarray:
        """Scaled NLP vector sampled from guess functions of time (``t0``: a free initial time's, default the
        problem's)."""

    @abstractmethod
    def _package(self, result: NLPResult) -> dict[str, Any]:
        """Solution fields (times, values, interpolants, breakpoints) from the NLP result."""

    def _path_points(self) -> list[PathPoints]:
        """The points where path constraints are enforced (schemes that support them override this)."""
        raise NotImplementedError(f"{type(self).__name__} does not enforce path constraints")

    # -- layout: sizes, indices, bounds, packing -------------------------------------------
    @property
    def global_variables(self) -> GlobalVariables:
        """The problem-wide NLP variables (pinned and free parameters, then t0 and tf where free), last in ``w``."""
        return GlobalVariables(self.problem)

    @property
    def n_variables(self) -> int:
        return sum(g.size for g in self._groups()) + self.global_variables.size

    def global_indices(self) -> np.ndarray:
        """NLP indices of the problem-wide variables (:attr:`global_variables`), last in ``w``."""
        k = self.global_variables.size
        return np.arange(self.n_variables - k, self.n_variables, dtype=np.int64)

    def _global_rows(self, count: int) -> list[np.ndarray]:
        """The problem-wide variables as index-table rows for ``count`` instances (an empty list without any)."""
        g = self.global_indices()
        return [np.tile(g[:, None], (1, count))] if g.size else []

    def time_indices(self) -> tuple[int | None, int | None]:
        """NLP indices of t0 and tf (None where fixed)."""
        g, layout = self.global_indices(), self.global_variables
        indices = tuple(None if k is None else int(g[k]) for k in (layout.t0_position, layout.tf_position))
        return cast("tuple[int | None, int | None]", indices)

    def global_values(self, w: ArrayLike) -> dict[str, Any]:
        """``{"pinned": {name: value}, "parameters": {name: value}, "t0": ..., "tf": ...}`` of a scaled NLP vector
        (``pinned``: the problem's parameters as solved with; ``parameters``: the free ones)."""
        w = np.asarray(w, dtype=float).ravel()
        if w.size != self.n_variables:
            raise ValueError(
                f"an NLP vector of {w.size} entries for {self.label}, which has {self.n_variables}: a refined "
                "solution's vector belongs to its last mesh, solution.raw['transcription']"
            )
        return self.global_variables.unpack(w[self.global_indices()])

    def parameter_values(self, parameters: Mapping[str, float] | None = None) -> np.ndarray:
        """The values the problem's parameters are pinned to in a solve: the problem's, with ``parameters``
        (a mapping of some names to values) replacing some; each name checked."""
        return self.problem.parameter_vector(parameters) if parameters is not None else self.problem.parameter_vector()

    def _index_tables(self) -> tuple[list[np.ndarray], int | None]:
        """Global NLP indices of each group, shaped (variables, points), and of tf (None if fixed)."""
        tables: list[np.ndarray] = []
        offset = 0
        for g in self._groups():
            tables.append(offset + np.arange(g.size).reshape(g.points, len(g.variables)).T)
            offset += g.size
        return tables, self.time_indices()[1]

    def _bounds(self, parameters: Mapping[str, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Scaled bounds of the NLP variables; state groups carry the boundary conditions, the problem's parameters
        are pinned to their values (``parameters``: some replaced)."""
        return self._stack_bounds(
            [
                node_bounds(cast("Sequence[State]", g.variables), g.points)
                if g.is_state
                else point_bounds(g.variables, g.points)
                for g in self._groups()
            ],
            parameters,
        )

    def pack(
        self,
        *values: ArrayLike | None,
        tf: float | None = None,
        t0: float | None = None,
        parameters: Mapping[str, float] | None = None,
    ) -> np.ndarray:
        """Scaled NLP vector from physical values, one (points, variables) array per group, and tf
        (free parameters and a free t0: ``parameters`` and ``t0``, default their guesses)."""
        groups = self._groups()
        if len(values) == len(groups) + 1 and tf is None:
            *values, tf = values  # type: ignore[assignment]  # tf given after the arrays, a number
        if len(values) != len(groups):
            raise ValueError(f"expected {len(groups)} arrays ({', '.join(g.name for g in groups)}), got {len(values)}")
        parts = []
        for g, v in zip(groups, values):
            v = np.asarray(v, dtype=float)
            if v.shape != (g.points, len(g.variables)):
                raise ValueError(f"{g.name} have shape {v.shape}, expected ({g.points}, {len(g.variables)})")
            parts.append(g.scaling.to_nlp(v).ravel() if g.variables else np.zeros(0))
        pr = self.problem
        given = dict(parameters or {})
        pinned = self.parameter_values({k: v for k, v in given.items() if k in pr.parameters})
        free = {k: v for k, v in given.items() if k not in pr.parameters}
        parts.append(self.global_variables.pack(pinned, free, t0, tf))
        return np.concatenate(parts)

    def unpack(self, w: ArrayLike) -> tuple[Any, ...]:
        """Physical values, one (points, variables) array per group, then tf, from a scaled NLP vector."""
        w = np.asarray(w, dtype=float).ravel()
        if w.size != self.n_variables:
            raise ValueError(f"NLP vector has {w.size} entries, expected {self.n_variables}")
        out: list[Any] = []
        offset = 0
        for g in self._groups():
            z = w[offset : offset + g.size].reshape(g.points, len(g.variables))
            out.append(g.scaling.from_nlp(z) if g.variables else z)
            offset += g.size
        out.append(self.global_variables.unpack(w[self.global_indices()])["tf"])
        return tuple(out)

    # -- helpers for subclasses ------------------------------------------------------------
    def _times(self, tf: float, s: ArrayLike, t0: float | None = None) -> np.ndarray:
        """Physical times of normalised times ``s`` in [0, 1]."""
        return Mesh.times(self.problem, tf, s, t0)

    def _result_problem(
        self, result: NLPResult, g: dict[str, Any] | None = None
    ) -> tuple[OptimalControlProblem, float, float]:
        """The problem of a result: with the parameter values it was solved with (sharing the functions) and the
        free parameters fixed at their solved values; and ``(t0, tf)`` (``g``: its :meth:`global_values`, if at
        hand)."""
        g = self.global_values(result.w) if g is None else g
        pr = self.problem
        if g["pinned"] != pr.parameters:
            pr = pr.replace(parameters=g["pinned"])
        if pr.free_parameters:
            pr = pr.fix_parameters(g["parameters"])
        return pr, g["t0"], g["tf"]

    # -- what a solve loop (ocpkit.transcription.loop) asks of a mesh ------------------------------------------
    def _parameter_slots(self) -> dict[str, np.ndarray]:
        """Per problem parameter, the NLP indices its value is pinned at (by both bounds, unscaled)."""
        g = self.global_indices()
        return {name: g[k : k + 1] for k, name in enumerate(self.problem.parameters)}

    def _parameter_defaults(self) -> dict[str, float]:
        return {name: float(value) for name, value in self.problem.parameters.items()}

    def _objective_scale(self) -> float:
        return float(self.problem.objective_scale)

    def _time_span(self, w: ArrayLike) -> tuple[float, float]:
        """``(t0, tf)`` of a scaled NLP vector."""
        values = self.global_values(w)
        return values["t0"], values["tf"]

    def _stack_bounds(
        self, parts: Sequence[tuple[np.ndarray, np.ndarray]], parameters: Mapping[str, float] | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Concatenate ``(lower, upper)`` arrays in layout order and append the problem-wide variables' bounds
        (the parameters pinned to :meth:`parameter_values`)."""
        lb = [np.ravel(lo) for lo, _ in parts]
        ub = [np.ravel(hi) for _, hi in parts]
        lo, hi = self.global_variables.bounds(self.parameter_values(parameters))
        return np.concatenate([*lb, lo]), np.concatenate([*ub, hi])

    def _mayer_block(self, first: np.ndarray, last: np.ndarray, tf_index: int | None) -> Block:
        """The Mayer term phi(x(t0), x(tf), t0, tf) on the NLP variables ``first`` and ``last`` (problem order)."""
        pr = self.problem
        z, p, x0, xf, t0, tf, P = self._boundary_symbols()
        phi = pr.mayer(x0, xf, t0, tf, P)
        var = np.concatenate([first, last, self.global_indices()])
        par = np.array(self.global_variables.constants, dtype=float).reshape(-1, 1)
        return Block("mayer", ca.Function("mayer", [z, p], [phi / pr.objective_scale]), var[:, None], par)

    # -- path and boundary constraints (rows after the defects) -------------------------------
    @property
    def n_path_points(self) -> int:
        """Points at which the path constraints hold (0 without path constraints)."""
        if self.problem.functions.path is None:
            return 0
        return sum(pp.count * pp.k for pp in self._path_points_cached())

    def _path_points_cached(self) -> list[PathPoints]:
        if getattr(self, "_path_points_list", None) is None:
            self._path_points_list = self._path_points()
        return self._path_points_list

    @property
    def n_path_constraints(self) -> int:
        c = self.problem.functions.path
        return 0 if c is None else self.n_path_points * c.size

    @property
    def n_boundary_constraints(self) -> int:
        c = self.problem.functions.boundary
        return 0 if c is None else c.size

    def path_point_fractions(self) -> np.ndarray:
        """Normalised times (0..1) of the path-constraint points, in constraint-row order."""
        if self.problem.functions.path is None:
            return np.zeros(0)
        return np.concatenate([pp.fractions.ravel() for pp in self._path_points_cached()])

    def _constraint_blocks(self) -> list[Block]:
        """Path constraints ``g / scale`` at every point of :meth:`_path_points`, then the boundary constraints."""
        pr = self.problem
        blocks: list[Block] = []
        row = self.n_defects
        path = pr.functions.path
        if path is not None:
            scale = ca.DM(path.scale)
            for j, pp in enumerate(self._path_points_cached()):
                P = self.global_variables.P(pp.z)
                out = ca.vertcat(*[pr.path(x, u, t, P) / scale for x, u, t in zip(pp.x, pp.u, pp.t)])
                per = out.shape[0]
                rows = row + np.arange(per * pp.count).reshape(pp.count, per).T
                fun = ca.Function(f"path_{j}", [pp.z, pp.p], [out])
                blocks.append(Block(f"path_constraints_{j}", fun, pp.variables, pp.constants, rows))
                row += per * pp.count
        boundary = pr.functions.boundary
        if boundary is not None:
            first, last, _ = self._boundary_indices()
            z, q, x0, xf, t0, tf, P = self._boundary_symbols()
            out = pr.boundary(x0, xf, t0, tf, P) / ca.DM(boundary.scale)
            var = np.concatenate([first, last, self.global_indices()])
            par = np.array(self.global_variables.constants, dtype=float).reshape(-1, 1)
            rows = row + np.arange(boundary.size)[:, None]
            blocks.append(
                Block("boundary_constraints", ca.Function("boundary", [z, q], [out]), var[:, None], par, rows)
            )
        return blocks

    def _boundary_symbols(self) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX, Any, Any, Any]:
        """Symbols ``z = [x(t0), x(tf), problem-wide variables]`` (scaled) and ``p = [(tf)]``, and in them the
        physical ``x0, xf, t0, tf`` and the parameter vector ``P``."""
        pr = self.problem
        nx = pr.nx
        layout = self.global_variables
        z = ca.SX.sym("z", 2 * nx + layout.size)
        q = ca.SX.sym("p", len(layout.constants))
        xs = pr.state_scaling
        x0, xf = xs.from_nlp(z[:nx]), xs.from_nlp(z[nx : 2 * nx])
        return z, q, x0, xf, layout.t0(z), layout.tf(z, q, 0), layout.P(z)

    def _boundary_indices(self) -> tuple[np.ndarray, np.ndarray, int | None]:
        """NLP indices of ``x(t0)`` and ``x(tf)`` (problem order) and of tf (None if fixed)."""
        tables, tfi = self._index_tables()
        X = tables[0]
        return X[:, 0], X[:, -1], tfi

    def _constraint_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        pr = self.problem
        lo, hi = [np.zeros(self.n_defects)], [np.zeros(self.n_defects)]
        path = pr.functions.path
        if path is not None:
            lo.append(np.tile(path.lower / path.scale, self.n_path_points))
            hi.append(np.tile(path.upper / path.scale, self.n_path_points))
        boundary = pr.functions.boundary
        if boundary is not None:
            lo.append(boundary.lower / boundary.scale)
            hi.append(boundary.upper / boundary.scale)
        return np.concatenate(lo), np.concatenate(hi)

    @property
    def n_constraints(self) -> int:
        return self.n_defects + self.n_path_constraints + self.n_boundary_constraints

    def _constraint_fields(self, result: NLPResult, tf: float, g: np.ndarray | None = None) -> dict[str, Any]:
        """Values and multipliers of the path and boundary constraints, in the problem's units.

        The multiplier of a constraint row is IPOPT's, converted from the scaled NLP
        (``objective_scale / scale``): positive where the upper bound is active, negative
        where the lower one is, zero where the constraint is inactive.
        """
        pr = self.problem
        out = {}
        if g is None and (pr.functions.path is not None or pr.functions.boundary is not None):
            g = np.asarray(self.nlp.constraint_function(result.w)).ravel()
        values = cast(np.ndarray, g)  # (evaluated above where there are constraints to read)
        lam = np.asarray(result.lam_g, dtype=float).ravel()
        row = self.n_defects
        path = pr.functions.path
        if path is not None:
            n, m = self.n_path_points, path.size
            sl = slice(row, row + n * m)
            order = np.argsort(self.path_point_fractions(), kind="stable")
            out["path_times"] = self._times(tf, self.path_point_fractions()[order])
            out["path_values"] = (values[sl].reshape(n, m) * path.scale)[order]
            out["path_multipliers"] = (lam[sl].reshape(n, m) * pr.objective_scale / path.scale)[order]
            row += n * m
        boundary = pr.functions.boundary
        if boundary is not None:
            sl = slice(row, row + boundary.size)
            out["boundary_values"] = values[sl] * boundary.scale
            out["boundary_multipliers"] = lam[sl] * pr.objective_scale / boundary.scale
        return out

    # -- shared machinery ---------------------------------------------------------------
    def build(self) -> Self:
        """Build the NLP (idempotent); the wall time is kept in ``build_s``."""
        if self._nlp is None:
            t = time.perf_counter()
            blocks = self._blocks() + self._constraint_blocks()
            self._nlp = SeparableNLP(self.n_variables, self.n_constraints, blocks, compile=self.compile)
            self._nlp_build_s = time.perf_counter() - t
        return self

    @property
    def build_s(self) -> float:
        """Wall time to build the NLP and create the IPOPT solver, in seconds."""
        return self._nlp_build_s + self._solver_build_s

    @property
    def nlp(self) -> SeparableNLP:
        """The transcription's NLP (:class:`~ocpkit.nlp.SeparableNLP`), built on first access (:meth:`build`)."""
        return cast(SeparableNLP, self.build()._nlp)  # (built)

    def effective_ipopt_options(self, ipopt_options: dict[str, Any] | None = None) -> dict[str, Any]:
        """The IPOPT options a solve with these overrides runs with: ocpkit's defaults
        (:data:`~ocpkit.nlp.DEFAULT_IPOPT_OPTIONS`), then this transcription's (``ipopt_defaults``: the ordering its
        structure asks for), then the overrides. A warm start adds :data:`~ocpkit.nlp.WARM_START` before the
        overrides (its options touch the barrier, not the linear solver)."""
        return {**DEFAULT_IPOPT_OPTIONS, **self.ipopt_defaults, **(ipopt_options or {})}

    def solver(self, ipopt_options: dict[str, Any] | None = None) -> ca.Function:
        """The IPOPT instance for these option overrides: created once per set of options, then reused."""
        key = tuple(sorted((ipopt_options or {}).items()))
        if key not in self._solvers:
            self.build()
            t = time.perf_counter()
            self._solvers[key] = self.nlp.solver(self.effective_ipopt_options(ipopt_options))
            self._solver_build_s = time.perf_counter() - t
        return self._solvers[key]

    def initial_point(self, guess: Guess | Solution | None = None) -> np.ndarray:
        """Scaled NLP start vector from a :class:`~ocpkit.Guess`, a :class:`~ocpkit.Solution` or the defaults."""
        xs: Callable[[ArrayLike], np.ndarray]
        us: Callable[[ArrayLike], np.ndarray]
        if guess is None:
            guess = Guess()
        if isinstance(guess, Solution):
            same = (guess.problem.state_names, guess.problem.control_names) == (
                self.problem.state_names,
                self.problem.control_names,
            )
            if not same:
                raise ValueError("a Solution used as guess must have the same states and controls")
            tf, xs, us = guess.tf, guess.state, guess.control
            t0 = guess.t0 if self.problem.free_initial_time else None
        elif isinstance(guess, Guess):
            tf, xs, us = guess.functions(self.problem)
            t0 = None
        else:
            raise TypeError(f"guess must be a Guess or a Solution, got {type(guess).__name__}")
        w0 = np.asarray(self._initial_point(tf, xs, us, t0), dtype=float)
        if w0.shape != (self.n_variables,):
            raise ValueError(f"initial point has shape {w0.shape}, expected ({self.n_variables},)")
        if self.problem.free_parameters:
            if isinstance(guess, Solution):
                values = {
                    v.name: guess.problem.parameters.get(v.name, v.guess_value) for v in self.problem.free_parameters
                }
            else:
                values = guess.parameter_values(self.problem)
            layout = self.global_variables
            w0[self.global_indices()[layout.free_positions]] = layout.free_to_nlp(values)
        lb, ub = self._bounds()
        return np.clip(w0, lb, ub)

    def nlp_bounds(
        self, parameters: Mapping[str, float] | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(lbw, ubw, lbg, ubg)``: the bounds of the scaled NLP variables and constraints, for solving
        :attr:`nlp` with another NLP solver (then :meth:`package` its result)."""
        return (*self._bounds(parameters), *self._constraint_bounds())

    def package(self, result: NLPResult, raise_on_failure: bool = True) -> Solution:
        """The :class:`~ocpkit.Solution` of an NLP result from any solver (a failed one raises
        :class:`~ocpkit.SolverError` naming its status, unless ``raise_on_failure`` is False)."""
        return settle(result, self._solution, raise_on_failure)

    def _solve_once(
        self,
        guess: Any,
        ipopt_options: dict[str, Any] | None,
        allow_acceptable: bool,
        raise_on_failure: bool,
        parameters: Mapping[str, float] | None = None,
        estimate_multipliers: bool = False,
    ) -> Solution:
        """One IPOPT solve (:func:`ocpkit.transcription.session.solve_once`)."""
        return session.solve_once(
            self, guess, ipopt_options, allow_acceptable, raise_on_failure, parameters, estimate_multipliers
        )

    # -- mesh refinement --------------------------------------------------------------------
    def refine(
        self, errors: np.ndarray, tolerance: float, switches: Sequence[np.ndarray | Sequence[float]] | None = None
    ) -> Transcription:
        """A transcription of the same problem on a mesh refined where ``errors`` (per interval) exceed ``tolerance``;
        ``switches``: per interval, where the control switches inside it (:func:`ocpkit.accuracy.control_switches`)."""
        raise NotImplementedError(f"{type(self).__name__} does not refine its mesh")

    # -- what the solve session (ocpkit.transcription.session) asks of a mesh ----------------------------------------
    def _mesh_fractions(self, solution: Solution) -> np.ndarray:
        """The solution's estimate intervals as fractions of its time span (a refinement's history)."""
        return np.diff(solution.estimate_intervals) / (solution.tf - solution.t0)

    def _path_where(self, solution: Solution) -> np.ndarray:
        """Per estimate interval, ``(index of its worst path constraint, its violation)`` (:func:`path_violations`)."""
        return path_violations(solution, solution.estimate_intervals)[2]

    def _cuts(self, solution: Solution) -> list[np.ndarray]:
        """Per estimate interval, where the next mesh cuts it: control switches and path-constraint junctions."""
        switches = control_switches(solution, solution.estimate_intervals)
        junctions = path_junctions(solution, solution.estimate_intervals)
        return [np.union1d(a, b) for a, b in zip(switches, junctions)]

    def _refinement_hint(self, solution: Solution) -> str:
        return refinement_hint(solution)

    def _warn_if_inaccurate(
        self, solution: Solution, threshold: float, label: str | None = None, stacklevel: int = 5
    ) -> None:
        """The single solve's warnings: the state estimate over ``threshold``, path constraints violated between
        points by more than it (``label``: who says so, default :attr:`label`; ``stacklevel``: the caller of
        ``solve()``, counted from the warning, through the session)."""
        label = self.label if label is None else label
        warn_if_inaccurate(
            label,
            solution.interval_errors,
            solution.estimate_intervals,
            threshold,
            lambda: periodic_control_hint(solution),
            stacklevel=stacklevel,
        )
        warn_if_path_violated(label, solution, threshold, stacklevel=stacklevel)

    def _check_parameters(self, parameters: Mapping[str, float]) -> None:
        self.parameter_values(parameters)

    @property
    def n_decision_variables(self) -> int:
        """The NLP's free variables (the paper's "NLP parameters"), all but the pinned problem parameters."""
        return self.n_variables - len(self.problem.parameters)

    @property
    def n_collocation_points(self) -> int:
        """Points at which the dynamics hold (the measure of a mesh's size in the refinement literature)."""
        return self.n_defects // max(self.problem.nx, 1)

    def _solution(self, result: NLPResult, g: np.ndarray | None = None) -> Solution:
        """The :class:`Solution` of an NLP result (``g``: its constraint values, when already evaluated).

        With free parameters, the solution's problem has them fixed at their solved values
        (:meth:`~ocpkit.OptimalControlProblem.fix_parameters`), so that everything done with
        the solution (interpolation, re-integration) uses them.
        """
        fields = self._package(result)
        fields.update(self._constraint_fields(result, fields["tf"], g))
        values = self.global_values(result.w)
        problem, _, _ = self._result_problem(result, values)
        fields["parameters"] = values["parameters"]
        return Solution(
            problem=problem,
            transcription=self.label,
            status=result.status,
            iterations=result.iterations,
            objective=result.objective * self.problem.objective_scale,
            decision_variables=self.n_decision_variables,
            defect_equations=self.n_defects,
            constraints=self.n_constraints,
            build_s=self.build_s,
            solve_s=result.solve_s,
            raw={
                "w": result.w,
                "lam_g": result.lam_g,
                "lam_w": result.lam_w,
                "stats": result.stats,
                "transcription": self,
            },
            converged=result.success,
            **fields,
        )
