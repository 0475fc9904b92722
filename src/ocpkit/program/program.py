"""The one program that owns a direct transcription's NLP: :class:`Program`.

A program is a statement (a single-phase :class:`~ocpkit.statement.problem.OptimalControlProblem`, or a
:class:`~ocpkit.statement.phases.MultiPhaseProblem` of named, linked phases) transcribed by one scheme per phase
(:class:`~ocpkit.program.scheme.Scheme`: configuration on a grid). It lays out the whole NLP once
(:class:`~ocpkit.program.layout.Layout`), builds its blocks once (:mod:`ocpkit.program.assembly`, the schemes'
own), keeps the :class:`~ocpkit.nlp.SeparableNLP` and its IPOPT instances, computes the bounds, the start and the
packing of every result into a :class:`~ocpkit.Solution`, and solves by one policy (:mod:`ocpkit.program.solve`: one
IPOPT solve, a warm start, a mesh refinement whose every mesh is a program again). A single-phase problem is a
program of one phase: ``HLGL(problem, intervals=20).solve()`` is the shorthand of
``Program(problem, HLGL(intervals=20)).solve()``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Self, cast

import casadi as ca
import numpy as np

from ..nlp import DEFAULT_IPOPT_OPTIONS, Block, NLPResult, SeparableNLP
from ..solution import PhaseSolution, Solution
from ..statement import Guess, OptimalControlProblem, wrap_periodic
from ..statement.phases import MultiPhaseProblem
from ..statement.variables import EndValues
from ..trajectory import Trajectory
from . import assembly
from . import solve as policy
from .layout import Layout, Phase
from .loop import SolveLoop
from .scheme import Scheme

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..statement import Constraint
    from ..statement.phases import Link
    from ..verdict import VerdictKind


#: Collocation points (of the phases with shared columns, :attr:`Program.points_with_shared_columns`: a free t0 or tf,
#: a free parameter) from which an NLP is factorised with ocpkit's default ordering, MUMPS' QAMD, whatever ordering
#: its scheme asks for. A variable every point of a phase depends on is a dense row and column of the KKT matrix: QAMD
#: is approximate minimum degree with quasi-dense row detection (MUMPS' users' guide, ICNTL(7) = 6), AMF (Radau's
#: ordering) has none, and its time grows much faster than the mesh (``benchmarks/bench_orderings.py``, its table by
#: size: the flat moon, free tf, 5 times the points, AMF 10 times the time, QAMD 6 times). Without shared columns AMF
#: is as fast. Below this size the scheme's ordering stays: the ordering also moves where IPOPT converges on hard
#: problems (:attr:`~ocpkit.transcription.radau.Radau.ipopt_defaults`), and no Radau mesh with a shared column in the
#: published record reaches it.
SHARED_COLUMN_POINTS = 10_000


def _is_scheme(value: Any) -> bool:
    return isinstance(value, Scheme)


class Program:
    """A statement transcribed by its schemes, owning the whole NLP (module docstring).

    Parameters
    ----------
    statement : OptimalControlProblem or MultiPhaseProblem
        The problem as stated: one phase, or named linked phases with the trajectory's cost, linkage constraints
        and parameters.
    scheme : Scheme, Sequence[Scheme] or Mapping[str, Scheme]
        How each phase is transcribed (``Radau(nodes=4, intervals=20)``): one scheme for every phase, one per phase
        in order, or one per phase by name. A scheme bound to a problem (``HLGL(problem, 20)``) must be bound to its
        phase's.
    compile : str or bool
        Whether the NLP's Jacobian and Hessian blocks are compiled to C (``"auto"``: where one evaluation is large
        and a C compiler is found); set before the NLP is built. A refinement's
        meshes keep it.
    """

    def __init__(
        self,
        statement: OptimalControlProblem | MultiPhaseProblem,
        scheme: Scheme | Sequence[Scheme] | Mapping[str, Scheme],
        *,
        compile: str | bool = "auto",
    ) -> None:
        if isinstance(statement, OptimalControlProblem):
            phased = MultiPhaseProblem({statement.name: statement}, objective_scale=statement.objective_scale)
        elif isinstance(statement, MultiPhaseProblem):
            phased = statement
        else:
            raise TypeError(f"expected an OptimalControlProblem or a MultiPhaseProblem, got {type(statement).__name__}")
        #: the problem as stated (a single phase's problem, or the phases' :class:`~ocpkit.MultiPhaseProblem`)
        self.statement = statement
        #: the statement as phases (a single-phase problem is one phase named after it)
        self.phased = phased
        #: one scheme per phase
        self.schemes = self._schemes(phased, scheme)
        #: whether the NLP's blocks are compiled to C (``"auto"``, True or False)
        self.compile = compile
        #: the NLP's layout (:class:`~ocpkit.program.layout.Layout`), built once
        self.layout = Layout.build(phased, self.schemes)
        self._nlp: SeparableNLP | None = None
        self._objective_blocks: list[list[tuple[Block, ca.Function]]] = []
        self._trajectory_cost: ca.Function | None = None
        self._trajectory_variables = np.zeros(0, dtype=np.int64)
        self._trajectory_constants = np.zeros(0)
        self._solvers: dict[tuple[Any, ...], ca.Function] = {}
        self._nlp_build_s = 0.0
        self._solver_build_s = 0.0

    @staticmethod
    def _schemes(
        phased: MultiPhaseProblem, scheme: Scheme | Sequence[Scheme] | Mapping[str, Scheme]
    ) -> tuple[Scheme, ...]:
        """One checked scheme per phase."""
        n = len(phased)
        if _is_scheme(scheme):
            schemes = [cast("Scheme", scheme)] * n
        elif isinstance(scheme, Mapping):
            missing = [name for name in phased.names if name not in scheme]
            unknown = [name for name in scheme if name not in phased.names]
            if missing or unknown:
                raise ValueError(
                    f"give one scheme per phase by name: the phases are {phased.names}"
                    + (f"; no scheme for {missing}" if missing else "")
                    + (f"; {unknown} are not phases" if unknown else "")
                )
            schemes = [scheme[name] for name in phased.names]
        elif isinstance(scheme, Sequence) and not isinstance(scheme, str):
            schemes = list(scheme)
            if len(schemes) != n:
                raise ValueError(f"give one scheme per phase: {n} phases, {len(schemes)} schemes")
        else:
            raise TypeError(f"scheme must be a transcription scheme (HLGL, Radau, ...), got {type(scheme).__name__}")
        for name, problem, s in zip(phased.names, phased.problems, schemes):
            if not _is_scheme(s):
                raise TypeError(
                    f"phase {name!r}: the scheme must be a transcription scheme (HLGL, Radau, ...), "
                    f"got {type(s).__name__}"
                )
            bound = getattr(s, "problem", None)
            if bound is not None and bound is not problem:
                raise ValueError(
                    f"phase {name!r}: its scheme {s.label} is bound to the problem {bound.name!r}, not to the phase's "
                    f"{problem.name!r}; give the scheme alone ({type(s).__name__}(...) without a problem)"
                )
        return tuple(schemes)

    @classmethod
    def from_phases(
        cls,
        phases: Sequence[Scheme] | Mapping[str, Scheme],
        links: Sequence[Link] | None = None,
        *,
        compile: str | bool = "auto",
        **options: Any,
    ) -> Program:
        """The program of phases each given by a scheme bound to its problem (``[HLGL(climb, 20), Radau(coast, 4,
        10)]``, or a mapping name -> scheme; unnamed phases are named by their problems), linked by ``links`` (default:
        each phase continues the previous one in every state and in time); ``options`` are
        :class:`~ocpkit.statement.phases.MultiPhaseProblem`'s (``cost``, ``constraints``, ``free_parameters``,
        ``local_parameters``, ``objective_scale``)."""
        listed = list(phases.values()) if isinstance(phases, Mapping) else list(phases)
        problems = []
        for k, s in enumerate(listed):
            bound = getattr(s, "problem", None)
            if not _is_scheme(s) or not isinstance(bound, OptimalControlProblem):
                raise TypeError(
                    f"phase {k} must be a scheme bound to its problem (HLGL(problem, ...), Radau(problem, ...)), "
                    f"got {s!r}"
                )
            problems.append(bound)
        named: Any = dict(zip(phases, problems)) if isinstance(phases, Mapping) else problems
        return cls(MultiPhaseProblem(named, links, **options), listed, compile=compile)

    @classmethod
    def split(
        cls,
        problem: OptimalControlProblem,
        times: Sequence[float],
        scheme: Scheme | Callable[[OptimalControlProblem], Scheme],
        *,
        cost: Callable[..., Any] | None = None,
        constraints: Sequence[Constraint] = (),
        compile: str | bool = "auto",
        **options: Any,
    ) -> Program:
        """``problem`` cut at fixed ``times`` into linked phases (:meth:`MultiPhaseProblem.split
        <ocpkit.statement.phases.MultiPhaseProblem.split>`), each transcribed by ``scheme`` (a scheme, or a function
        of a piece's problem that returns one, ``lambda piece: Radau(piece, 4, 3)``)."""
        statement = MultiPhaseProblem.split(problem, times, cost=cost, constraints=constraints, **options)
        schemes: Scheme | list[Scheme]
        schemes = (
            [cast("Callable[..., Scheme]", scheme)(p) for p in statement.problems]
            if not _is_scheme(scheme)
            else cast("Scheme", scheme)
        )
        return cls(statement, schemes, compile=compile)

    # -- what it is ---------------------------------------------------------------------------------------------------
    @property
    def phases(self) -> tuple[Phase, ...]:
        """Each phase's layout, scheme and rows (:class:`~ocpkit.program.layout.Phase`)."""
        return self.layout.phases

    @property
    def names(self) -> list[str]:
        """The phases' names."""
        return list(self.phased.names)

    @property
    def single(self) -> bool:
        """Whether the program has one phase."""
        return len(self.phases) == 1

    @property
    def plain(self) -> bool:
        """Whether the program is a single-phase problem's, one phase and no cost or linkage constraint of the
        trajectory (its solution is then its phase's)."""
        return self.single and self.phased.cost is None and self.phased.linkage is None

    def _only(self, what: str) -> Phase:
        if not self.single:
            raise AttributeError(f"a program of {len(self.phases)} phases has a {what} per phase ({self.names})")
        return self.phases[0]

    @property
    def problem(self) -> OptimalControlProblem:
        """The problem of a single-phase program (a program of several phases has one per phase,
        ``phased.phase(name)``)."""
        return self._only("problem").problem

    @property
    def scheme(self) -> Scheme:
        """The scheme of a single-phase program (a program of several phases has one per phase, ``schemes``)."""
        return self._only("scheme").scheme

    @property
    def objective_scale(self) -> float:
        """The NLP minimises ``J / objective_scale``."""
        return self.phased.objective_scale

    @property
    def label(self) -> str:
        """The scheme's label (of several phases, each phase's)."""
        if self.single:
            return self.schemes[0].label
        return "Program(" + ", ".join(f"{p.name}: {p.scheme.label}" for p in self.phases) + ")"

    @property
    def shared_parameters(self) -> list[str]:
        """The free parameters of the trajectory (one NLP variable each, whatever the phases naming them)."""
        return self.phased.shared_parameters

    @property
    def cut_times(self) -> np.ndarray | None:
        """The times a problem was cut at (:meth:`split`), else None."""
        return self.phased.cut_times

    # -- sizes ------------------------------------------------------------------------------------------------------
    @property
    def n_variables(self) -> int:
        """The NLP's variables (the layout's size)."""
        return self.layout.size

    @property
    def n_constraints(self) -> int:
        """The NLP's constraint rows."""
        return self.layout.n_constraints

    @property
    def n_defects(self) -> int:
        """The schemes' defect equations, over the phases."""
        return int(sum(p.n_defects for p in self.phases))

    @property
    def n_decision_variables(self) -> int:
        """The NLP's free variables (the paper's "NLP parameters"), all but the pinned problem parameters."""
        return self.n_variables - int(sum(len(p.problem.parameters) for p in self.phases))

    @property
    def n_collocation_points(self) -> int:
        """Points at which the dynamics hold (the measure of a mesh's size in the refinement literature)."""
        return int(sum(p.n_defects // max(p.problem.nx, 1) for p in self.phases))

    @property
    def n_path_points(self) -> int:
        """Points at which the path constraints hold (0 without path constraints)."""
        return int(sum(p.n_path_points for p in self.phases))

    def path_point_fractions(self) -> np.ndarray:
        """Normalised times (0..1) of the path-constraint points, in constraint-row order (phase by phase)."""
        return np.concatenate([p.path_fractions for p in self.phases]) if self.phases else np.zeros(0)

    # -- the NLP ------------------------------------------------------------------------------------------------------
    def build(self) -> Self:
        """Build the NLP once (its blocks, :class:`~ocpkit.nlp.SeparableNLP`); the wall time is kept in
        :attr:`build_s`."""
        if self._nlp is None:
            t = time.perf_counter()
            blocks: list[Block] = []
            self._objective_blocks = []
            for p in self.phases:
                own = assembly.phase_blocks(p, "" if self.single else f"phase{p.index}_")
                self._objective_blocks.append(
                    [(b, b.function.map(b.variables.shape[1])) for b in own if b.rows is None]
                )
                blocks += own
            layout = self.layout
            blocks += assembly.link_blocks(self.phased, self.phases, layout.link_rows)
            trajectory, cost = assembly.trajectory_blocks(
                self.phased, self.phases, layout.n_phase_rows + layout.n_link_rows
            )
            blocks += trajectory
            if cost is not None:
                _, _, _, self._trajectory_variables, self._trajectory_constants = assembly.ends_function(self.phases)
            self._trajectory_cost = cost
            self._nlp = SeparableNLP(self.n_variables, self.n_constraints, blocks, compile=self.compile)
            self._nlp_build_s = time.perf_counter() - t
        return self

    @property
    def nlp(self) -> SeparableNLP:
        """The program's NLP (:class:`~ocpkit.nlp.SeparableNLP`), built on first access (:meth:`build`)."""
        return cast(SeparableNLP, self.build()._nlp)  # (built)

    @property
    def build_s(self) -> float:
        """Wall time to build the NLP and create the IPOPT solver, in seconds."""
        return self._nlp_build_s + self._solver_build_s

    @property
    def shared_columns(self) -> int:
        """How many free variables every point of a phase may depend on (free parameters, a free t0 or tf), counted
        per phase; pinned parameters are held by their bounds, which IPOPT removes."""
        return int(sum(self._shared(p) for p in self.phases))

    @property
    def points_with_shared_columns(self) -> int:
        """The collocation points of the phases with shared columns (:attr:`shared_columns`): the length of the
        KKT matrix's dense columns."""
        return int(sum(p.n_defects // max(p.problem.nx, 1) for p in self.phases if self._shared(p)))

    @staticmethod
    def _shared(phase: Phase) -> int:
        return phase.layout.times.size - phase.layout.times.n_pinned

    @property
    def ipopt_defaults(self) -> dict[str, Any]:
        """The schemes' IPOPT defaults where every phase asks for the same value (an ordering one phase's structure
        asks for, and another's does not, is left at ocpkit's default), except a scheme's ordering on a large NLP
        with shared columns (:data:`SHARED_COLUMN_POINTS`), which gets ocpkit's default ordering."""
        first, *others = [dict(s.ipopt_defaults) for s in self.schemes]
        agreed = {k: v for k, v in first.items() if all(o.get(k, object()) == v for o in others)}
        if self.points_with_shared_columns >= SHARED_COLUMN_POINTS:
            agreed.pop("mumps_pivot_order", None)
        return agreed

    def effective_ipopt_options(self, ipopt_options: dict[str, Any] | None = None) -> dict[str, Any]:
        """The IPOPT options a solve with these overrides runs with: ocpkit's defaults
        (:data:`~ocpkit.nlp.DEFAULT_IPOPT_OPTIONS`), then the schemes' (:attr:`ipopt_defaults`: the ordering their
        structure asks for), then the overrides."""
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

    # -- bounds ------------------------------------------------------------------------------------------------------
    def check_parameters(self, parameters: Mapping[str, float]) -> dict[str, float]:
        """New values of some of the phases' fixed parameters, checked by name (a KeyError names them all) and as
        finite numbers."""
        if not isinstance(parameters, Mapping):
            raise TypeError(f"parameters must be a mapping of names to values, got {type(parameters).__name__}")
        known = sorted(self.layout.parameter_slots)
        unknown = sorted(set(parameters) - set(known))
        if unknown:
            raise KeyError(f"unknown parameters {unknown}; {self.label} has {known}")
        out = {}
        for name, value in parameters.items():
            value = float(value)
            if not np.isfinite(value):
                raise ValueError(f"parameter {name!r} must be finite, got {value!r}")
            out[name] = value
        return out

    def parameter_defaults(self) -> dict[str, float | None]:
        """Each fixed parameter's value where its phases agree, None where they hold it at different values (a value
        given to a solve pins every phase's)."""
        values: dict[str, float | None] = {}
        for p in self.phases:
            for name, value in p.problem.parameters.items():
                if name in values and values[name] != value:
                    values[name] = None
                else:
                    values.setdefault(name, float(value))
        return values

    @property
    def parameter_slots(self) -> dict[str, np.ndarray]:
        """Per fixed parameter, the NLP indices its value is pinned at, in every phase that has it."""
        return self.layout.parameter_slots

    def _phase_bounds(self, phase: Phase, parameters: Mapping[str, float] | None) -> tuple[np.ndarray, np.ndarray]:
        """A phase's scaled variable bounds in its own numbering: states with their boundary conditions at their
        groups' first and last point, controls with their end values where a point lies there, the problem-wide
        variables (the fixed parameters pinned to their values, ``parameters`` replacing some)."""
        layout = phase.layout
        lower, upper = [], []
        for g in layout.groups:
            # float: a group whose bounds are all integers would truncate its end values (0.5 stored as 0)
            lo = np.tile(np.array([v.lower for v in g.variables], dtype=float), (g.points, 1))
            hi = np.tile(np.array([v.upper for v in g.variables], dtype=float), (g.points, 1))
            lo, hi = lo.reshape(g.points, len(g.variables)), hi.reshape(g.points, len(g.variables))
            fractions = np.asarray(g.fractions, dtype=float)
            for j, v in enumerate(g.variables):
                if not isinstance(v, EndValues):
                    continue
                if g.is_state or (v.initial is not None and fractions[0] == 0.0):
                    lo[0, j], hi[0, j] = v.boundary_interval("initial")
                if g.is_state or (v.final is not None and fractions[-1] == 1.0):
                    lf, hf = v.boundary_interval("final")
                    lo[-1, j], hi[-1, j] = max(lo[-1, j], lf), min(hi[-1, j], hf)
            sc = g.scaling
            lower.append(sc.to_nlp(lo).ravel())
            upper.append(sc.to_nlp(hi).ravel())
        pr = phase.problem
        given = {k: v for k, v in (parameters or {}).items() if k in pr.parameters}
        lo, hi = layout.times.bounds(pr.parameter_vector(given) if given else pr.parameter_vector())
        return np.concatenate([*lower, lo]), np.concatenate([*upper, hi])

    def bounds(self, parameters: Mapping[str, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The scaled bounds of the NLP's variables (``parameters``: new values of some fixed parameters); a free
        parameter of the trajectory is bounded by every phase's declaration of it."""
        if self.single:
            return self._phase_bounds(self.phases[0], parameters)
        lb, ub = np.full(self.n_variables, -np.inf), np.full(self.n_variables, np.inf)
        for p in self.phases:
            lo, hi = self._phase_bounds(p, parameters)
            np.maximum.at(lb, p.to_global, lo)
            np.minimum.at(ub, p.to_global, hi)
        return lb, ub

    def constraint_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The bounds of the constraint rows: each phase's (defects zero, path and boundary constraints over their
        scales, control end values), then the links (zero) and the linkage constraints."""
        lo: list[np.ndarray] = []
        hi: list[np.ndarray] = []
        for p in self.phases:
            pr = p.problem
            lo.append(np.zeros(p.n_defects))
            hi.append(np.zeros(p.n_defects))
            path = pr.functions.path
            if path is not None:
                lo.append(np.tile(path.lower / path.scale, p.n_path_points))
                hi.append(np.tile(path.upper / path.scale, p.n_path_points))
            boundary = pr.functions.boundary
            if boundary is not None:
                lo.append(boundary.lower / boundary.scale)
                hi.append(boundary.upper / boundary.scale)
            for end in p.control_ends:
                c = end.control
                total = float(np.sum(end.weights))
                lo.append(np.array([(end.lower - c.shift * total) / c.scale]))
                hi.append(np.array([(end.upper - c.shift * total) / c.scale]))
        links = np.zeros(self.layout.n_link_rows)
        lo.append(links)
        hi.append(links)
        linkage = self.phased.linkage
        if linkage is not None:
            lo.append(linkage.lower / linkage.scale)
            hi.append(linkage.upper / linkage.scale)
        return np.concatenate(lo), np.concatenate(hi)

    def nlp_bounds(
        self, parameters: Mapping[str, float] | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(lbw, ubw, lbg, ubg)``: the bounds of the scaled NLP variables and constraints, for solving
        :attr:`nlp` with another NLP solver (then :meth:`package` its result)."""
        return (*self.bounds(parameters), *self.constraint_bounds())

    # -- vectors ---------------------------------------------------------------------------------------------------------
    def _phase_guesses(self, guess: Any) -> list[Any]:
        n = len(self.phases)
        if guess is None:
            return [None] * n
        if isinstance(guess, Solution) and len(guess.phases) == n and n > 1:
            return list(guess.phases)
        if isinstance(guess, Mapping):
            unknown = [k for k in guess if k not in self.names]
            if unknown:
                raise KeyError(f"guesses of unknown phases {unknown}; the phases are {self.names}")
            return [guess.get(name) for name in self.names]
        if isinstance(guess, (list, tuple)):
            if len(guess) != n:
                raise ValueError(f"give one guess per phase: {n} phases, {len(guess)} guesses")
            return list(guess)
        if n == 1 or isinstance(guess, (Guess, Trajectory)):
            return [guess] * n  # one guess of the whole horizon: each phase takes its own window of it
        raise TypeError(
            f"a program of {n} phases takes one guess per phase (a list or a mapping by name), a solution of "
            f"{n} phases, or one Guess or trajectory of the whole horizon; got {type(guess).__name__}"
        )

    def _phase_start(self, phase: Phase, guess: Any, whole: bool = False) -> np.ndarray:
        """A phase's scaled start vector (its own numbering) from a :class:`~ocpkit.Guess`, a trajectory of the
        same states and controls (a solution, an extremal) or the defaults.

        ``whole``: ``guess`` is one guess of the whole horizon, shared by every phase. Each phase then takes its own
        window of it: a fixed end at its own time, a free one at the phase's own guess of it (the guess does not
        know where a junction lies), except the trajectory's ends, the first phase's start and the last phase's
        end, which the guess's own times give."""
        pr = phase.problem
        xs: Callable[[ArrayLike], np.ndarray]
        us: Callable[[ArrayLike], np.ndarray]
        if guess is None:
            guess = Guess()
        if isinstance(guess, Trajectory):
            if (guess.state_names, guess.control_names) != (pr.state_names, pr.control_names):
                raise ValueError("a Solution used as guess must have the same states and controls")
            tf, xs, us = guess.tf, guess.state, guess.control
            t0 = guess.t0 if pr.free_initial_time else None
        elif isinstance(guess, Guess):
            tf, xs, us = guess.functions(pr)
            t0 = None
        else:
            raise TypeError(f"guess must be a Guess or a Solution, got {type(guess).__name__}")
        if not self.single:  # a phase's window: its own times where they are fixed (and, of one guess of the whole
            # horizon, where they are free, but for the trajectory's start and end)
            first, last = phase is self.phases[0], phase is self.phases[-1]
            tf = tf if pr.free_final_time and (last or not whole) else pr.tf_guess
            t0 = t0 if pr.free_initial_time and (first or not whole) else None
        layout = phase.layout
        start = pr.t0 if t0 is None else t0
        index = {name: k for k, name in enumerate(pr.state_names)} | {
            name: k for k, name in enumerate(pr.control_names)
        }
        parts = []
        for g in layout.groups:
            source = xs if g.is_state else us
            values = np.asarray(source(start + (tf - start) * np.asarray(g.fractions)), dtype=float)
            if g.is_control and isinstance(guess, Trajectory):  # a continuous angle into its bounds by whole turns
                values = wrap_periodic(values, pr.controls)
            values = values[:, [index[v.name] for v in g.variables]] if g.variables else np.zeros((g.points, 0))
            if values.shape != (g.points, len(g.variables)):
                raise ValueError(f"{g.name} have shape {values.shape}, expected ({g.points}, {len(g.variables)})")
            parts.append(g.scaling.to_nlp(values).ravel() if g.variables else np.zeros(0))
        times = layout.times
        parts.append(times.pack(pr.parameter_vector(), {}, t0, tf))
        w0 = np.concatenate(parts)
        if times.n_free:
            if isinstance(guess, Trajectory):
                solved = dict(getattr(guess, "parameters", None) or {})
                try:
                    solved = {**guess.problem.parameters, **solved}
                except (AttributeError, ValueError):  # a solution of several phases has a problem per phase
                    pass
                guessed = {v.name: solved.get(v.name, v.guess_value) for v in times.free}
            else:
                guessed = cast(Guess, guess).parameter_values(pr)
            w0[layout.global_indices[times.free_positions]] = times.free_to_nlp(guessed)
        return w0

    def initial_point(self, guess: Any = None) -> np.ndarray:
        """Scaled NLP start vector from a :class:`~ocpkit.Guess`, a :class:`~ocpkit.Solution` or the defaults (of
        several phases: one of these per phase, in a list or a mapping by name, a solution of as many phases, or one
        guess of the whole horizon, of which each phase takes its own window: :meth:`solve`'s ``guess``)."""
        guesses = self._phase_guesses(guess)
        if self.single:
            w0 = self._phase_start(self.phases[0], guesses[0])
        else:
            # one guess of the whole horizon (a Guess or a trajectory, not one per phase): each phase its window of it
            whole = isinstance(guess, (Guess, Trajectory)) and guesses[0] is guess
            w0 = np.full(self.n_variables, np.nan)
            for p, g in zip(self.phases, guesses):
                local = self._phase_start(p, g, whole)
                unset = np.isnan(w0[p.to_global])  # a free parameter of the trajectory: its first phase's start
                w0[p.to_global[unset]] = local[unset]
        if w0.shape != (self.n_variables,):
            raise ValueError(f"initial point has shape {w0.shape}, expected ({self.n_variables},)")
        lb, ub = self.bounds()
        return np.clip(w0, lb, ub)

    def pack(
        self,
        *values: ArrayLike | None,
        tf: float | None = None,
        t0: float | None = None,
        parameters: Mapping[str, float] | None = None,
    ) -> np.ndarray:
        """Scaled NLP vector of a single-phase program from physical values, one (points, variables) array per group,
        and tf (free parameters and a free t0: ``parameters`` and ``t0``, default their guesses)."""
        layout = self._only("packing").layout
        groups = layout.groups
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
        pr = layout.problem
        given = dict(parameters or {})
        pinned = pr.parameter_vector({k: v for k, v in given.items() if k in pr.parameters})
        free = {k: v for k, v in given.items() if k not in pr.parameters}
        parts.append(layout.times.pack(pinned, free, t0, tf))
        return np.concatenate(parts)

    def unpack(self, w: ArrayLike) -> tuple[Any, ...]:
        """Physical values of a single-phase program's scaled NLP vector, one (points, variables) array per group,
        then tf."""
        layout = self._only("unpacking").layout
        w = self._vector(w)
        out: list[Any] = [
            g.scaling.from_nlp(w[table.T]) if g.variables else w[table.T]
            for g, table in zip(layout.groups, layout.tables)
        ]
        out.append(layout.times.unpack(w[layout.global_indices])["tf"])
        return tuple(out)

    def _vector(self, w: ArrayLike) -> np.ndarray:
        w = np.asarray(w, dtype=float).ravel()
        if w.size != self.n_variables:
            raise ValueError(
                f"an NLP vector of {w.size} entries for {self.label}, which has {self.n_variables}: a refined "
                "solution's vector belongs to its last mesh, solution.program"
            )
        return w

    def global_indices(self) -> np.ndarray:
        """NLP indices of a single-phase program's problem-wide variables (parameters, a free t0 and tf), last."""
        p = self._only("problem-wide variables")
        return p.to_global[p.layout.global_indices]

    def time_indices(self) -> tuple[int | None, int | None]:
        """NLP indices of a single-phase program's t0 and tf (None where fixed)."""
        g, times = self.global_indices(), self._only("time").layout.times
        indices = tuple(None if k is None else int(g[k]) for k in (times.t0_position, times.tf_position))
        return cast("tuple[int | None, int | None]", indices)

    def global_values(self, w: ArrayLike) -> dict[str, Any]:
        """``{"pinned": {name: value}, "parameters": {name: value}, "t0": ..., "tf": ...}`` of a single-phase
        program's scaled NLP vector (``pinned``: the problem's parameters as solved with; ``parameters``: the free
        ones)."""
        w = self._vector(w)
        return self._only("time").layout.times.unpack(w[self.global_indices()])

    def _phase_values(self, phase: Phase, w: np.ndarray) -> dict[str, Any]:
        local = w[phase.to_global]
        return phase.layout.times.unpack(local[phase.layout.global_indices])

    def time_span(self, w: ArrayLike) -> tuple[float, float]:
        """``(t0, tf)`` of a scaled NLP vector: the first phase's start and the last phase's end."""
        w = np.asarray(w, dtype=float).ravel()
        return self._phase_values(self.phases[0], w)["t0"], self._phase_values(self.phases[-1], w)["tf"]

    # -- results -------------------------------------------------------------------------------------------------------
    def _solved_problem(self, phase: Phase, values: Mapping[str, Any]) -> OptimalControlProblem:
        """The phase's problem with the parameter values solved with (sharing the functions) and its free parameters
        fixed at their solved values."""
        pr = phase.problem
        if values["pinned"] != pr.parameters:
            pr = pr.replace(parameters=values["pinned"])
        if pr.free_parameters:
            pr = pr.fix_parameters(values["parameters"])
        return pr

    def _phase_solution(self, phase: Phase, result: NLPResult, g: np.ndarray | None) -> PhaseSolution:
        layout = phase.layout
        local = result.w[phase.to_global]
        values = layout.times.unpack(local[layout.global_indices])
        problem = self._solved_problem(phase, values)
        t0, tf = values["t0"], values["tf"]
        groups = [
            g_.scaling.from_nlp(local[table.T]) if g_.variables else local[table.T]
            for g_, table in zip(layout.groups, layout.tables)
        ]
        fields = phase.scheme.interpolants(layout, groups, problem, t0, tf)
        lam = np.asarray(result.lam_g, dtype=float)
        defects = lam[phase.row_offset : phase.row_offset + phase.n_defects]
        costates = phase.scheme.costates(layout, defects, t0, tf)
        if self.plain:
            objective = result.objective * self.objective_scale
        else:
            objective = self._phase_objective(phase, result.w)
        return PhaseSolution(
            name=phase.name,
            problem=problem,
            statement=phase.problem,
            transcription=phase.scheme.label,
            objective=objective,
            t0=t0,
            tf=tf,
            defect_equations=phase.n_defects,
            state_times=fields.state_times,
            state_values=fields.state_values,
            control_times=fields.control_times,
            control_values=fields.control_values,
            breakpoints=fields.breakpoints,
            state_interpolant=fields.state_interpolant,
            control_interpolant=fields.control_interpolant,
            costate_times=None if costates is None else costates[0],
            costate_values=None if costates is None else costates[1],
            estimate_breakpoints=fields.estimate_breakpoints,
            estimate_points=fields.estimate_points,
            parameters=values["parameters"],
            **self._constraint_fields(phase, result, g, t0, tf),
        )

    def _constraint_fields(
        self, phase: Phase, result: NLPResult, g: np.ndarray | None, t0: float, tf: float
    ) -> dict[str, Any]:
        """Values and multipliers of a phase's path and boundary constraints, in the problem's units.

        The multiplier of a constraint row is IPOPT's, converted from the scaled NLP
        (``objective_scale / scale``): positive where the upper bound is active, negative
        where the lower one is, zero where the constraint is inactive.
        """
        pr = phase.problem
        out: dict[str, Any] = {}
        path, boundary = pr.functions.path, pr.functions.boundary
        if path is None and boundary is None:
            return out
        values = cast(np.ndarray, g)  # (evaluated where there are constraints to read)
        lam = np.asarray(result.lam_g, dtype=float).ravel()
        os = self.objective_scale
        row = phase.row_offset + phase.n_defects
        if path is not None:
            n, m = phase.n_path_points, path.size
            sl = slice(row, row + n * m)
            order = np.argsort(phase.path_fractions, kind="stable")
            out["path_times"] = t0 + (tf - t0) * phase.path_fractions[order]
            out["path_values"] = (values[sl].reshape(n, m) * path.scale)[order]
            out["path_multipliers"] = (lam[sl].reshape(n, m) * os / path.scale)[order]
            row += n * m
        if boundary is not None:
            sl = slice(row, row + boundary.size)
            out["boundary_values"] = values[sl] * boundary.scale
            out["boundary_multipliers"] = lam[sl] * os / boundary.scale
        return out

    def _phase_objective(self, phase: Phase, w: np.ndarray) -> float:
        """A phase's objective at ``w``: the sum of its objective blocks, in the problem's units."""
        self.build()
        total = 0.0
        for b, mapped in self._objective_blocks[phase.index]:
            total += float(np.sum(np.asarray(mapped(w[b.variables], b.constants))))
        return total * self.objective_scale

    def trajectory_cost_at(self, w: ArrayLike) -> float:
        """The trajectory-level cost at a scaled NLP vector (0 without one)."""
        self.build()
        if self._trajectory_cost is None:
            return 0.0
        w = np.asarray(w, dtype=float).ravel()
        return float(self._trajectory_cost(w[self._trajectory_variables], self._trajectory_constants))

    def _trajectory_parameters(self, phases: Sequence[PhaseSolution]) -> dict[str, float]:
        """The solved free parameters of the trajectory: each shared one once, and each that one phase alone names;
        phase-local ones (``local_parameters`` named by several phases) are in ``phase(name).parameters``."""
        count: dict[str, int] = {}
        for p in self.phases:
            for v in p.problem.free_parameters:
                count[v.name] = count.get(v.name, 0) + 1
        out: dict[str, float] = {}
        for sol in phases:
            for name, value in sol.parameters.items():
                if name in self.phased.shared or count[name] == 1:
                    out.setdefault(name, value)
        return out

    def solution(self, result: NLPResult, g: np.ndarray | None = None) -> Solution:
        """The :class:`~ocpkit.Solution` of an NLP result (``g``: its constraint values, when already evaluated)."""
        needs_g = not self.plain or any(
            p.problem.functions.path is not None or p.problem.functions.boundary is not None for p in self.phases
        )
        if g is None and needs_g:
            g = np.asarray(self.nlp.constraint_function(result.w)).ravel()
        phases = [self._phase_solution(p, result, g) for p in self.phases]
        if self.plain:
            objective = result.objective * self.objective_scale
            parameters, residual, trajectory_cost = phases[0].parameters, 0.0, 0.0
        else:
            trajectory_cost = self.trajectory_cost_at(result.w)
            objective = float(sum(p.objective for p in phases)) + trajectory_cost
            parameters = self._trajectory_parameters(phases)
            rows = slice(self.layout.n_phase_rows, self.n_constraints)
            lo, hi = (b[rows] for b in self.constraint_bounds())
            link = cast(np.ndarray, g)[rows]
            residual = float(np.max(np.maximum(lo - link, link - hi), initial=0.0))
        return Solution(
            phases=phases,
            program=self,
            status=result.status,
            iterations=result.iterations,
            objective=objective,
            decision_variables=self.n_decision_variables,
            constraints=self.n_constraints,
            build_s=self.build_s,
            solve_s=result.solve_s,
            converged=result.success,
            nlp_result=result,
            parameters=parameters,
            link_residual=residual,
            trajectory_cost=trajectory_cost,
        )

    def package(self, result: NLPResult, raise_on_failure: bool = True) -> Solution:
        """The :class:`~ocpkit.Solution` of an NLP result from any solver (a failed one raises
        :class:`~ocpkit.SolverError` naming its status, unless ``raise_on_failure`` is False)."""
        return policy.settle(result, self.solution, raise_on_failure)

    def linkage_values(self, result: NLPResult) -> tuple[np.ndarray, np.ndarray]:
        """The trajectory's linkage constraints at a result: values and multipliers in the problem's units."""
        linkage = self.phased.linkage
        if linkage is None:
            return np.zeros(0), np.zeros(0)
        g = np.asarray(self.nlp.constraint_function(result.w)).ravel()
        rows = slice(self.n_constraints - linkage.size, self.n_constraints)
        lam = np.asarray(result.lam_g, dtype=float).ravel()
        return g[rows] * linkage.scale, lam[rows] * self.objective_scale / linkage.scale

    def flown_trajectory_cost(self, solution: Solution) -> float:
        """The trajectory-level cost on the flown trajectory (:meth:`ocpkit.Solution.flown_trajectory_cost`)."""
        if self.phased.cost is None:
            return 0.0
        from ..flight import fly

        flown_ends: dict[int, np.ndarray] = {}
        ends = []
        for k, p in enumerate(solution.phases):
            x0 = np.array(p.initial_state(), dtype=float)
            for linked in self.phased.links:
                if linked.after == k and linked.before in flown_ends:
                    for i_before, i_after, _, jump in linked.states:
                        x0[i_after] = flown_ends[linked.before][i_before] + jump
            xf = fly(p, x0=x0).final_state
            flown_ends[k] = xf
            ends.append(np.concatenate([x0, xf, [p.t0, p.tf], p.problem.parameter_vector()]))
        return self.phased.trajectory_cost(np.concatenate(ends))

    # -- solving --------------------------------------------------------------------------------------------------------
    def solve(
        self,
        guess: Any = None,
        *,
        ipopt_options: dict[str, Any] | None = None,
        allow_acceptable: bool = False,
        raise_on_failure: bool = True,
        error_threshold: float | None = 1e-3,
        mesh_tolerance: float | None = None,
        max_mesh_iterations: int = 25,
        parameters: Mapping[str, float] | None = None,
        verdict: VerdictKind = "whole",
    ) -> Solution:
        """Solve with IPOPT from ``guess``: a :class:`~ocpkit.Solution`, with its whole verdict said.

        Parameters
        ----------
        guess : Guess, Solution or None
            A :class:`~ocpkit.Solution` of this same program is an exact warm start: its NLP vector and IPOPT's
            multipliers, with IPOPT's warm-start options (:data:`~ocpkit.nlp.WARM_START`); another solution is
            interpolated onto this mesh. Several phases take one guess per phase (a list, or a mapping by name), or
            a solution of as many phases, or one Guess or solution of the whole horizon, of which each phase takes
            its own window: a free junction time at the phase's own guess of it, the trajectory's start (a
            solution's) and end at the guess's. A Guess's functions of time follow the whole horizon; its ``(start,
            end)`` pairs, and the variables it does not name, run over each phase's window.
        ipopt_options : dict
            Overrides of :data:`ocpkit.nlp.DEFAULT_IPOPT_OPTIONS` (without the ``ipopt.`` prefix).
        allow_acceptable : bool
            Accept IPOPT's ``Solved_To_Acceptable_Level`` as success.
        raise_on_failure : bool
            True (default): a failed solve raises :class:`~ocpkit.SolverError` naming IPOPT's
            status, with the last iterate as ``error.result``. False: the last iterate is
            returned as a :class:`~ocpkit.Solution` with ``converged=False``.
        error_threshold : float or None
            The tolerance of the solution's :attr:`~ocpkit.Solution.verdict` (:mod:`ocpkit.verdict`): every part of
            the estimated error is computed and compared with it, one :class:`~ocpkit.accuracy.AccuracyWarning`
            per part over it, naming the part, its value and the remedy: the relative state error
            (:attr:`~ocpkit.Solution.state_error`, naming its interval), the objective's (the NLP's cost against
            the cost its control achieves when flown), each path constraint's violation between the scheme's points
            (in units of its scale); and one :class:`~ocpkit.verdict.SolutionNote` per note (a free time or
            parameter on its bound, a control on a bound over the whole horizon, an unbounded control held on its
            safeguard box; a state no function reads is noted in the verdict without a warning). The state's part
            is warned per phase, a phase's path constraints in one warning. None: a single solve computes and says
            nothing (the verdict is computed when asked for, at :data:`~ocpkit.verdict.DEFAULT_TOLERANCE`); a
            refinement (``mesh_tolerance``) says its own outcome and the notes.
        mesh_tolerance : float or None
            Refine the mesh (each phase's scheme's ``refine``, :meth:`refine`) until every part of the error
            estimate (:class:`~ocpkit.accuracy.Accuracy`: the state's, the objective's, each path constraint's
            violation between points) is at most this, at most ``max_mesh_iterations`` solves, each
            warm-started from the previous solution; the returned solution's ``mesh_history`` lists
            every iteration (and a warning names the parts if the tolerance is not met). Where the
            state meets the tolerance and another part does not, the next mesh cuts the intervals at
            their worst path violation, and refines to a tolerance tightened by the objective's
            excess. A failed solve on any mesh raises :class:`~ocpkit.SolverError` with the best
            solution before it (``error.best``); an estimate that stops falling while the mesh grows
            (:data:`~ocpkit.program.solve.STALL_MESHES`) stops the refinement with a warning saying so, naming a
            singular arc where a control enters linearly and an angle not declared periodic
            (:func:`~ocpkit.accuracy.refinement_hint`). Below 1e-6, IPOPT's bounds are relaxed by a hundredth of
            the tolerance, not its 1e-8 (:func:`~ocpkit.program.solve.refinement_ipopt_options`), unless
            ``ipopt_options`` sets ``bound_relax_factor``.
        max_mesh_iterations : int
            At most this many meshes (default 25: bang-bang and singular problems from coarse meshes
            take 13 to 20; a stalled refinement stops sooner).
        parameters : Mapping[str, float], optional
            New values of some of the phases' fixed parameters (:attr:`OptimalControlProblem.parameters
            <ocpkit.statement.problem.OptimalControlProblem.parameters>`) for this solve. They are NLP variables
            pinned by their bounds, so the NLP and the IPOPT instance are built once and reused for any values: a
            study of many values builds once. The solution's problem carries the values solved with.
        verdict : str
            ``"whole"`` (default): every part of the verdict. ``"fast"``: all but the objective's part, which costs
            an integration of the flown control (for loops and sliders); the verdict records that it skipped it
            (``verdict.skipped``, ``verdict.complete``, ``describe()``), and nothing is warned for it.
        """
        return policy.solve(
            self,
            guess,
            ipopt_options=ipopt_options,
            allow_acceptable=allow_acceptable,
            raise_on_failure=raise_on_failure,
            error_threshold=error_threshold,
            mesh_tolerance=mesh_tolerance,
            max_mesh_iterations=max_mesh_iterations,
            parameters=parameters,
            verdict=verdict,
        )

    def loop(
        self,
        *,
        ipopt_options: dict[str, Any] | None = None,
        allow_acceptable: bool = False,
        raise_on_failure: bool = True,
    ) -> SolveLoop:
        """A :class:`~ocpkit.program.loop.SolveLoop` of this program: many solves (parameter values, starts) at the
        cost of the IPOPT call, each result's Solution built only when asked for.

        ``loop(parameters, guess=...)`` returns a :class:`~ocpkit.program.loop.LoopResult` (the NLP's arrays, the
        objective, IPOPT's status and iterations; ``.solution`` the full Solution), equal to
        ``solve(guess, parameters=parameters, error_threshold=None)`` with the same options, to the last bit.
        """
        return SolveLoop(
            self, ipopt_options=ipopt_options, allow_acceptable=allow_acceptable, raise_on_failure=raise_on_failure
        )

    # -- refinement -------------------------------------------------------------------------------------------------------
    def estimate_counts(self, solution: Solution) -> list[int]:
        """Per phase, the intervals of a solution's error estimate (how :meth:`refine` splits its ``errors``)."""
        return [len(p.estimate_intervals) - 1 for p in solution.phases]

    def refine(
        self, errors: Sequence[np.ndarray], tolerance: float, cuts: Sequence[Sequence[np.ndarray] | None] | None = None
    ) -> Program:
        """The same statement with each phase's mesh refined by its scheme (rule 9 of
        :class:`~ocpkit.program.scheme.Scheme`) on its ``errors`` (one array per phase, per estimate interval,
        :meth:`estimate_counts`) and ``cuts`` (likewise); this very program where no scheme refines anything."""
        if len(errors) != len(self.phases):
            raise ValueError(f"{len(errors)} arrays of interval errors for {len(self.phases)} phases")
        per_cuts: Sequence[Sequence[np.ndarray] | None] = [None] * len(errors) if cuts is None else cuts
        schemes = [
            s.refine(np.asarray(e, dtype=float), tolerance, c) for s, e, c in zip(self.schemes, errors, per_cuts)
        ]
        if all(new is old for new, old in zip(schemes, self.schemes)):
            return self
        return Program(self.statement, dict(zip(self.names, schemes)), compile=self.compile)

    def uniform(self) -> Program:
        """The same statement with each phase on its scheme's uniform mesh (rule 10 of
        :class:`~ocpkit.program.scheme.Scheme`) of at least as many collocation points as it has here."""
        schemes = [s.uniform(p.n_defects // max(p.problem.nx, 1)) for s, p in zip(self.schemes, self.phases)]
        return Program(self.statement, dict(zip(self.names, schemes)), compile=self.compile)

    def __repr__(self) -> str:
        return f"Program({self.label}, {self.n_variables} variables, {self.n_constraints} constraints)"


__all__ = ["SHARED_COLUMN_POINTS", "Program"]
