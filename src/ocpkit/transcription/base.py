"""What every direct transcription shares: build once, solve, package the solution."""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..nlp import Block, NLPResult, SeparableNLP, solve_nlp
from ..problem import AffineScaling, Guess, OptimalControlProblem, State
from ..solution import Solution


def mesh_fractions(segments: int | None, mesh) -> np.ndarray:
    """Segment lengths as fractions of [t0, tf] from a count or explicit fractions."""
    if mesh is not None:
        frac = np.asarray(mesh, dtype=float).ravel()
        if frac.size < 1 or np.any(~np.isfinite(frac)) or np.any(frac <= 0):
            raise ValueError("mesh fractions must be positive and finite")
        if segments is not None and segments != frac.size:
            raise ValueError(f"segments={segments} disagrees with a mesh of {frac.size} fractions")
        return frac / frac.sum()
    if segments is None:
        raise ValueError("give the number of segments or the mesh fractions")
    if isinstance(segments, bool) or not isinstance(segments, (int, np.integer)):
        raise TypeError(f"segments must be an integer, got {segments!r}")
    if segments < 1:
        raise ValueError(f"segments must be at least 1, got {segments}")
    return np.full(int(segments), 1.0 / segments)


def segment_starts(fractions: np.ndarray) -> np.ndarray:
    """Normalised start times (0..1) of segments with lengths ``fractions``."""
    return np.concatenate([[0.0], np.cumsum(fractions)[:-1]])


def segment_point_fractions(starts: np.ndarray, fractions: np.ndarray, local) -> np.ndarray:
    """Normalised times (0..1) of points at ``local`` positions in [0, 1) of every segment, then the end (1).

    Points are ordered segment by segment, as in the NLP layouts: consecutive
    segments share their boundary point, so ``local`` excludes 1.
    """
    local = np.asarray(local, dtype=float)
    s = (starts[:, None] + fractions[:, None] * local[None, :]).ravel()
    return np.concatenate([s, [1.0]])


def node_bounds(states, n_nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Scaled bounds (n_nodes, len(states)) of states on a node set, with the boundary conditions at both ends."""
    lb = np.empty((n_nodes, len(states)))
    ub = np.empty((n_nodes, len(states)))
    for j, s in enumerate(states):
        def nlp(v, s=s):
            return (v - s.shift) / s.scale

        lb[:, j], ub[:, j] = nlp(s.lower), nlp(s.upper)
        lo, hi = s.boundary_interval("initial")
        lb[0, j], ub[0, j] = nlp(lo), nlp(hi)
        lo, hi = s.boundary_interval("final")
        lb[-1, j], ub[-1, j] = max(lb[-1, j], nlp(lo)), min(ub[-1, j], nlp(hi))
    return lb, ub


def point_bounds(controls, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Scaled bounds (n_points, len(controls)) of controls at their parameter points."""
    lb = np.tile([(c.lower - c.shift) / c.scale for c in controls], (n_points, 1)).reshape(n_points, len(controls))
    ub = np.tile([(c.upper - c.shift) / c.scale for c in controls], (n_points, 1)).reshape(n_points, len(controls))
    return lb, ub


@dataclass(frozen=True)
class VariableGroup:
    """A run of NLP variables: the values of ``variables`` at ``points`` points, point by point.

    State groups carry the boundary conditions at their first and last point.
    """

    name: str
    variables: tuple
    points: int

    @property
    def size(self) -> int:
        return self.points * len(self.variables)

    @property
    def is_state(self) -> bool:
        return bool(self.variables) and isinstance(self.variables[0], State)

    @property
    def scaling(self) -> AffineScaling:
        return AffineScaling(np.array([v.shift for v in self.variables]), np.array([v.scale for v in self.variables]))


class Transcription(ABC):
    """A direct transcription of an :class:`~ocpkit.problem.OptimalControlProblem` into an NLP.

    Subclasses define the variable layout, the blocks and the interpolants;
    this class times the build, runs IPOPT and returns a :class:`~ocpkit.Solution`.
    """

    #: IPOPT options this scheme prefers over :data:`ocpkit.nlp.DEFAULT_IPOPT_OPTIONS` (user options win).
    ipopt_defaults: dict = {}

    def __init__(self, problem: OptimalControlProblem):
        if not isinstance(problem, OptimalControlProblem):
            raise TypeError(f"expected an OptimalControlProblem, got {type(problem).__name__}")
        self.problem = problem
        self._nlp: SeparableNLP | None = None
        self._solver = None
        self._solver_options = None
        self._nlp_build_s = 0.0
        self._solver_build_s = 0.0

    # -- to be provided by each scheme ------------------------------------------------
    @property
    @abstractmethod
    def label(self) -> str:
        """Short description, e.g. ``HLGL(segments=20)``."""

    @abstractmethod
    def _groups(self) -> list[VariableGroup]:
        """The NLP variables in layout order (a free final time follows them)."""

    @property
    @abstractmethod
    def n_defects(self) -> int: ...

    @abstractmethod
    def _blocks(self) -> list: ...

    @abstractmethod
    def _initial_point(self, tf: float, states, controls) -> np.ndarray:
        """Scaled NLP vector sampled from guess functions of time."""

    @abstractmethod
    def _package(self, result: NLPResult) -> dict:
        """Solution fields (times, values, interpolants, breakpoints) from the NLP result."""

    # -- layout: sizes, indices, bounds, packing -------------------------------------------
    @property
    def n_variables(self) -> int:
        return sum(g.size for g in self._groups()) + int(self.problem.free_final_time)

    def _index_tables(self) -> tuple[list[np.ndarray], int | None]:
        """Global NLP indices of each group, shaped (variables, points), and of tf (None if fixed)."""
        tables, offset = [], 0
        for g in self._groups():
            tables.append(offset + np.arange(g.size).reshape(g.points, len(g.variables)).T)
            offset += g.size
        return tables, (offset if self.problem.free_final_time else None)

    def _bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Scaled bounds of the NLP variables; state groups carry the boundary conditions."""
        return self._stack_bounds([
            node_bounds(g.variables, g.points) if g.is_state else point_bounds(g.variables, g.points)
            for g in self._groups()
        ])

    def pack(self, *values, tf: float | None = None) -> np.ndarray:
        """Scaled NLP vector from physical values, one (points, variables) array per group, and tf."""
        groups = self._groups()
        if len(values) == len(groups) + 1 and tf is None:
            *values, tf = values
        if len(values) != len(groups):
            raise ValueError(f"expected {len(groups)} arrays ({', '.join(g.name for g in groups)}), got {len(values)}")
        parts = []
        for g, v in zip(groups, values):
            v = np.asarray(v, dtype=float)
            if v.shape != (g.points, len(g.variables)):
                raise ValueError(f"{g.name} have shape {v.shape}, expected ({g.points}, {len(g.variables)})")
            parts.append(g.scaling.to_nlp(v).ravel() if g.variables else np.zeros(0))
        if self.problem.free_final_time:
            if tf is None:
                raise ValueError("this problem has a free final time: give tf")
            parts.append([tf / self.problem.tf.scale])
        return np.concatenate(parts)

    def unpack(self, w) -> tuple:
        """Physical values, one (points, variables) array per group, then tf, from a scaled NLP vector."""
        w = np.asarray(w, dtype=float).ravel()
        if w.size != self.n_variables:
            raise ValueError(f"NLP vector has {w.size} entries, expected {self.n_variables}")
        out, offset = [], 0
        for g in self._groups():
            z = w[offset:offset + g.size].reshape(g.points, len(g.variables))
            out.append(g.scaling.from_nlp(z) if g.variables else z)
            offset += g.size
        pr = self.problem
        out.append(float(w[-1] * pr.tf.scale if pr.free_final_time else pr.tf))
        return tuple(out)

    # -- helpers for subclasses ------------------------------------------------------------
    def _times(self, tf: float, fractions: np.ndarray) -> np.ndarray:
        """Physical times of normalised times ``fractions`` in [0, 1]."""
        return self.problem.t0 + (tf - self.problem.t0) * np.asarray(fractions)

    def _stack_bounds(self, parts) -> tuple[np.ndarray, np.ndarray]:
        """Concatenate ``(lower, upper)`` arrays in layout order and append the final-time bounds."""
        pr = self.problem
        lb = [np.ravel(lo) for lo, _ in parts]
        ub = [np.ravel(hi) for _, hi in parts]
        if pr.free_final_time:
            lb.append([pr.tf.lower / pr.tf.scale])
            ub.append([pr.tf.upper / pr.tf.scale])
        return np.concatenate(lb), np.concatenate(ub)

    def _mayer_block(self, first: np.ndarray, last: np.ndarray, tf_index: int | None) -> Block:
        """The Mayer term phi(x(t0), x(tf), t0, tf) on the NLP variables ``first`` and ``last`` (problem order)."""
        pr = self.problem
        nx = pr.nx
        free = pr.free_final_time
        z = ca.SX.sym("z", 2 * nx + int(free))
        p = ca.SX.sym("p", int(not free))
        tf = z[-1] * pr.tf.scale if free else p[0]
        xs = pr.state_scaling
        phi = pr.mayer(xs.from_nlp(z[:nx]), xs.from_nlp(z[nx:2 * nx]), pr.t0, tf)
        var = np.concatenate([first, last] + ([[tf_index]] if free else []))
        par = np.zeros((0, 1)) if free else np.array([[pr.tf]])
        return Block("mayer", ca.Function("mayer", [z, p], [phi / pr.objective_scale]), var[:, None], par)

    def _constraint_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        z = np.zeros(self.n_defects)
        return z, z.copy()

    @property
    def n_constraints(self) -> int:
        return self.n_defects

    # -- shared machinery ---------------------------------------------------------------
    def build(self) -> "Transcription":
        """Build the NLP (idempotent); the wall time is kept in ``build_s``."""
        if self._nlp is None:
            t = time.perf_counter()
            self._nlp = SeparableNLP(self.n_variables, self.n_constraints, self._blocks())
            self._nlp_build_s = time.perf_counter() - t
        return self

    @property
    def build_s(self) -> float:
        """Wall time to build the NLP and create the IPOPT solver, in seconds."""
        return self._nlp_build_s + self._solver_build_s

    @property
    def nlp(self) -> SeparableNLP:
        return self.build()._nlp

    def solver(self, ipopt_options: dict | None = None):
        key = tuple(sorted((ipopt_options or {}).items()))
        if self._solver is None or key != self._solver_options:
            self.build()
            t = time.perf_counter()
            self._solver = self.nlp.solver({**self.ipopt_defaults, **(ipopt_options or {})})
            self._solver_build_s = time.perf_counter() - t
            self._solver_options = key
        return self._solver

    def initial_point(self, guess=None) -> np.ndarray:
        """Scaled NLP start vector from a :class:`~ocpkit.Guess`, a :class:`~ocpkit.Solution` or the defaults."""
        if guess is None:
            guess = Guess()
        if isinstance(guess, Solution):
            same = (guess.problem.state_names, guess.problem.control_names) == (
                self.problem.state_names, self.problem.control_names)
            if not same:
                raise ValueError("a Solution used as guess must have the same states and controls")
            tf, xs, us = guess.tf, guess.state, guess.control
        elif isinstance(guess, Guess):
            tf, xs, us = guess.functions(self.problem)
        else:
            raise TypeError(f"guess must be a Guess or a Solution, got {type(guess).__name__}")
        w0 = np.asarray(self._initial_point(tf, xs, us), dtype=float)
        if w0.shape != (self.n_variables,):
            raise ValueError(f"initial point has shape {w0.shape}, expected ({self.n_variables},)")
        lb, ub = self._bounds()
        return np.clip(w0, lb, ub)

    def solve(self, guess=None, *, ipopt_options: dict | None = None, allow_acceptable: bool = False) -> Solution:
        """Solve with IPOPT from ``guess``; raise :class:`~ocpkit.SolverError` on failure.

        Parameters
        ----------
        guess : Guess, Solution or None
        ipopt_options : dict
            Overrides of :data:`ocpkit.nlp.DEFAULT_IPOPT_OPTIONS` (without the ``ipopt.`` prefix).
        allow_acceptable : bool
            Accept IPOPT's ``Solved_To_Acceptable_Level`` as success.
        """
        solver = self.solver(ipopt_options)
        lbw, ubw = self._bounds()
        lbg, ubg = self._constraint_bounds()
        w0 = self.initial_point(guess)
        result = solve_nlp(solver, w0, lbw, ubw, lbg, ubg, allow_acceptable=allow_acceptable)
        fields = self._package(result)
        return Solution(
            problem=self.problem,
            transcription=self.label,
            status=result.status,
            iterations=result.iterations,
            objective=result.objective * self.problem.objective_scale,
            nlp_parameters=self.n_variables,
            defect_equations=self.n_defects,
            constraints=self.n_constraints,
            build_s=self.build_s,
            solve_s=result.solve_s,
            raw={"w": result.w, "lam_g": result.lam_g, "lam_w": result.lam_w, "stats": result.stats},
            **fields,
        )
