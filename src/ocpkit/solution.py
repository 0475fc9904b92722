"""The result of a direct solve, for any number of phases: :class:`Solution`, made of :class:`PhaseSolution` s.

A :class:`Solution` is the whole NLP's answer: its status and statistics, its objective, the program that solved it
(:attr:`Solution.program`, an exact warm start of it) and the user's statement (:attr:`Solution.statement`), and one
:class:`PhaseSolution` per phase (:meth:`Solution.phase`), each a :class:`~ocpkit.trajectory.Trajectory` of its own
problem with the scheme's points, interpolants, costates and constraint values. A solution of one phase answers for
its phase too (``solution.state_values``, ``solution.costate(t)``: the phase's); a solution of several is one
trajectory over them (``state(t)``, ``sample``, ``reintegrate``: each time in its phase, the later one at a shared
time) where the phases share their states and controls.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, ClassVar, NoReturn, cast

import numpy as np

from ._arrays import unique
from ._deprecation import renamed
from .nlp import NLPResult
from .statement import OptimalControlProblem, declared_turn, wrap_periodic
from .trajectory import Reintegration, Trajectory
from .verdict import DEFAULT_TOLERANCE, Verdict

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure
    from numpy.typing import ArrayLike

    from .accuracy import Accuracy, MultiPhaseAccuracy
    from .program import Program
    from .statement.phases import LinkedStates, MultiPhaseProblem
    from .verdict import VerdictKind

__all__ = ["PhaseSolution", "Reintegration", "Solution", "SolveOptions"]


@dataclass
class PhaseSolution(Trajectory):
    """One phase of a :class:`Solution`: its problem's trajectory as its scheme gives it.

    ``name`` (the phase's), ``problem`` (the phase's problem with the parameter values solved with, its free
    parameters fixed at their solved values: everything done with the phase, interpolation and re-integration, uses
    them), ``statement`` (the problem as stated), ``transcription`` (the scheme's label), ``objective`` (the phase's
    share of the cost), ``t0`` and ``tf``, the NLP values at their times (``state_*``, ``control_*``), the scheme's
    interpolants, its mesh's ``breakpoints``, ``defect_equations`` and, for schemes that estimate them,
    ``costate_times`` and ``costate_values``.

    With path constraints: ``path_times`` (the points where the scheme enforces them,
    increasing), ``path_values`` (points, expressions) and ``path_multipliers`` (their
    KKT multipliers in the problem's units: positive where the upper bound is active,
    negative where the lower one is, zero where inactive; a discrete measure, whose sum
    over an interval estimates the integral of the continuous multiplier). With boundary
    constraints: ``boundary_values`` and ``boundary_multipliers``. Columns and entries
    follow ``problem.functions.path.labels`` and ``.boundary.labels``; :meth:`constraint`
    and :meth:`path_dataframe` select by name.
    """

    #: a phase's own share of the cost, not the whole solution's objective
    objective_label: ClassVar[str] = "the phase's own cost"
    name: str
    problem: OptimalControlProblem
    statement: OptimalControlProblem
    transcription: str
    objective: float
    t0: float
    tf: float
    defect_equations: int
    state_times: np.ndarray
    state_values: np.ndarray
    control_times: np.ndarray
    control_values: np.ndarray
    breakpoints: np.ndarray
    state_interpolant: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    control_interpolant: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    costate_times: np.ndarray | None = field(default=None, repr=False)
    costate_values: np.ndarray | None = field(default=None, repr=False)
    path_times: np.ndarray | None = field(default=None, repr=False)
    path_values: np.ndarray | None = field(default=None, repr=False)
    #: the KKT multipliers of the path constraints at ``path_times`` (points, expressions), in the problem's units
    #: (positive where the upper bound is active, negative where the lower one is, zero where inactive; a discrete
    #: measure, whose sum over an interval estimates the integral of the continuous multiplier)
    path_multipliers: np.ndarray | None = field(default=None, repr=False)
    boundary_values: np.ndarray | None = field(default=None, repr=False)
    boundary_multipliers: np.ndarray | None = field(default=None, repr=False)
    estimate_breakpoints: np.ndarray | None = field(default=None, repr=False)
    estimate_points: np.ndarray | int | None = field(default=None, repr=False)
    #: the phase's solved free parameters (:class:`~ocpkit.FreeParameter`) by name; the problem's constants, and
    #: these fixed at their solved values, are ``problem.parameters``
    parameters: dict[str, float] = field(default_factory=dict)
    #: the control values, by name, that the phase's periodic controls start nearest (whole periods apart), so that
    #: it continues the phase before it; the ones not given start in their declared turn (:attr:`~ocpkit.Control.period`)
    control_start: dict[str, float] = field(default_factory=dict, repr=False)

    # -- accuracy ---------------------------------------------------------------------
    @cached_property
    def interval_errors(self) -> np.ndarray:
        """Relative state error estimate on each mesh interval (:mod:`ocpkit.accuracy`, Patterson-Hager-Rao)."""
        from .accuracy import interval_errors

        return interval_errors(self, self.estimate_points, self.estimate_intervals)

    @property
    def estimate_intervals(self) -> np.ndarray:
        """The intervals of :attr:`interval_errors` (the scheme's segments, or its fine segments)."""
        return self.breakpoints if self.estimate_breakpoints is None else self.estimate_breakpoints

    @property
    def state_error(self) -> float:
        """The largest of :attr:`interval_errors`, the phase's estimated relative state error: the state part of
        the solution's :attr:`~Solution.verdict` (the other parts, the objective's and the path constraints', are
        in :attr:`accuracy`)."""
        return float(self.interval_errors.max())

    @property
    def error_estimate(self) -> float:
        """Deprecated name of :attr:`state_error` (the state part of the verdict; every part is in the solution's
        :attr:`~Solution.verdict`)."""
        renamed("PhaseSolution.error_estimate", "PhaseSolution.state_error")
        return self.state_error

    @cached_property
    def accuracy(self) -> Accuracy:
        """Every part of the phase's estimated error (:class:`ocpkit.accuracy.Accuracy`), the state's, the
        objective's (the cost its admissible control achieves against the NLP's) and each path constraint's
        largest violation between the scheme's points."""
        from .accuracy import Accuracy

        return Accuracy(self)

    # -- the trajectory -------------------------------------------------------------
    def _state(self, t: np.ndarray) -> np.ndarray:
        return self.state_interpolant(t)

    def _control(self, t: np.ndarray) -> np.ndarray:
        """The transcription's control interpolant, projected onto the control bounds, its periodic controls as
        continuous angles (:attr:`control_turns`).

        Between its parameters a polynomial control can overshoot a bound it
        touches (and an LGR control, extrapolated past the last collocation point,
        can leave it); the projection gives the only values the dynamics admit.
        """
        raw = self.control_interpolant(t)
        values = self.admissible(raw)
        angles = [j for j, c in enumerate(self.problem.controls) if declared_turn(c) is not None]
        if angles:
            breaks = self.control_breakpoints
            piece = np.clip(np.searchsorted(breaks, t, side="right") - 1, 0, breaks.size - 2)
            values[..., angles] = raw[..., angles] + self.control_turns[piece][..., angles]
        return values

    @cached_property
    def control_turns(self) -> np.ndarray:
        """What the control interpolant's pieces (between :attr:`control_breakpoints`) are moved by to report the
        periodic controls as continuous angles (:attr:`~ocpkit.Control.period`): whole periods, shape ``(pieces,
        controls)``, zero for the other controls. Each piece starts within half a period of where the one before
        ends; the first starts in the control's declared turn (:func:`~ocpkit.statement.declared_turn`), or
        nearest its :attr:`control_start`."""
        breaks = self.control_breakpoints
        controls = self.problem.controls
        turns = np.zeros((breaks.size - 1, len(controls)))
        if not any(declared_turn(c) is not None for c in controls):
            return turns
        starts = self.control_interpolant(breaks[:-1])  # each piece at its left end
        ends = self.control_interpolant(np.nextafter(breaks[1:], -np.inf))  # each piece at its right end
        for j, c in enumerate(controls):
            a = declared_turn(c)
            if a is None:
                continue
            period = cast(float, c.period)  # (a declared turn is a periodic control's)
            first = starts[0, j]
            if c.name in self.control_start:
                shift = np.round((self.control_start[c.name] - first) / period)
            else:
                shift = -np.floor((first - a) / period)
            steps = np.round((ends[:-1, j] - starts[1:, j]) / period)
            turns[:, j] = period * (shift + np.concatenate([[0.0], np.cumsum(steps)]))
        return turns

    def admissible(self, values: ArrayLike) -> np.ndarray:
        """Control values (last axis: the controls) as the dynamics admit them: a periodic control
        (:attr:`~ocpkit.Control.period`) with a finite bound and bounds at least a period apart moved by whole
        periods into its declared turn (:func:`~ocpkit.statement.wrap_periodic`), then every control clipped to its
        bounds. (:meth:`~ocpkit.trajectory.Trajectory.control` reports a periodic control as a continuous angle instead, the same angle.)"""
        lo, hi = self._control_bounds
        return np.clip(wrap_periodic(values, self.problem.controls), lo, hi)

    @property
    def control_breakpoints(self) -> np.ndarray:
        """Where the control interpolant's pieces meet (the mesh's breakpoints, or a finer control mesh's)."""
        raw = self.control_interpolant
        for breaks in (getattr(raw, "breaks", None), getattr(getattr(raw, "poly", None), "x", None)):
            if breaks is not None:
                return np.asarray(breaks, dtype=float)
        return np.asarray(self.breakpoints, dtype=float)

    def _raw_control(self, t: ArrayLike) -> np.ndarray:
        return self.control_interpolant(self._check_times(t))

    def initial_state(self) -> np.ndarray:
        return self.state_values[0].astype(float)

    @property
    def has_costates(self) -> bool:
        return self.costate_values is not None

    def _costate(self, t: ArrayLike) -> np.ndarray:
        """Costate estimates, linear between their points (transcriptions that provide them, e.g. Radau)."""
        if self.costate_values is None:
            raise ValueError(f"{self.transcription} provides no costate estimates")
        t = np.asarray(t, dtype=float)
        times = cast(np.ndarray, self.costate_times)  # given with the values
        cols = [np.interp(t.ravel(), times, self.costate_values[:, j]) for j in range(self.costate_values.shape[1])]
        return np.stack(cols, axis=-1).reshape(t.shape + (len(cols),))

    @cached_property
    def _control_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        controls = self.problem.controls
        return np.array([c.lower for c in controls]), np.array([c.upper for c in controls])

    # -- tables ---------------------------------------------------------------------
    def costates_dataframe(self) -> pd.DataFrame:
        """Costate estimates at their points (transcriptions that provide them, e.g. Radau)."""
        import pandas as pd

        if self.costate_values is None:
            raise ValueError(f"{self.transcription} provides no costate estimates")
        df = pd.DataFrame(self.costate_values, columns=[f"lambda_{n}" for n in self.problem.state_names])
        df.insert(0, "t", self.costate_times)
        return df

    def constraint(self, name: str) -> dict[str, Any]:
        """One constraint by name: ``{"values", "multipliers", "lower", "upper"}`` (and the times ``"t"`` of a
        path constraint), one column per expression of the constraint."""
        functions = self.problem.functions
        for kind in ("path", "boundary"):
            cs = getattr(functions, kind)
            if cs is None or name not in cs.names:
                continue
            i = cs.names.index(name)
            start = int(sum(cs.sizes[:i]))
            cols = slice(start, start + cs.sizes[i])
            out = {"lower": cs.lower[cols], "upper": cs.upper[cols]}
            # a solution of a problem with constraints of this kind has their values and multipliers
            if kind == "path":
                values, multipliers = cast(np.ndarray, self.path_values), cast(np.ndarray, self.path_multipliers)
                out.update(t=self.path_times, values=values[:, cols], multipliers=multipliers[:, cols])
            else:
                values, multipliers = (
                    cast(np.ndarray, self.boundary_values),
                    cast(np.ndarray, self.boundary_multipliers),
                )
                out.update(values=values[cols], multipliers=multipliers[cols])
            return out
        raise KeyError(f"no constraint {name!r}; the problem's constraints are {self.constraint_names}")

    @property
    def constraint_names(self) -> list[str]:
        """The names of the phase's path and boundary constraints."""
        functions = self.problem.functions
        return [n for kind in ("path", "boundary") if getattr(functions, kind) for n in getattr(functions, kind).names]

    def path_dataframe(self) -> pd.DataFrame:
        """Path constraints at their points: ``t``, each expression's value and its multiplier (``mu_<label>``)."""
        import pandas as pd

        cs = self.problem.functions.path
        if cs is None:
            raise ValueError(f"{self.problem.name!r} has no path constraints")
        df = pd.DataFrame(self.path_values, columns=cs.labels)
        for j, label in enumerate(cs.labels):
            df[f"mu_{label}"] = cast(np.ndarray, self.path_multipliers)[:, j]
        df.insert(0, "t", self.path_times)
        return df

    def nodes_dataframe(self) -> pd.DataFrame:
        """NLP state parameters at their nodes."""
        import pandas as pd

        df = pd.DataFrame(self.state_values, columns=self.problem.state_names)
        df.insert(0, "t", self.state_times)
        return df


@dataclass(frozen=True)
class SolveOptions:
    """How a solution was solved, so that the same NLP can be solved again as it was: the IPOPT option overrides and
    whether IPOPT's acceptable level was accepted."""

    ipopt_options: Mapping[str, Any] = field(default_factory=dict)
    allow_acceptable: bool = False

    def as_kwargs(self) -> dict[str, Any]:
        """The options as ``solve``'s keyword arguments."""
        return {"ipopt_options": dict(self.ipopt_options), "allow_acceptable": self.allow_acceptable}


def _readonly(name: str) -> Callable[[Any, Any], NoReturn]:
    def setter(self: Any, value: Any) -> NoReturn:
        raise AttributeError(f"a solution's {name} is its phases': it cannot be set")

    return setter


@dataclass(eq=False)
class Solution(Trajectory):
    """A direct solve's result, for any number of phases (module docstring).

    ``status`` (IPOPT's), ``converged`` (whether the solve succeeded: a solve raises on failure unless asked to
    return the last iterate, :meth:`ocpkit.program.Program.solve`), ``iterations``, ``objective`` (in the problem's
    units: the phases' costs and the trajectory's), ``decision_variables`` (the NLP's free variables, Desai &
    Conway's "NLP parameters"), ``constraints``, ``build_s`` and ``solve_s`` (wall times); ``phases`` (one
    :class:`PhaseSolution` each), ``program`` (the :class:`~ocpkit.program.Program` solved: a solution of it is its
    exact warm start), ``nlp_result`` (the NLP vector, IPOPT's multipliers and statistics), ``parameters`` (the solved
    free parameters of the trajectory, each shared one once), ``link_residual`` (the largest scaled violation of the
    links and linkage constraints), ``trajectory_cost`` (the trajectory-level cost's value), ``solve_options`` and
    ``linear_solver`` (how it was solved), and, after a refinement, ``mesh_history``, ``refinement_outcome`` and
    ``refinement_reason``.

    A solution of one phase also answers for its phase: every field and method of :class:`PhaseSolution`
    (``state_values``, ``costate_values``, ``path_times``, ``interval_errors``, ``constraint(name)``, ...) is the
    phase's.
    """

    #: one solution per phase
    phases: list[PhaseSolution]
    #: the program solved (a solution of it is its exact warm start)
    program: Program = field(repr=False)
    #: IPOPT's return status
    status: str
    iterations: int
    objective: float
    #: the NLP's free variables (Desai & Conway's "NLP parameters"; ``nlp_parameters`` is its deprecated name)
    decision_variables: int
    constraints: int
    build_s: float
    #: the wall time of the IPOPT solve, in seconds
    solve_s: float
    converged: bool
    #: the NLP's last iterate and IPOPT's multipliers and statistics (scaled NLP)
    nlp_result: NLPResult = field(repr=False)
    #: the solved free parameters of the trajectory by name (each shared one once); a phase's, phase(name).parameters
    parameters: dict[str, float] = field(default_factory=dict)
    link_residual: float = 0.0
    trajectory_cost: float = 0.0
    #: how it was solved (IPOPT's option overrides, the acceptable level), to solve the same NLP again as it was
    solve_options: SolveOptions | None = field(default=None, repr=False)
    #: IPOPT's linear solver and its ordering in this solve (e.g. ``"mumps (QAMD ordering)"``; chosen by the
    #: transcription's structure, :attr:`~ocpkit.Radau.ipopt_defaults`); ``""`` where not recorded
    linear_solver: str = field(default="", repr=False)
    mesh_history: list[Any] | None = field(default=None, repr=False)
    #: how a refinement (``solve(mesh_tolerance=...)``) ended, ``"met"`` (every part of the estimate within the
    #: tolerance), ``"stalled"``, ``"stopped"`` (the next mesh would have been this one), ``"not met"`` (out of
    #: meshes) or ``"failed"`` (the last mesh's solve did not succeed, with ``raise_on_failure=False``); None for a
    #: single solve. ``refinement_reason``: the warning's text that said so ("" where met).
    refinement_outcome: str | None = field(default=None, repr=False)
    refinement_reason: str = field(default="", repr=False)
    #: the tolerance and kind of the solve's :attr:`verdict` (its ``error_threshold``, or a refinement's
    #: ``mesh_tolerance``; ``solve(verdict=...)``)
    verdict_tolerance: float = field(default=DEFAULT_TOLERANCE, repr=False)
    verdict_kind: VerdictKind = field(default="whole", repr=False)
    #: the unbounded controls the solve held on the box of a runaway (:mod:`ocpkit.program.safeguard`), name -> the
    #: box's limit: the solution is the bounded problem's there, which its verdict notes
    held_controls: dict[str, float] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        if not self.phases:
            raise ValueError("a solution has at least one phase")
        periodic = any(declared_turn(c) is not None for p in self.phases for c in p.problem.controls)
        for before, phase in zip(self.phases, self.phases[1:]) if periodic else ():
            # a periodic control continues from the phase before, where both declare it periodic
            end = before._control(np.array([before.tf]))[0]
            names = before.problem.control_names
            phase.control_start = {
                c.name: float(end[names.index(c.name)])
                for c in phase.problem.controls
                if c.name in names
                and declared_turn(c) is not None
                and declared_turn(before.problem.controls[names.index(c.name)]) is not None
            }
            phase.__dict__.pop("control_turns", None)  # computed, if at all, without its start

    # -- the program and the statement -----------------------------------------------------------------------------
    @property
    def statement(self) -> OptimalControlProblem | MultiPhaseProblem:
        """The problem as the user stated it (an :class:`~ocpkit.OptimalControlProblem`, or the
        :class:`~ocpkit.statement.phases.MultiPhaseProblem` of several phases): free parameters free, the parameter
        values as stated."""
        return self.program.statement

    @property
    def names(self) -> list[str]:
        """The phases' names."""
        return [p.name for p in self.phases]

    def phase(self, key: str | int) -> PhaseSolution:
        """A phase's solution by name or index."""
        if isinstance(key, str):
            if key not in self.names:
                raise KeyError(f"unknown phase {key!r}; the phases are {self.names}")
            return self.phases[self.names.index(key)]
        return self.phases[key]

    @property
    def links(self) -> list[LinkedStates]:
        """The program's links between phases, resolved (indices, states and jumps)."""
        return list(self.program.phased.links)

    @property
    def objective_scale(self) -> float:
        """The NLP minimises ``J / objective_scale``."""
        return self.program.objective_scale

    def _only(self, what: str) -> PhaseSolution:
        """The phase of a one-phase solution (``what``: the field asked for, named in the error otherwise)."""
        if len(self.phases) != 1:
            raise AttributeError(
                f"a solution of {len(self.phases)} phases has a {what} per phase: ask phase(name).{what} "
                f"(the phases are {self.names})"
            )
        return self.phases[0]

    @property
    def single(self) -> bool:
        """Whether the solution is its one phase's (a single-phase problem's, with one phase and no cost or linkage
        constraint of the trajectory)."""
        return self.program.plain

    # -- what is the one phase's: the trajectory's definition --------------------------------------------------------
    @property
    def problem(self) -> OptimalControlProblem:
        """The problem of a one-phase solution, with the parameter values solved with and its free parameters fixed
        at their solved values; of several phases cut from one problem (:meth:`Program.split
        <ocpkit.program.Program.split>`), that problem so (otherwise ``phase(name).problem``; the statement:
        :attr:`statement`)."""
        if self.single:
            return self.phases[0].problem
        return self._source_problem

    @problem.setter
    def problem(self, value: OptimalControlProblem) -> NoReturn:
        _readonly("problem")(self, value)

    @cached_property
    def _source_problem(self) -> OptimalControlProblem:
        source = self.program.phased.source
        if source is None:
            self._only("problem")  # raises, naming the phases
        pr = cast(OptimalControlProblem, source)
        first = self.phases[0]
        pinned = {n: first.problem.parameters[n] for n in pr.parameters}
        if pinned != pr.parameters:
            pr = pr.replace(parameters=pinned)
        if pr.free_parameters:
            pr = pr.fix_parameters(
                {v.name: self.parameters.get(v.name, first.parameters[v.name]) for v in pr.free_parameters}
            )
        return pr

    @property
    def t0(self) -> float:
        """The initial time (of the first phase)."""
        return self.phases[0].t0

    @t0.setter
    def t0(self, value: float) -> NoReturn:
        _readonly("t0")(self, value)

    @property
    def tf(self) -> float:
        """The final time (of the last phase)."""
        return self.phases[-1].tf

    @tf.setter
    def tf(self, value: float) -> NoReturn:
        _readonly("tf")(self, value)

    @property
    def breakpoints(self) -> np.ndarray:
        """Where the control may jump, the mesh's breakpoints (every phase's)."""
        if self.single:
            return self.phases[0].breakpoints
        return unique(np.concatenate([p.breakpoints for p in self.phases]))

    @breakpoints.setter
    def breakpoints(self, value: np.ndarray) -> NoReturn:
        _readonly("breakpoints")(self, value)

    @property
    def transcription(self) -> str:
        """The scheme's label (of several phases, the program's)."""
        return self.phases[0].transcription if self.single else self.program.label

    @property
    def defect_equations(self) -> int:
        return int(sum(p.defect_equations for p in self.phases))

    # -- the one phase's fields (PhaseSolution's) ------------------------------------------------------------------------
    @property
    def state_times(self) -> np.ndarray:
        """The one phase's ``state_times`` (:class:`PhaseSolution`), the times of the state points."""
        return self._only("state_times").state_times

    @property
    def state_values(self) -> np.ndarray:
        """The one phase's ``state_values`` (:class:`PhaseSolution`), the states at their points."""
        return self._only("state_values").state_values

    @property
    def control_times(self) -> np.ndarray:
        """The one phase's ``control_times`` (:class:`PhaseSolution`), the times of the control points."""
        return self._only("control_times").control_times

    @property
    def control_values(self) -> np.ndarray:
        """The one phase's ``control_values`` (:class:`PhaseSolution`), the controls at their points."""
        return self._only("control_values").control_values

    @property
    def state_interpolant(self) -> Callable[[np.ndarray], np.ndarray]:
        """The one phase's ``state_interpolant`` (:class:`PhaseSolution`), the scheme's state interpolant (a function of time)."""
        return self._only("state_interpolant").state_interpolant

    @property
    def control_interpolant(self) -> Callable[[np.ndarray], np.ndarray]:
        """The one phase's ``control_interpolant`` (:class:`PhaseSolution`), the scheme's control interpolant, overshoots included."""
        return self._only("control_interpolant").control_interpolant

    @property
    def costate_times(self) -> np.ndarray | None:
        """The one phase's ``costate_times`` (:class:`PhaseSolution`), the times of the costate estimates."""
        return self._only("costate_times").costate_times

    @property
    def costate_values(self) -> np.ndarray | None:
        """The one phase's ``costate_values`` (:class:`PhaseSolution`), the costate estimates."""
        return self._only("costate_values").costate_values

    @property
    def path_times(self) -> np.ndarray | None:
        """The one phase's ``path_times`` (:class:`PhaseSolution`), the times of the path-constraint points."""
        return self._only("path_times").path_times

    @property
    def path_values(self) -> np.ndarray | None:
        """The one phase's ``path_values`` (:class:`PhaseSolution`), the path constraints at their points."""
        return self._only("path_values").path_values

    @property
    def path_multipliers(self) -> np.ndarray | None:
        """The one phase's ``path_multipliers`` (:class:`PhaseSolution`), the path constraints' multipliers, in the problem's units."""
        return self._only("path_multipliers").path_multipliers

    @property
    def boundary_values(self) -> np.ndarray | None:
        """The one phase's ``boundary_values`` (:class:`PhaseSolution`), the boundary constraints' values."""
        return self._only("boundary_values").boundary_values

    @property
    def boundary_multipliers(self) -> np.ndarray | None:
        """The one phase's ``boundary_multipliers`` (:class:`PhaseSolution`), the boundary constraints' multipliers, in the problem's units."""
        return self._only("boundary_multipliers").boundary_multipliers

    @property
    def estimate_breakpoints(self) -> np.ndarray | None:
        """The one phase's ``estimate_breakpoints`` (:class:`PhaseSolution`), the error estimate's intervals where they are not the mesh's."""
        return self._only("estimate_breakpoints").estimate_breakpoints

    @property
    def estimate_points(self) -> np.ndarray | int | None:
        """The one phase's ``estimate_points`` (:class:`PhaseSolution`), the error estimate's points per interval."""
        return self._only("estimate_points").estimate_points

    @property
    def estimate_intervals(self) -> np.ndarray:
        """The one phase's ``estimate_intervals`` (:class:`PhaseSolution`), the intervals of the error estimate."""
        return self._only("estimate_intervals").estimate_intervals

    @property
    def control_breakpoints(self) -> np.ndarray:
        """The one phase's ``control_breakpoints`` (:class:`PhaseSolution`), where the control interpolant's pieces meet."""
        return self._only("control_breakpoints").control_breakpoints

    def admissible(self, values: ArrayLike) -> np.ndarray:
        """The one phase's :meth:`PhaseSolution.admissible`."""
        return self._only("admissible").admissible(values)

    def costates_dataframe(self) -> pd.DataFrame:
        """The one phase's :meth:`PhaseSolution.costates_dataframe`."""
        return self._only("costates_dataframe").costates_dataframe()

    def nodes_dataframe(self) -> pd.DataFrame:
        """The one phase's :meth:`PhaseSolution.nodes_dataframe`."""
        return self._only("nodes_dataframe").nodes_dataframe()

    # -- the NLP ---------------------------------------------------------------------------------------------------------
    @property
    def nlp_parameters(self) -> int:
        """Deprecated name of :attr:`decision_variables`."""
        renamed("Solution.nlp_parameters", "Solution.decision_variables")
        return self.decision_variables

    @property
    def raw(self) -> dict[str, Any]:
        """The typed fields :attr:`nlp_result` (``w``, ``lam_g``, ``lam_w``, ``stats``), :attr:`program`,
        :attr:`solve_options` and :attr:`linear_solver` as the dict that held them (deprecated)."""
        renamed("Solution.raw", "Solution.nlp_result, .program, .solve_options, .linear_solver")
        r = self.nlp_result
        program = self.program  # a bound scheme was its own transcription object: the scheme, as before
        bound = program.plain and getattr(program.scheme, "problem", None) is not None
        out: dict[str, Any] = {
            "w": r.w,
            "lam_g": r.lam_g,
            "lam_w": r.lam_w,
            "stats": r.stats,
            "transcription": program.scheme if bound else program,
        }
        if self.solve_options is not None:
            out["solve_options"] = self.solve_options.as_kwargs()
        if self.linear_solver:
            out["linear_solver"] = self.linear_solver
        return out

    def summary(self) -> dict[str, Any]:
        """Key numbers, JSON-serialisable."""
        problem = self.phases[0].problem.name if self.single else [p.problem.name for p in self.phases]
        out = {
            "problem": problem,
            "transcription": self.transcription,
            "status": self.status,
            "objective": self.objective,
            "tf": self.tf,
            "nlp_parameters": self.decision_variables,
            "defect_equations": self.defect_equations,
            "constraints": self.constraints,
            "iterations": self.iterations,
            "build_s": self.build_s,
            "solve_s": self.solve_s,
        }
        if not self.single:
            out["phases"] = self.names
            out["link_residual"] = self.link_residual
        return out

    # -- accuracy ---------------------------------------------------------------------------------------------------------
    @property
    def interval_errors(self) -> np.ndarray:
        """Every phase's :attr:`PhaseSolution.interval_errors`, in phase order."""
        if self.single:
            return self.phases[0].interval_errors
        return np.concatenate([p.interval_errors for p in self.phases])

    @property
    def state_error(self) -> float:
        """The largest of the phases' estimated relative state errors (:attr:`PhaseSolution.state_error`): the
        state part of the :attr:`verdict`."""
        return float(np.max([p.state_error for p in self.phases]))  # (NaN in any phase is NaN)

    @property
    def error_estimate(self) -> float:
        """Deprecated; the state part of the verdict is :attr:`state_error`, every part is in :attr:`verdict`."""
        renamed("Solution.error_estimate", "Solution.state_error (every part of the error: Solution.verdict)")
        return self.state_error

    @cached_property
    def verdict(self) -> Verdict:
        """The whole verdict of the solve (:class:`ocpkit.verdict.Verdict`): every part of the estimated error
        (state, objective, each path constraint's violation between points) against the solve's
        ``error_threshold`` (:data:`~ocpkit.verdict.DEFAULT_TOLERANCE` where it gave none; a refinement's
        ``mesh_tolerance``), whether it ``passed``, and its notes (a free time or parameter on its bound, a control
        on a bound over the whole horizon, a state no function reads). ``solve(verdict="fast")``: all but the
        objective's part, which the verdict says it skipped (:meth:`judge` computes any verdict)."""
        return self.judge(self.verdict_tolerance, self.verdict_kind)

    def judge(self, tolerance: float | None = None, kind: VerdictKind = "whole") -> Verdict:
        """A :class:`~ocpkit.verdict.Verdict` of this solution at ``tolerance`` (default the solve's), ``kind``
        ``"whole"`` (every part) or ``"fast"`` (all but the objective's)."""
        return Verdict(self, self.verdict_tolerance if tolerance is None else tolerance, kind)

    @cached_property
    def accuracy(self) -> Accuracy | MultiPhaseAccuracy:
        """Every part of the estimated error (:class:`ocpkit.accuracy.Accuracy`; over several phases,
        :class:`ocpkit.accuracy.MultiPhaseAccuracy`)."""
        if self.single:
            return self.phases[0].accuracy
        from .accuracy import MultiPhaseAccuracy

        return MultiPhaseAccuracy(self)

    def plot_refinement(self, *, figsize: tuple[float, float] | None = None, fig: Figure | None = None) -> Figure:
        """A matplotlib figure of the refinement that gave this solution (``mesh_history``): each mesh's
        intervals and collocation points, its error estimate against the refinement's tolerance (logarithmic), and
        its interval boundaries over normalised time, one row of ticks per mesh (:mod:`ocpkit.plotting`).
        ``figsize``: inches; ``fig``: an empty figure or subfigure to draw into."""
        from .plotting import refinement_figure

        if not self.mesh_history:
            raise ValueError(
                "this solution has no mesh history (it was solved on one mesh): solve with a mesh tolerance, e.g. "
                "solve(mesh_tolerance=1e-6), to refine the mesh and record each iteration"
            )
        name = self.problem.name if self.single else "phases " + ", ".join(self.names)
        title = f"mesh refinement of {name}, {self.transcription}: {self.refinement_outcome}"
        return refinement_figure(self.mesh_history, self.verdict_tolerance, title=title, figsize=figsize, fig=fig)

    # -- constraints ---------------------------------------------------------------------------------------------------------
    def constraint(self, name: str) -> dict[str, Any]:
        """A constraint by name: a phase's path or boundary constraint (:meth:`PhaseSolution.constraint`; one that
        several phases state, over all of them in time order, with ``"phase"`` naming each point's), or a linkage
        constraint of the trajectory (``{"values", "multipliers", "lower", "upper"}``)."""
        if self.single:
            return self.phases[0].constraint(name)
        found = [(p.name, p.constraint(name)) for p in self.phases if name in p.constraint_names]
        if found:
            if len(found) == 1:
                return found[0][1]
            out = {"lower": found[0][1]["lower"], "upper": found[0][1]["upper"]}
            for key in ("t", "values", "multipliers"):
                if key in found[0][1]:
                    out[key] = np.concatenate([np.atleast_1d(part[key]) for _, part in found])
            out["phase"] = np.concatenate(
                [np.full(np.shape(np.atleast_1d(part["values"]))[0], phase) for phase, part in found]
            )
            return out
        linkage = self.program.phased.linkage
        if linkage is not None and name in linkage.names:
            i = linkage.names.index(name)
            start = int(sum(linkage.sizes[:i]))
            cols = slice(start, start + linkage.sizes[i])
            values, multipliers = self.program.linkage_values(self.nlp_result)
            return {
                "values": values[cols],
                "multipliers": multipliers[cols],
                "lower": linkage.lower[cols],
                "upper": linkage.upper[cols],
            }
        known = sorted({n for p in self.phases for n in p.constraint_names} | set(linkage.names if linkage else ()))
        raise KeyError(f"no constraint {name!r}; the constraints are {known}")

    def path_dataframe(self) -> pd.DataFrame:
        """Path constraints at their points (:meth:`PhaseSolution.path_dataframe`); of several phases, every phase
        with path constraints, in time order, with a ``phase`` column."""
        if self.single:
            return self.phases[0].path_dataframe()
        import pandas as pd

        parts = []
        for p in self.phases:
            if p.problem.functions.path is None:
                continue
            df = p.path_dataframe()
            df.insert(0, "phase", p.name)
            parts.append(df)
        if not parts:
            raise ValueError(f"no phase of {self.names} has path constraints")
        return pd.concat(parts, ignore_index=True)

    # -- the trajectory over the phases ---------------------------------------------------------------------------------
    @property
    def uniform(self) -> bool:
        """Whether every phase has the first's states and controls (then the phases make one trajectory)."""
        return self.program.phased.uniform

    @property
    def state_names(self) -> list[str]:
        """The states' names (the phases'; they must share them)."""
        self._require_uniform()
        return self.phases[0].state_names

    @property
    def control_names(self) -> list[str]:
        """The controls' names (the phases'; they must share them)."""
        self._require_uniform()
        return self.phases[0].control_names

    def _require_uniform(self) -> None:
        if not self.uniform:
            raise ValueError("the phases have different states or controls: evaluate phase(name) instead")

    def _phase_of(self, t: np.ndarray) -> np.ndarray:
        starts = np.array([p.t0 for p in self.phases])
        return np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.phases) - 1)

    def _piecewise(self, t: np.ndarray, what: str) -> np.ndarray:
        """``what`` (``"state"``, ``"control"``, ``"costate"``, ``"_raw_control"``) at the times ``t``, each time in its
        phase (the later one at a shared time)."""
        self._require_uniform()
        t = np.asarray(t, dtype=float)
        flat = t.ravel()
        k = self._phase_of(flat)
        first = self.phases[0]
        dim = getattr(first, what)(np.array([first.t0])).shape[-1]
        out = np.empty((flat.size, dim))
        for j in unique(k):
            ph = self.phases[j]
            sel = k == j
            out[sel] = getattr(ph, what)(np.clip(flat[sel], ph.t0, ph.tf))
        return out.reshape(t.shape + (dim,))

    def _state(self, t: np.ndarray) -> np.ndarray:
        return self.phases[0]._state(t) if self.single else self._piecewise(t, "state")

    def _control(self, t: np.ndarray) -> np.ndarray:
        return self.phases[0]._control(t) if self.single else self._piecewise(t, "control")

    def _raw_control(self, t: ArrayLike) -> np.ndarray:
        if self.single:
            return self.phases[0]._raw_control(t)
        return self._piecewise(self._check_times(t), "_raw_control")

    @property
    def has_costates(self) -> bool:
        return all(p.has_costates for p in self.phases)

    def _costate(self, t: np.ndarray) -> np.ndarray:
        if self.single:
            return self.phases[0]._costate(t)
        missing = [p.name for p in self.phases if not p.has_costates]
        if missing:
            raise ValueError(f"phases {missing} provide no costate estimates ({self.transcription})")
        return self._piecewise(t, "costate")

    def initial_state(self) -> np.ndarray:
        return self.phases[0].initial_state()

    def sample(
        self, expr: Callable[..., Any], grid: ArrayLike | None = None, n: int = 401
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(t, values)`` of ``expr(x, u, t[, p])`` (:meth:`Trajectory.sample`), each time in its phase (the later one
        at a shared time), each phase with its own variables and parameters and the trajectory's
        (:attr:`parameters`)."""
        if self.single:
            return self.phases[0].sample(expr, grid, n)
        t = self.time_grid(n) if grid is None else self._check_times(grid)
        if t.size == 0:
            return t, self.phases[0].evaluate(expr, t, self.parameters)
        flat = t.ravel()
        k = self._phase_of(flat)
        parts = {
            j: self.phases[j].evaluate(
                expr, np.clip(flat[k == j], self.phases[j].t0, self.phases[j].tf), self.parameters
            )
            for j in unique(k)
        }
        first = next(iter(parts.values()))
        out = np.empty((flat.size,) + first.shape[1:])
        for j, values in parts.items():
            out[k == j] = values
        return t, out.reshape(t.shape + first.shape[1:])

    def value(self, what: str | Callable[..., Any]) -> float | np.ndarray:
        """A number of this solution (:meth:`Trajectory.value`): a parameter's value by name (the trajectory's,
        then the first phase's fixed ones), ``"t0"``, ``"tf"``, ``"objective"``, or ``what(x0, xf, t0, tf[, p])``
        written as a Mayer term is, ``x0`` the first phase's initial state and ``xf`` the last phase's final one."""
        if self.single:
            return self.phases[0].value(what)
        if isinstance(what, str) and what in self.parameters:
            return float(self.parameters[what])
        first, last = self.phases[0], self.phases[-1]
        if isinstance(what, str):
            return first.value(what)
        extra = {k: v for k, v in self.parameters.items() if k not in first.problem.parameter_names}
        fun = first.problem.expression(what, "boundary", "value's expression", list(extra))
        P = np.concatenate([first.problem.parameter_vector(), np.array(list(extra.values()), dtype=float)])
        x0, xf = first.state(np.array(first.t0)), last.state(np.array(last.tf))
        out = np.asarray(fun(x0, xf, self.t0, self.tf, P)).ravel()
        return float(out[0]) if out.size == 1 else out

    def to_dataframe(self, t: ArrayLike | None = None, n: int = 401, costates: bool = False) -> pd.DataFrame:
        """:meth:`Trajectory.to_dataframe` over the phases (the one phase's for a one-phase solution)."""
        if self.single:
            return self.phases[0].to_dataframe(t, n, costates)
        return super().to_dataframe(t, n, costates)

    def reintegrate(
        self, rtol: float = 1e-12, atol: float = 1e-12, n: int = 2001, controls: str = "bounded"
    ) -> Reintegration:
        """Each phase re-integrated from its own initial state (a link may jump), as one
        :class:`~ocpkit.Reintegration` over the phases' times (phases with the same states; otherwise
        ``phase(name).reintegrate()``). ``n`` points per phase."""
        if self.single:
            return self.phases[0].reintegrate(rtol=rtol, atol=atol, n=n, controls=controls)
        if not self.uniform:
            raise ValueError(
                "the phases have different states or controls: reintegrate each, phase(name).reintegrate()"
            )
        parts = self._reintegrations(rtol=rtol, atol=atol, n=n, controls=controls)
        first = parts[0]
        same = all(np.array_equal(r.scale, first.scale) for r in parts)
        return Reintegration(
            t=np.concatenate([r.t for r in parts]),
            states=np.concatenate([r.states for r in parts]),
            error=np.concatenate([r.error for r in parts]),
            state_names=first.state_names,
            # each phase's errors in its own states' scales (one row of scales per time where the phases' differ)
            scale=first.scale if same else np.concatenate([np.broadcast_to(r.scale, r.error.shape) for r in parts]),
            rtol=rtol,
            atol=atol,
            n_rhs=int(sum(r.n_rhs for r in parts)),
        )

    def _reintegrations(self, **options: Any) -> list[Reintegration]:
        return [p.reintegrate(**options) for p in self.phases]

    def max_reintegration_error(self, **kwargs: Any) -> float:
        """The largest re-integration error over the phases (units of each phase's state scales)."""
        return max(r.max_error for r in self._reintegrations(**kwargs))

    def flown_trajectory_cost(self) -> float:
        """The trajectory-level cost on the flown trajectory (0 without one): each phase's admissible control flown
        (:func:`ocpkit.flight.fly`) from its linked start, the previous phases' flown end plus the link's jump
        (its own NLP start in the states no link sets), so that a cost at a cut time (``ends.at(t)``) sees the
        flown state there; its part of :attr:`accuracy`'s objective."""
        return self.program.flown_trajectory_cost(self)


def __getattr__(name: str) -> Any:
    if name == "MultiPhaseSolution":
        renamed("ocpkit.solution.MultiPhaseSolution", "ocpkit.Solution (one result for any number of phases)")
        return Solution
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
