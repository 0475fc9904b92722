"""A trajectory of several phases: the phases' problems, their links, and what the trajectory states once.

Each phase is a single-phase :class:`~ocpkit.statement.problem.OptimalControlProblem` (its own dynamics, bounds,
constraints). A :class:`Link` joins the end of one phase to the start of another,

    x_after(t0_after) - x_before(tf_before) - jump = 0        for the linked states,
    t0_after = tf_before                                      (times, when linked),

the jump being, for instance, the mass dropped at a stage separation. What belongs to the trajectory is stated once
(:class:`MultiPhaseProblem`): a cost of the phases' boundary values (a Mayer term that one in every phase would count
once per phase), linkage constraints between any phases' boundary values, and the free parameters of the trajectory.
A free parameter (:class:`~ocpkit.statement.variables.FreeParameter`) that several phases name is **one parameter
of the trajectory**, as GPOPS-II's static parameters are (one NLP variable, whatever the number of phases); name it
in ``local_parameters`` to give each phase its own, or declare it in ``free_parameters`` to give its bounds, scaling
and guess once for every phase. The objective is the sum of the phases' objectives and the trajectory's cost.

The statement is independent of any transcription: a :class:`~ocpkit.program.Program` transcribes it, each phase
on a scheme of its own.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, cast

import casadi as ca
import numpy as np

from ..names import Named, NamedParameters, UnknownName, call
from .constraints import Constraint, ConstraintSet, checked_constraints
from .problem import OptimalControlProblem
from .symbols import column, constraint_set, read_inputs
from .variables import FreeParameter

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from .variables import Variable


@dataclass(frozen=True)
class Link:
    """The start of phase ``after`` continues the end of phase ``before`` (each by its index or its name).

    ``states``: the names of the linked states (``"all"``: every state of ``before``, which
    ``after`` must have too); ``jumps``: ``{state: value}`` added across the link
    (``x_after(t0) = x_before(tf) + jump``; a stage separation's dropped mass is a
    negative jump of the mass); ``time``: the phases meet in time, ``t0_after = tf_before``.
    """

    before: int | str
    after: int | str
    states: Sequence[str] | str = "all"
    jumps: Mapping[str, float] = field(default_factory=dict)
    time: bool = True

    @property
    def label(self) -> str:
        return f"link {self.before} -> {self.after}"


@dataclass(frozen=True)
class PhaseEnds:
    """One phase's boundary values, as a trajectory-level cost or linkage constraint sees them (symbols).

    ``x0``, ``xf``: the states at the phase's start and end, by name (``xf["v"]``); ``t0``, ``tf``: its
    times; ``p``: its parameters by name; ``fixed_t0``, ``fixed_tf``: the times where fixed (None where free).
    """

    name: str
    x0: Named
    xf: Named
    t0: ca.SX
    tf: ca.SX
    p: NamedParameters
    fixed_t0: float | None = None
    fixed_tf: float | None = None


class PhasesEnds(Mapping[Any, PhaseEnds]):
    """Every phase's :class:`PhaseEnds`, by name or by index: ``ends["descent"].tf``, ``ends[0].xf["h"]``."""

    def __init__(self, ends: Sequence[PhaseEnds]) -> None:
        self._ends = list(ends)
        self._by_name = {e.name: e for e in self._ends}

    def __getitem__(self, key: str | int) -> PhaseEnds:
        if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
            if -len(self._ends) <= key < len(self._ends):
                return self._ends[key]
        elif key in self._by_name:
            return self._by_name[key]
        raise UnknownName(
            f"unknown phase {key!r}; the phases are {list(self._by_name)} (or indices 0 to {len(self) - 1})"
        )

    def at(self, t: float) -> Named:
        """The states at the fixed time ``t``: the ``x0`` of the first phase that starts there, else the ``xf`` of the
        last phase that ends there (at a link with a jump, the state after the jump): a named interior time of
        :meth:`MultiPhaseProblem.split`, a measurement time."""

        def same(v: float | None) -> bool:
            return v is not None and math.isclose(v, t, rel_tol=1e-12, abs_tol=1e-12)

        for e in self._ends:
            if same(e.fixed_t0):
                return e.x0
        for e in reversed(self._ends):
            if same(e.fixed_tf):
                return e.xf
        fixed = sorted({v for e in self._ends for v in (e.fixed_t0, e.fixed_tf) if v is not None})
        raise UnknownName(f"no phase starts or ends at the fixed time t = {t}; the fixed phase times are {fixed}")

    def __iter__(self) -> Iterator[str]:
        return iter(self._by_name)

    def __len__(self) -> int:
        return len(self._ends)


def _has_cost(problem: OptimalControlProblem) -> bool:
    return problem.functions.L is not None or problem.functions.phi is not None


@dataclass(frozen=True)
class LinkedStates:
    """A resolved :class:`Link`: the phases' indices, ``(index in before, index in after, name, jump)`` of each linked
    state, and how the times meet (``"none"``, ``"consistent"``: both fixed and equal, ``"constraint"``: a row)."""

    link: Link
    before: int
    after: int
    states: tuple[tuple[int, int, str, float], ...]
    time: str


class MultiPhaseProblem:
    """Phases, their links, and the trajectory's cost, linkage constraints and parameters (module docstring).

    Parameters
    ----------
    phases : Sequence[OptimalControlProblem] or Mapping[str, OptimalControlProblem]
        One problem per phase, in time order, or a mapping name -> problem. Unnamed phases are named by their
        problems' names (by their indices when two problems share a name).
    links : Sequence[Link], optional
        Default: each phase continues the previous one in every state and in time.
    cost : callable, optional
        A trajectory-level cost added to the phases' own: ``cost(ends)`` or ``cost(ends, p)``, ``ends`` the
        phases' :class:`PhaseEnds` by name or index (``lambda ends: ends["climb"].tf``: a Mayer term stated once),
        ``p`` the trajectory's parameters by name.
    constraints : Sequence[Constraint], optional
        Linkage constraints between any phases' boundary values, their functions called as ``cost`` is
        (``Constraint("bounce", lambda e: e[1].x0["v"] + 0.9 * e[0].xf["v"], lower=0, upper=0)``).
    free_parameters : Sequence[FreeParameter], optional
        Free parameters of the trajectory, declared once: every phase that names one (its own problem declares it
        free, so that its functions see it) uses this declaration's bounds, scaling and guess.
    local_parameters : Sequence[str], optional
        Free parameters that each phase naming them keeps to itself; every other free parameter named by
        several phases is one parameter shared by all of them (the module docstring).
    objective_scale : float, optional
        The NLP minimises ``J / objective_scale``, ``J`` the sum of every phase's cost and ``cost``. Default: the
        largest of the phases' that have a cost.
    """

    def __init__(
        self,
        phases: Sequence[OptimalControlProblem] | Mapping[str, OptimalControlProblem],
        links: Sequence[Link] | None = None,
        *,
        cost: Callable[..., Any] | None = None,
        constraints: Sequence[Constraint] = (),
        free_parameters: Sequence[FreeParameter] = (),
        local_parameters: Sequence[str] = (),
        objective_scale: float | None = None,
    ) -> None:
        if isinstance(phases, Mapping):
            self.names = [str(k) for k in phases]
            self.problems = list(phases.values())
        else:
            self.problems = list(phases)
            own = [getattr(pr, "name", None) for pr in self.problems]
            own_names = cast("list[str]", own)  # (when all of them are names)
            self.names = own_names if len(set(own)) == len(own) and all(own) else [str(k) for k in range(len(own))]
        if not self.problems:
            raise ValueError("a multi-phase problem needs at least one phase")
        for k, pr in enumerate(self.problems):
            if not isinstance(pr, OptimalControlProblem):
                raise TypeError(f"phase {k} must be an OptimalControlProblem, got {type(pr).__name__}")
        if len(set(self.names)) != len(self.names):
            raise ValueError(f"phase names must be distinct, got {self.names}")
        self.links = [self._resolve(link) for link in (links if links is not None else self._default_links())]
        self.local_parameters = tuple([local_parameters] if isinstance(local_parameters, str) else local_parameters)
        self.declared = self._declared(free_parameters)
        self.shared = self._shared_parameters()
        with_cost = [pr.objective_scale for pr in self.problems if _has_cost(pr)]
        if objective_scale is None:
            objective_scale = max(with_cost, default=1.0)
        if not (objective_scale > 0 and math.isfinite(objective_scale)):
            raise ValueError(f"objective_scale must be positive and finite, got {objective_scale}")
        self.objective_scale = float(objective_scale)
        self.cost_callable = cost
        self.constraints = checked_constraints(constraints, "linkage constraints")
        self._symbols = self._ends_symbols()
        self.cost = self._trajectory_cost(cost)
        self.linkage = self._linkage_constraints(self.constraints)
        self._check_parameters_read()
        #: the times a problem was cut at (:meth:`split`), else None
        self.cut_times: np.ndarray | None = None
        #: the problem the phases are, cut at times (:meth:`split` without a cost, constraints or local parameters of
        #: its own), else None
        self.source: OptimalControlProblem | None = None

    def _default_links(self) -> list[Link]:
        return [Link(k, k + 1) for k in range(len(self.problems) - 1)]

    # -- the phases ------------------------------------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self.problems)

    def phase(self, key: str | int) -> OptimalControlProblem:
        """A phase's problem by name or index."""
        return self.problems[self.index(key)]

    def index(self, key: str | int) -> int:
        """A phase's index from its name or index (an unknown one raises, naming the phases)."""
        if isinstance(key, str):
            if key not in self.names:
                raise KeyError(f"unknown phase {key!r}; the phases are {self.names}")
            return self.names.index(key)
        if isinstance(key, (int, np.integer)) and not isinstance(key, bool) and -len(self) <= key < len(self):
            return int(key) % len(self)
        raise KeyError(f"unknown phase {key!r}; the phases are {self.names} (or indices 0 to {len(self) - 1})")

    @property
    def uniform(self) -> bool:
        """Whether every phase has the first's states and controls (then the phases make one trajectory)."""
        first = self.problems[0]
        return all((p.state_names, p.control_names) == (first.state_names, first.control_names) for p in self.problems)

    def with_problems(self, problems: Sequence[OptimalControlProblem]) -> MultiPhaseProblem:
        """The same trajectory (links, cost, constraints, parameters) over other problems of the phases (the same
        names and variables; another parameter value, say)."""
        out = MultiPhaseProblem(
            dict(zip(self.names, problems)),
            [replace(k.link, before=k.before, after=k.after) for k in self.links],
            cost=self.cost_callable,
            constraints=self.constraints,
            free_parameters=tuple(v for v in self.declared.values() if v is not None),
            local_parameters=self.local_parameters,
            objective_scale=self.objective_scale,
        )
        out.cut_times, out.source = self.cut_times, self.source
        return out

    # -- links -------------------------------------------------------------------------------------------------------
    def _resolve(self, link: Link) -> LinkedStates:
        """``link`` checked, its phases as indices and its states as indices in each phase."""
        if not isinstance(link, Link):
            raise TypeError(f"links must be Link objects, got {link!r}")
        ends = {}
        for which in ("before", "after"):
            v = getattr(link, which)
            if isinstance(v, str):
                if v not in self.names:
                    raise ValueError(f"{link.label}: no phase named {v!r}; the phases are {self.names}")
                v = self.names.index(v)
            ends[which] = v
        n = len(self.problems)
        kb, ka = ends["before"], ends["after"]
        if not (0 <= kb < n and 0 <= ka < n) or kb == ka:
            raise ValueError(f"{link.label}: phases must be two different indices in [0, {n})")
        before, after = self.problems[kb], self.problems[ka]
        if isinstance(link.states, str) and link.states != "all":
            raise TypeError(f"{link.label}: states must be 'all' or a sequence of names, got {link.states!r}")
        names = before.state_names if link.states == "all" else list(link.states)
        missing = [s for s in names if s not in before.state_names or s not in after.state_names]
        if missing:
            raise ValueError(
                f"{link.label}: states {missing} are not states of both phases "
                f"(phase {link.before}: {before.state_names}; phase {link.after}: {after.state_names})"
            )
        unknown = sorted(set(link.jumps) - set(names))
        if unknown:
            raise ValueError(f"{link.label}: jumps of {unknown}, which the link does not join (it joins {names})")
        states = tuple((before.state_index(s), after.state_index(s), s, float(link.jumps.get(s, 0.0))) for s in names)
        return LinkedStates(link, kb, ka, states, self._time_link_kind(link, before, after))

    @staticmethod
    def _time_link_kind(link: Link, before: OptimalControlProblem, after: OptimalControlProblem) -> str:
        """``"none"``, ``"consistent"`` (both times fixed and equal) or ``"constraint"`` (either is free)."""
        if not link.time:
            return "none"
        if before.free_final_time or after.free_initial_time:
            return "constraint"
        if not np.isclose(cast(float, before.tf), after.t0, rtol=1e-12, atol=1e-12):
            raise ValueError(
                f"{link.label}: phase {link.before} ends at tf = {before.tf} but phase {link.after} starts at "
                f"t0 = {after.t0}; make the times agree, or free one of them (FreeFinalTime, FreeInitialTime)"
            )
        return "consistent"

    # -- parameters ----------------------------------------------------------------------------------------------------
    def _declared(self, given: Sequence[FreeParameter]) -> dict[str, FreeParameter | None]:
        """The trajectory-level declarations by name (checked: each is a FreeParameter some phase names free)."""
        out: dict[str, FreeParameter | None] = {}
        named = {v.name for pr in self.problems for v in pr.free_parameters}
        for v in given:
            if not isinstance(v, FreeParameter):
                raise TypeError(f"free_parameters must be FreeParameter objects, got {v!r}")
            if v.name in out:
                raise ValueError(f"free parameter {v.name!r} declared twice")
            if v.name not in named:
                raise ValueError(
                    f"free parameter {v.name!r} is declared for the trajectory, but no phase names it (a phase's "
                    f"functions see a parameter its problem declares free: FreeParameter({v.name!r}, ...))"
                )
            if v.name in self.local_parameters:
                raise ValueError(f"free parameter {v.name!r} is both the trajectory's and in local_parameters")
            out[v.name] = v
        return out

    def _shared_parameters(self) -> dict[str, list[tuple[int, int]]]:
        """``{name: [(phase, index among its free parameters), ...]}`` of the trajectory's free parameters: those
        declared for the trajectory, and those several phases name that ``local_parameters`` does not (checked:
        every name in ``local_parameters`` is a free parameter of some phase)."""
        where: dict[str, list[tuple[int, int]]] = {}
        for k, pr in enumerate(self.problems):
            for j, v in enumerate(pr.free_parameters):
                where.setdefault(v.name, []).append((k, j))
        unknown = sorted(set(self.local_parameters) - set(where))
        if unknown:
            raise ValueError(
                f"local_parameters {unknown} are not free parameters of any phase (they are {sorted(where)})"
            )
        return {
            name: w
            for name, w in where.items()
            if name in self.declared or (len(w) > 1 and name not in self.local_parameters)
        }

    def parameter_declaration(self, name: str) -> FreeParameter:
        """The one declaration of the trajectory's free parameter ``name``: its trajectory-level one, or the phases'
        (the same scaling; bounds intersected; the first phase's guess, within them)."""
        declared = self.declared.get(name)
        if declared is not None:
            return declared
        where = self.shared[name]
        found = [self.problems[k].free_parameters[j] for k, j in where]
        first = found[0]
        for k, v in zip((k for k, _ in where), found):
            if (v.scale, v.shift) != (first.scale, first.shift):
                raise ValueError(
                    f"free parameter {name!r} is one parameter of the trajectory, but phases {self.names[where[0][0]]!r}"
                    f" and {self.names[k]!r} scale it differently ((scale, shift) {(first.scale, first.shift)} and "
                    f"{(v.scale, v.shift)}); give it one scaling, declare it once (free_parameters=), or name it in "
                    "local_parameters"
                )
        lower, upper = max(v.lower for v in found), min(v.upper for v in found)
        if lower > upper:
            raise ValueError(f"free parameter {name!r}: the phases' bounds of it do not intersect")
        return replace(first, lower=lower, upper=upper, guess=float(np.clip(first.guess_value, lower, upper)))

    def free_declarations(self, k: int) -> tuple[FreeParameter, ...]:
        """Phase ``k``'s free parameters as the program lays them out: each of the trajectory's by its one
        declaration (:meth:`parameter_declaration`), the others the phase's own."""
        return tuple(
            self.parameter_declaration(v.name) if v.name in self.shared else v for v in self.problems[k].free_parameters
        )

    @property
    def shared_parameters(self) -> list[str]:
        """The free parameters of the trajectory (one NLP variable each, whatever the phases naming them)."""
        return list(self.shared)

    # -- what the trajectory states once: its cost and linkage constraints, on the phases' boundary values -------------
    def _ends_symbols(self) -> tuple[ca.SX, list[ca.SX], PhasesEnds, NamedParameters]:
        """The symbols of every phase's boundary values: ``(e, parts, ends, p)``.

        ``e``: one column of ``[x0, xf, t0, tf, P]`` per phase, in the problems' units (``P`` the phase's parameter
        vector: fixed values, then free ones); ``parts`` its per-phase pieces; ``ends`` the :class:`PhasesEnds` in
        them; ``p``: the trajectory's parameters by name (each shared free one once, each that one phase alone names,
        each fixed one that the phases naming it give one value; a phase-local one is in ``ends[k].p``).
        """
        parts: list[ca.SX] = []
        ends: list[PhaseEnds] = []
        entries: dict[str, list[Any]] = {}  # name -> [(its symbol in a phase's p, fixed value or None), ...]
        for k, pr in enumerate(self.problems):
            nx = pr.nx
            x0, xf = ca.SX.sym(f"x0_{k}", nx), ca.SX.sym(f"xf_{k}", nx)
            t0, tf = ca.SX.sym(f"t0_{k}"), ca.SX.sym(f"tf_{k}")
            P = ca.SX.sym(f"P_{k}", len(pr.parameter_names))
            parts.append(ca.vertcat(x0, xf, t0, tf, P))
            states = pr.state_names
            ends.append(
                PhaseEnds(
                    self.names[k],
                    Named(x0, states, "state", "x0"),
                    Named(xf, states, "state", "xf"),
                    t0,
                    tf,
                    NamedParameters(P, pr.parameter_names),
                    None if pr.free_initial_time else pr.t0,
                    None if pr.free_final_time else cast(float, pr.tf),
                )
            )
            for j, name in enumerate(pr.parameter_names):
                entries.setdefault(name, []).append((ends[-1].p[j], pr.parameters.get(name)))
        chosen = {}
        for name, found in entries.items():
            if name in self.shared:  # the free copies are one parameter: the first free one (a phase may fix it)
                chosen[name] = next(symbol for symbol, fixed in found if fixed is None)
                continue
            held = {v for _, v in found}
            if len(found) == 1 or (None not in held and len(held) == 1):
                chosen[name] = found[0][0]
        p = NamedParameters(
            ca.vertcat(*chosen.values()) if chosen else ca.SX(0, 1), list(chosen), "trajectory parameter"
        )
        return ca.vertcat(*parts), parts, PhasesEnds(ends), p

    @property
    def ends(self) -> PhasesEnds:
        """The phases' boundary values as symbols (:class:`PhasesEnds`), as the cost and constraints see them."""
        return self._symbols[2]

    @property
    def trajectory_parameters(self) -> NamedParameters:
        """The trajectory's parameters by name, as the cost and constraints see them (``p``)."""
        return self._symbols[3]

    def ends_layout(self, k: int) -> tuple[int, int]:
        """Where phase ``k``'s ``[x0, xf, t0, tf, P]`` lie in the ends column: ``(start, size)``."""
        sizes = [part.numel() for part in self._symbols[1]]
        return int(sum(sizes[:k])), sizes[k]

    def _call_on_ends(self, fn: Callable[..., Any], what: str) -> Any:
        p = self.trajectory_parameters
        return call(fn, [self.ends], p, has_parameters=bool(p.names), what=what)

    def _trajectory_cost(self, cost: Callable[..., Any] | None) -> ca.Function | None:
        """``e -> J_trajectory`` (in the problem's units) of ``cost`` (None without)."""
        if cost is None:
            return None
        if not callable(cost):
            raise TypeError(f"cost must be a callable of the phases' ends, got {cost!r}")
        expr = column(self._call_on_ends(cost, "the trajectory cost"), "the trajectory cost")
        if expr.shape != (1, 1):
            raise ValueError(f"the trajectory cost must be a scalar, got shape {expr.shape}")
        return ca.Function("trajectory_cost", [self._symbols[0]], [expr])

    def _linkage_constraints(self, constraints: Sequence[Constraint]) -> ConstraintSet | None:
        """The linkage constraints compiled into one function ``e -> g`` with bounds (None without)."""
        e = self._symbols[0]
        return constraint_set("linkage", constraints, [e], ["e"], ca.SX(0, 1), self._call_on_ends)

    def _check_parameters_read(self) -> None:
        """A ValueError naming each free parameter that no function reads: neither a function of a phase that names
        it (one of the trajectory's: of any phase naming it) nor the trajectory's cost or linkage constraints. The
        solver would return an arbitrary value for it (IPOPT: the middle of its bounds). Checked here, where every
        function that may read it is known: a phase's problem alone cannot tell (a parameter that only the
        trajectory's cost reads is declared by a phase)."""
        if not any(pr.free_parameters for pr in self.problems):
            return
        e, parts = self._symbols[0], self._symbols[1]
        outputs = [] if self.cost is None else [self.cost(e)]
        if self.linkage is not None:
            outputs.append(self.linkage.function(e, ca.SX(0, 1)))
        trajectory = ca.vertcat(*outputs) if outputs else ca.SX(0, 1)
        read: dict[str, bool] = {}
        where: dict[str, list[str]] = {}
        for k, pr in enumerate(self.problems):
            if not pr.free_parameters:
                continue
            _, by_phase = read_inputs(pr.functions)
            offset = 2 * pr.nx + 2
            for j, v in enumerate(pr.free_parameters):
                i = len(pr.parameters) + j
                key = v.name if v.name in self.shared else f"{v.name}@{k}"
                seen = i in by_phase or bool(ca.depends_on(trajectory, parts[k][offset + i]))
                read[key] = read.get(key, False) or seen
                where.setdefault(key, []).append(self.names[k])
        unread = [key for key, seen in read.items() if not seen]
        if unread:
            key = unread[0]
            name = key.split("@")[0]
            phases = ", ".join(map(repr, where[key]))
            trajectory_functions = (
                ", nor the trajectory's cost or linkage constraints" if len(self) > 1 or outputs else ""
            )
            raise ValueError(
                f"free parameter {name!r} of {phases} is read by no function (neither the dynamics, the costs nor "
                f"the constraints{trajectory_functions}), so the solver would return an arbitrary value for it (the "
                f"middle of its bounds): use it (p[{name!r}]) in one of them, or give it a value "
                f"(parameters={{{name!r}: ...}}), or remove it from free_parameters="
            )

    def trajectory_cost(self, values: ArrayLike) -> float:
        """The trajectory-level cost at the phases' boundary values ``values`` (the ends column, :meth:`ends_layout`;
        0 without a cost)."""
        if self.cost is None:
            return 0.0
        return float(self.cost(np.asarray(values, dtype=float)))

    # -- a problem cut into phases ---------------------------------------------------------------------------------------
    @classmethod
    def split(
        cls,
        problem: OptimalControlProblem,
        times: Sequence[float],
        *,
        cost: Callable[..., Any] | None = None,
        constraints: Sequence[Constraint] = (),
        **options: Any,
    ) -> MultiPhaseProblem:
        """One problem cut at fixed ``times`` into linked phases, so that costs and constraints can name those times.

        Each piece keeps the dynamics, bounds, running cost, path constraints and parameters (its free parameters
        shared: one parameter of the trajectory); the first keeps the initial conditions, the last the final ones;
        the Mayer term and the boundary constraints move to the trajectory level (with the first phase's copy of a
        phase-local parameter); the pieces' guesses continue the whole problem's. ``cost`` and ``constraints`` are
        the trajectory's, and ``ends.at(t)`` is the state at a cut time (or at t0, tf): a least-squares fit to
        measurements is a sum of ``(ends.at(t)["y"] - y_measured) ** 2``. The problem's t0 and tf must be fixed;
        ``options`` go to :class:`MultiPhaseProblem` (``local_parameters``, ``objective_scale``).
        """
        if problem.free_initial_time or problem.free_final_time:
            raise ValueError(f"split needs fixed t0 and tf: {problem.name!r} has a free one")
        tf = cast(float, problem.tf)  # (fixed)
        t = np.sort(np.asarray(times, dtype=float).ravel())
        if t.size and (not np.all(np.isfinite(t)) or t[0] < problem.t0 or t[-1] > tf):
            raise ValueError(f"times must lie in [t0, tf] = [{problem.t0}, {tf}], got {t.min()} to {t.max()}")
        edges = [problem.t0]
        for v in [*t, tf]:  # times as close as PhasesEnds.at matches them are one cut
            if not math.isclose(v, edges[-1], rel_tol=1e-12, abs_tol=1e-12):
                edges.append(float(v))
        edges[-1] = tf
        cuts = np.array(edges)
        n = cuts.size - 1
        span = tf - problem.t0

        def whole(variable: Variable) -> Callable[[ArrayLike], np.ndarray]:
            """The whole problem's guess of ``variable`` as a function of physical time (so pieces continue it)."""
            fn = variable.guess_function()
            return lambda t: fn((np.asarray(t, dtype=float) - problem.t0) / span, np.asarray(t, dtype=float))

        controls = [
            replace(
                c,
                guess=whole(c),
                initial=c.initial if k == 0 else None,
                final=c.final if k == n - 1 else None,
            )
            for k in range(n)
            for c in problem.controls
        ]
        pieces: dict[str, OptimalControlProblem] = {}
        for k, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
            states = [
                replace(
                    s,
                    initial=s.initial if k == 0 else None,
                    final=s.final if k == n - 1 else None,
                    guess=whole(s),
                )
                for s in problem.states
            ]
            pieces[f"{problem.name}_{k}"] = problem.replace(
                name=f"{problem.name}_{k}",
                states=states,
                controls=controls[k * problem.nu : (k + 1) * problem.nu],
                t0=float(a),
                tf=float(b),
                mayer=None,
                boundary_constraints=(),
            )
        functions = problem.functions

        def total_cost(ends: PhasesEnds, p: NamedParameters) -> Any:
            out = 0.0 if cost is None else call(cost, [ends], p, has_parameters=bool(p.names), what="split(cost=...)")
            if functions.phi is not None:
                first, last = ends[0], ends[-1]
                out = out + functions.phi(first.x0, last.xf, first.t0, last.tf, first.p.column)
            return out

        def boundary(c: Constraint) -> Constraint:
            def at_ends(ends: PhasesEnds) -> Any:
                first, last = ends[0], ends[-1]
                inputs = [first.x0, last.xf, first.t0, last.tf]
                what = f"boundary constraint {c.name!r}"
                return call(c.function, inputs, first.p, has_parameters=problem.takes_parameters, what=what)

            return replace(c, function=at_ends)

        moved = [boundary(c) for c in problem.boundary_constraints]
        has_cost = cost is not None or functions.phi is not None
        options.setdefault("objective_scale", problem.objective_scale)  # the whole problem's, whatever the pieces'
        out = cls(pieces, cost=total_cost if has_cost else None, constraints=[*moved, *constraints], **options)
        out.cut_times = cuts
        # the phases are exactly the problem cut (nothing stated at the cut times, every parameter one): its solution
        # is one of that problem
        if cost is None and not constraints and not out.local_parameters:
            out.source = problem
        return out

    def __repr__(self) -> str:
        return f"MultiPhaseProblem({', '.join(f'{n}: {p.name!r}' for n, p in zip(self.names, self.problems))})"


__all__ = ["Link", "LinkedStates", "MultiPhaseProblem", "PhaseEnds", "PhasesEnds"]
