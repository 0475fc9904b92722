"""Where everything lies in a program's NLP: the one frozen layout, built once per mesh.

Each phase has its own numbering, the one its scheme writes its blocks in (:class:`PhaseLayout`): the scheme's
variable groups in order, then the phase's problem-wide variables (:class:`GlobalVariables`: pinned parameters, free parameters, a free t0, a free tf or duration). The program's NLP vector
lays the phases out one after the other, each phase's numbering mapped to the NLP's by ``to_global``, except that a
free parameter of the trajectory (several phases naming it, :class:`~ocpkit.statement.phases.MultiPhaseProblem`) is
one NLP variable where its first phase puts it, which the others' numbering maps to. A single-phase program's map
is the identity. The constraint rows follow the phases in turn (each: the scheme's defects, the path constraints at
the scheme's points, the boundary constraints, the control end values that no point holds), then the links and the
trajectory's linkage constraints. :class:`Layout` names its index slices (``layout["climb.states"]``,
``layout["climb.tf"]``, ``layout["parameter k"]``).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any, cast

import casadi as ca
import numpy as np

from ..statement import Control, Duration, OptimalControlProblem
from ..statement.phases import MultiPhaseProblem
from ..statement.variables import AffineScaling

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..statement import FreeFinalTime, FreeInitialTime, FreeParameter
    from ..transcription.mesh import Mesh
    from .scheme import PathPoints, Scheme, VariableGroup


class GlobalVariables:
    """The problem-wide NLP variables of a phase, last in its variables and in every block's ``z``: the pinned
    parameters (NLP variables held by their bounds, so that new values need no rebuild), the free parameters (scaled),
    then t0 and tf where free (divided by their ``scale``; a :class:`~ocpkit.statement.times.Duration` holds
    ``tf - t0`` instead). The only code that maps them, numerically (:meth:`pack`, :meth:`unpack`, :meth:`bounds`)
    and symbolically (:meth:`t0`, :meth:`tf`, :meth:`P`).

    ``free``: the declarations of the free parameters (bounds, scaling, guess), the problem's by default; a program
    gives a parameter that several phases share one declaration (:class:`ocpkit.program.Program`).
    """

    def __init__(self, problem: OptimalControlProblem, free: Sequence[FreeParameter] | None = None) -> None:
        self.problem = problem
        self.free = tuple(problem.free_parameters if free is None else free)
        if [v.name for v in self.free] != [v.name for v in problem.free_parameters]:
            raise ValueError(
                f"declarations of {[v.name for v in self.free]} for the free parameters "
                f"{[v.name for v in problem.free_parameters]} of {problem.name!r}"
            )
        self.free_scaling = AffineScaling.of(self.free)
        self.n_pinned = len(problem.parameters)
        self.n_free = len(self.free)
        self.size = self.n_pinned + self.n_free + int(problem.free_initial_time) + int(problem.free_final_time)
        self.duration = isinstance(problem.tf, Duration)

    @property
    def free_positions(self) -> np.ndarray:
        """The positions of the free parameters among them."""
        return np.arange(self.n_pinned, self.n_pinned + self.n_free, dtype=np.int64)

    def free_to_nlp(self, values: Mapping[str, float]) -> np.ndarray:
        """The scaled values of the free parameters from physical ones by name (default their guesses)."""
        values = {v.name: v.guess_value for v in self.free} | dict(values)
        return self.free_scaling.to_nlp([values[v.name] for v in self.free])

    @property
    def t0_position(self) -> int | None:
        """The position of t0 among them (None when fixed)."""
        return self.n_pinned + self.n_free if self.problem.free_initial_time else None

    @property
    def tf_position(self) -> int | None:
        """The position of tf among them (None when fixed)."""
        return self.size - 1 if self.problem.free_final_time else None

    @property
    def constants(self) -> list[float]:
        """The block constants the times need, ``[tf]`` when it is fixed (a block's ``q`` holds it, so that one
        compiled block serves any fixed final time), else none."""
        return [] if self.problem.free_final_time else [float(cast(float, self.problem.tf))]

    # -- numbers ---------------------------------------------------------------------------------------------------
    def pack(
        self, pinned: ArrayLike, parameters: Mapping[str, float], t0: float | None, tf: float | None
    ) -> np.ndarray:
        """The scaled values from physical ones: the pinned vector, the free parameters by name (default their
        guesses), t0 (default the problem's guess) and tf (required when free)."""
        pr = self.problem
        parts: list[Any] = [np.asarray(pinned, dtype=float).ravel()]
        if self.n_free:
            parts.append(self.free_to_nlp(parameters))
        t0 = pr.t0 if t0 is None else t0
        if pr.free_initial_time:
            parts.append([t0 / cast("FreeInitialTime", pr.initial_time).scale])
        if pr.free_final_time:
            if tf is None:
                raise ValueError("this problem has a free final time: give tf")
            parts.append([((tf - t0) if self.duration else tf) / cast("FreeFinalTime", pr.tf).scale])
        return np.concatenate(parts)

    def unpack(self, z: ArrayLike) -> dict[str, Any]:
        """``{"pinned": {name: value}, "parameters": {name: value}, "t0": ..., "tf": ...}`` of their scaled values."""
        pr = self.problem
        z = np.asarray(z, dtype=float).ravel()
        n_pinned, nf = self.n_pinned, self.n_free
        values = self.free_scaling.from_nlp(z[n_pinned : n_pinned + nf]) if nf else np.zeros(0)
        i0, i_f = self.t0_position, self.tf_position
        t0 = float(z[i0] * cast("FreeInitialTime", pr.initial_time).scale) if i0 is not None else pr.t0
        return {
            "pinned": dict(zip(pr.parameters, z[:n_pinned].tolist())),
            "parameters": dict(zip([v.name for v in self.free], values.tolist())),
            "t0": t0,
            "tf": float(self._final(t0, z[i_f])) if i_f is not None else pr.tf,
        }

    def _final(self, t0: Any, value: Any) -> Any:
        """The final time from t0 and the scaled NLP value of tf (or of the duration)."""
        return (t0 if self.duration else 0.0) + value * cast("FreeFinalTime", self.problem.tf).scale

    def bounds(self, pinned: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Their scaled bounds, the pinned parameters held at ``pinned``."""
        pr = self.problem
        pinned = np.asarray(pinned, dtype=float).ravel()
        lb: list[Any] = [pinned]
        ub: list[Any] = [pinned]
        if self.n_free:
            sc = self.free_scaling
            lb.append(sc.to_nlp([v.lower for v in self.free]))
            ub.append(sc.to_nlp([v.upper for v in self.free]))
        for spec, free in ((pr.initial_time, pr.free_initial_time), (pr.tf, pr.free_final_time)):
            if free:
                spec = cast("FreeFinalTime", spec)  # (a FreeInitialTime is one)
                lb.append([spec.lower / spec.scale])
                ub.append([spec.upper / spec.scale])
        return np.concatenate(lb), np.concatenate(ub)

    # -- symbols (a block's ``z`` ends with these variables; ``q`` holds its constants) -------------------------
    def t0(self, z: ca.SX) -> ca.SX | float:
        """The symbolic initial time: its NLP variable in ``z``'s tail when free, else the constant."""
        if self.t0_position is None:
            return self.problem.t0
        return z[z.numel() - self.size + self.t0_position] * cast("FreeInitialTime", self.problem.initial_time).scale

    def tf(self, z: ca.SX, q: ca.SX, index: int) -> ca.SX:
        """The symbolic final time: its NLP variable in ``z``'s tail when free, else the block constant ``q[index]``."""
        return self._final(self.t0(z), z[z.numel() - 1]) if self.tf_position is not None else q[index]

    def P(self, z: ca.SX) -> ca.SX | ca.DM:
        """The parameter vector ``P`` from ``z``'s tail: the pinned values, then the free parameters."""
        pr = self.problem
        if not self.n_pinned + self.n_free:
            return pr.full_parameters
        start = z.numel() - self.size
        parts = [z[start : start + self.n_pinned]] if self.n_pinned else []
        if self.n_free:
            free = z[start + self.n_pinned : start + self.n_pinned + self.n_free]
            parts.append(self.free_scaling.from_nlp(free))
        return ca.vertcat(*parts)


def segment_clock(times: GlobalVariables | OptimalControlProblem, z: ca.SX, p: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
    """``(t_begin, T, h)`` of a block whose constants are ``[s, fraction, (tf)]`` (:meth:`~ocpkit.transcription.mesh.Mesh.block_constants`),
    ``times`` the phase's problem-wide variables (or its problem, whose are then laid out again).

    ``T = tf - t0``, ``t_begin = t0 + T s`` and ``h = T fraction``.
    """
    layout = times if isinstance(times, GlobalVariables) else GlobalVariables(times)
    t0 = layout.t0(z)
    T = layout.tf(z, p, 2) - t0
    return t0 + T * p[0], T, T * p[1]


@dataclass(frozen=True, eq=False)
class PhaseLayout:
    """One phase's variables in its own numbering, as its scheme sees them (:class:`~ocpkit.program.scheme.Scheme`): the scheme's ``groups`` and their index ``tables`` (each ``(variables, points)``), then the phase's
    problem-wide variables ``times`` (last, :meth:`global_indices`); ``objective_scale``: the program's, which the
    scheme's objective blocks divide by."""

    name: str
    problem: OptimalControlProblem
    groups: tuple[VariableGroup, ...]
    tables: tuple[np.ndarray, ...]
    times: GlobalVariables
    objective_scale: float

    @classmethod
    def of(
        cls,
        name: str,
        problem: OptimalControlProblem,
        groups: Sequence[VariableGroup],
        objective_scale: float,
        free: Sequence[FreeParameter] | None = None,
    ) -> PhaseLayout:
        """The layout of ``groups`` then the problem-wide variables (``free``: the free parameters' declarations)."""
        tables: list[np.ndarray] = []
        offset = 0
        for g in groups:
            tables.append(offset + np.arange(g.size, dtype=np.int64).reshape(g.points, len(g.variables)).T)
            offset += g.size
        return cls(name, problem, tuple(groups), tuple(tables), GlobalVariables(problem, free), float(objective_scale))

    # -- sizes and indices ---------------------------------------------------------------------------------------------
    @cached_property
    def n_group_variables(self) -> int:
        return int(sum(g.size for g in self.groups))

    @property
    def size(self) -> int:
        """How many variables the phase's own numbering holds, its groups' and its problem-wide ones."""
        return self.n_group_variables + self.times.size

    @cached_property
    def global_indices(self) -> np.ndarray:
        """The phase's numbers of its problem-wide variables (``times``), last."""
        return np.arange(self.n_group_variables, self.size, dtype=np.int64)

    def table(self, name: str) -> np.ndarray:
        """The index table ``(variables, points)`` of the group named ``name``."""
        for g, table in zip(self.groups, self.tables):
            if g.name == name:
                return table
        raise KeyError(f"no group {name!r}; the groups are {[g.name for g in self.groups]}")

    def tail_rows(self, count: int) -> list[np.ndarray]:
        """The problem-wide variables as index-table rows for ``count`` instances (an empty list without any)."""
        g = self.global_indices
        return [np.tile(g[:, None], (1, count))] if g.size else []

    def where(self, name: str) -> tuple[int, int]:
        """``(group, column)`` of the state or control ``name``."""
        for k, g in enumerate(self.groups):
            for j, v in enumerate(g.variables):
                if v.name == name:
                    return k, j
        raise KeyError(f"{name!r} is in none of the scheme's groups of phase {self.name!r}")

    @cached_property
    def boundary_states(self) -> tuple[np.ndarray, np.ndarray]:
        """The phase's numbers of ``x(t0)`` and ``x(tf)``, in the problem's order of the states: each state's group's
        first and last point."""
        first = np.empty(self.problem.nx, dtype=np.int64)
        last = np.empty(self.problem.nx, dtype=np.int64)
        for i, s in enumerate(self.problem.states):
            k, j = self.where(s.name)
            first[i], last[i] = self.tables[k][j, 0], self.tables[k][j, -1]
        return first, last

    @property
    def constants(self) -> list[float]:
        """The block constants of the times (``[tf]`` where it is fixed)."""
        return self.times.constants

    # -- helpers of the schemes' blocks --------------------------------------------------------------------------------
    def clock(self, z: ca.SX, p: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
        """``(t_begin, T, h)`` of a block with constants ``[s, fraction, (tf)]``
        (:func:`~ocpkit.transcription.mesh.segment_clock`)."""
        return segment_clock(self.times, z, p)

    def block_constants(self, mesh: Mesh, s: Any = None, fractions: Any = None) -> np.ndarray:
        """``mesh``'s block constants ``[s, fraction, (tf)]`` (:meth:`~ocpkit.transcription.mesh.Mesh.block_constants`)."""
        return mesh.block_constants(self.times, s, fractions)

    def boundary_symbols(self) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX, ca.SX | float, ca.SX, ca.SX | ca.DM]:
        """Symbols ``z = [x(t0), x(tf), problem-wide variables]`` (scaled, the layout of :meth:`boundary_variables`)
        and ``q = [(tf)]``, and in them the physical ``x0, xf, t0, tf`` and the parameter vector ``P``."""
        nx = self.problem.nx
        layout = self.times
        z = ca.SX.sym("z", 2 * nx + layout.size)
        q = ca.SX.sym("q", len(layout.constants))
        xs = self.problem.state_scaling
        x0, xf = xs.from_nlp(z[:nx]), xs.from_nlp(z[nx : 2 * nx])
        return z, q, x0, xf, layout.t0(z), layout.tf(z, q, 0), layout.P(z)

    def __repr__(self) -> str:
        return f"PhaseLayout({self.name!r}, groups {[g.name for g in self.groups]}, {self.size} variables)"

    def boundary_variables(self) -> np.ndarray:
        """The phase's numbers of ``[x(t0), x(tf), problem-wide variables]`` (:meth:`boundary_symbols`' ``z``)."""
        first, last = self.boundary_states
        return np.concatenate([first, last, self.global_indices])


@dataclass(frozen=True, eq=False)
class ControlEnd:
    """A control's end value held by a constraint row (where the scheme has no point there, rule 6 of
    :class:`~ocpkit.program.scheme.Scheme`): ``lower <= sum_k weights_k U_k <= upper`` on the control's
    values at ``points`` of its group (physical units)."""

    control: Control
    which: str
    variables: np.ndarray
    weights: np.ndarray
    lower: float
    upper: float


@dataclass(frozen=True, eq=False)
class Phase:
    """One phase of a program: its layout (:class:`PhaseLayout`) and scheme, ``to_global`` (the NLP number of each
    of its own), and its constraint rows from ``row_offset``: the scheme's ``n_defects``, the path constraints at
    ``path_points``, the boundary constraints, and the ``control_ends`` that rows hold."""

    index: int
    layout: PhaseLayout
    scheme: Scheme
    to_global: np.ndarray
    row_offset: int
    n_defects: int
    path_points: tuple[PathPoints, ...]
    control_ends: tuple[ControlEnd, ...]

    @property
    def name(self) -> str:
        return self.layout.name

    @property
    def problem(self) -> OptimalControlProblem:
        return self.layout.problem

    @property
    def n_path_points(self) -> int:
        """Points at which the path constraints hold (0 without path constraints)."""
        return int(sum(pp.count * pp.k for pp in self.path_points))

    @property
    def n_path_rows(self) -> int:
        c = self.problem.functions.path
        return 0 if c is None else self.n_path_points * c.size

    @property
    def n_boundary_rows(self) -> int:
        c = self.problem.functions.boundary
        return 0 if c is None else c.size

    @property
    def n_rows(self) -> int:
        return self.n_defects + self.n_path_rows + self.n_boundary_rows + len(self.control_ends)

    @cached_property
    def path_fractions(self) -> np.ndarray:
        """Normalised times (0..1) of the path-constraint points, in constraint-row order."""
        if not self.path_points:
            return np.zeros(0)
        return np.concatenate([pp.fractions.ravel() for pp in self.path_points])

    def __repr__(self) -> str:
        return f"Phase({self.index}, {self.name!r}, {self.scheme.label}, rows from {self.row_offset}: {self.n_rows})"


def control_ends(layout: PhaseLayout, scheme: Scheme) -> tuple[ControlEnd, ...]:
    """The end values of the phase's controls that no point holds (the scheme's control interpolant does)."""
    out: list[ControlEnd] = []
    for c in layout.problem.controls:
        k, j = layout.where(c.name)
        fractions = np.asarray(layout.groups[k].fractions, dtype=float)
        for which, at in (("initial", 0.0), ("final", 1.0)):
            if getattr(c, which) is None or np.any(fractions == at):
                continue
            points, weights = scheme.control_weights(at)
            lower, upper = c.boundary_interval(which)
            table = layout.tables[k]
            out.append(ControlEnd(c, which, table[j, np.asarray(points)], np.asarray(weights, float), lower, upper))
    return tuple(out)


class Layout(Mapping[str, np.ndarray]):
    """The whole NLP's layout (module docstring): the :class:`Phase` s, the number of variables and of constraint
    rows, the links' rows, and the named index slices (a mapping ``name -> NLP indices``). Built once per program
    (:meth:`build`); everything a solve asks (bounds, packing, blocks) reads it."""

    def __init__(
        self,
        statement: MultiPhaseProblem,
        phases: Sequence[Phase],
        size: int,
        slices: dict[str, np.ndarray],
        link_rows: Sequence[tuple[int, int]],
    ) -> None:
        self.statement = statement
        self.phases = tuple(phases)
        self.size = int(size)
        self._slices = slices
        #: per link, ``(first row, rows)``: its states' rows then its time row (where a constraint)
        self.link_rows = tuple(link_rows)
        self.n_phase_rows = int(sum(p.n_rows for p in self.phases))
        self.n_link_rows = int(sum(n for _, n in self.link_rows))
        self.n_linkage_rows = 0 if statement.linkage is None else statement.linkage.size
        self.n_constraints = self.n_phase_rows + self.n_link_rows + self.n_linkage_rows

    @classmethod
    def build(cls, statement: MultiPhaseProblem, schemes: Sequence[Scheme]) -> Layout:
        """Lay out ``statement``'s phases on their ``schemes`` (one per phase)."""
        phases: list[Phase] = []
        slices: dict[str, np.ndarray] = {}
        shared: dict[str, int] = {}  # a trajectory's free parameter -> its one NLP index
        offset = row = 0
        for k, (problem, scheme) in enumerate(zip(statement.problems, schemes)):
            name = statement.names[k]
            free = statement.free_declarations(k)
            layout = PhaseLayout.of(name, problem, scheme.groups(problem), statement.objective_scale, free)
            to_global = np.empty(layout.size, dtype=np.int64)
            n = layout.n_group_variables
            to_global[:n] = offset + np.arange(n)
            for g, table in zip(layout.groups, layout.tables):
                slices[f"{name}.{g.name}"] = offset + table
            offset += n
            times = layout.times
            tail = layout.global_indices
            for position in range(times.size):
                j = position - times.n_pinned
                if 0 <= j < times.n_free and times.free[j].name in statement.shared:
                    parameter = times.free[j].name
                    if parameter not in shared:
                        shared[parameter] = offset
                        offset += 1
                    to_global[tail[position]] = shared[parameter]
                else:
                    to_global[tail[position]] = offset
                    offset += 1
            for position, label in _tail_labels(times):
                slices[f"{name}.{label}"] = to_global[tail[position : position + 1]]
            path_points = tuple(scheme.path_points(layout)) if problem.functions.path is not None else ()
            if problem.functions.path is not None and not path_points:
                raise ValueError(
                    f"phase {name!r}: {scheme.label} enforces no path constraints (its path_points gives none), and "
                    f"{problem.name!r} has {list(problem.functions.path.names)}; transcribe it with a scheme that does"
                )
            phase = Phase(
                k,
                layout,
                scheme,
                to_global,
                row,
                int(scheme.defect_count(problem)),
                path_points,
                control_ends(layout, scheme),
            )
            phases.append(phase)
            row += phase.n_rows
        for parameter, index in shared.items():
            slices[f"parameter {parameter}"] = np.array([index], dtype=np.int64)
        link_rows = []
        for linked in statement.links:
            n = len(linked.states) + int(linked.time == "constraint")
            link_rows.append((row, n))
            row += n
        return cls(statement, phases, offset, slices, link_rows)

    # -- the named slices ------------------------------------------------------------------------------------------------
    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._slices:
            raise KeyError(f"no slice {name!r}; the slices are {list(self._slices)}")
        return self._slices[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._slices)

    def __len__(self) -> int:
        return len(self._slices)

    # -- parameters ---------------------------------------------------------------------------------------------------
    @cached_property
    def parameter_slots(self) -> dict[str, np.ndarray]:
        """The NLP indices of each fixed parameter by name, in every phase that has it (one value for all of them,
        each pinned by its bounds)."""
        slots: dict[str, list[np.ndarray]] = {}
        for p in self.phases:
            g = p.to_global[p.layout.global_indices]
            for position, name in enumerate(p.problem.parameters):
                slots.setdefault(name, []).append(g[position : position + 1])
        return {name: np.concatenate(parts) for name, parts in slots.items()}

    def __repr__(self) -> str:
        return f"Layout({self.size} variables, {self.n_constraints} rows, phases {[p.name for p in self.phases]})"


def _tail_labels(times: GlobalVariables) -> list[tuple[int, str]]:
    """``(position, label)`` of the problem-wide variables worth a slice: the free parameters, t0 and tf."""
    out = [(times.n_pinned + j, f"parameter {v.name}") for j, v in enumerate(times.free)]
    if times.t0_position is not None:
        out.append((times.t0_position, "t0"))
    if times.tf_position is not None:
        out.append((times.tf_position, "duration" if times.duration else "tf"))
    return out


__all__ = ["ControlEnd", "GlobalVariables", "Layout", "Phase", "PhaseLayout", "control_ends", "segment_clock"]
