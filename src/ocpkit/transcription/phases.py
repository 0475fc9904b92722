"""Multi-phase problems: several transcribed phases, linked, in one NLP and one solve.

A phase is any direct transcription of a single-phase
:class:`~ocpkit.problem.OptimalControlProblem` (its own dynamics, bounds, constraints,
scheme and mesh). :class:`MultiPhase` stacks the phases' NLP variables and constraint
rows, offsets their blocks accordingly (each block stays the small mapped function it
was: the NLP keeps its block-separable exact derivatives), and adds one linkage block
per :class:`Link`:

    x_after(t0_after) - x_before(tf_before) - jump = 0        for the linked states,
    t0_after = tf_before                                      (times, when linked),

the jump being, for instance, the mass dropped at a stage separation. A free parameter
(:class:`~ocpkit.FreeParameter`) that several phases name is **one parameter of the
trajectory**, as GPOPS-II's static parameters are: one linear row per further phase,

    p_phase_k - p_first_phase = 0,

holds every phase's copy equal (the COPS gas-oil fit stated as linked phases used to fit
one set of rate constants per phase, and report success); name it in ``local_parameters``
to give each phase its own. The objective is the sum of the phases' objectives. The result, :class:`MultiPhaseSolution`, holds each
phase's :class:`~ocpkit.Solution` and is itself a :class:`~ocpkit.Trajectory` spanning
the phases when they share their states and controls.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import TYPE_CHECKING, Any, Self, cast

import casadi as ca
import numpy as np

from .._arrays import unique
from .._deprecation import renamed
from ..names import Named, NamedParameters, UnknownName, call
from ..nlp import DEFAULT_IPOPT_OPTIONS, Block, NLPResult, SeparableNLP
from ..solution import Solution
from ..statement import Constraint, ConstraintSet, OptimalControlProblem
from ..statement.constraints import checked_constraints
from ..statement.symbols import column, constraint_set
from ..trajectory import Reintegration, Trajectory
from . import session
from .base import Transcription

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..accuracy import MultiPhaseAccuracy
    from ..statement import Variable


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


def _has_cost(problem: OptimalControlProblem) -> bool:
    return problem.functions.L is not None or problem.functions.phi is not None


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
        :meth:`MultiPhase.split`, a measurement time."""

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


class MultiPhase(session.SolveSession["MultiPhaseSolution"]):
    """Transcribed phases and their links, as one NLP (see the module docstring).

    Parameters
    ----------
    phases : Sequence[Transcription] or Mapping[str, Transcription]
        One transcription per phase (:class:`~ocpkit.transcription.Transcription`), in time order, or a mapping
        name -> transcription. Unnamed phases are named by their problems' names
        (by their indices when two problems share a name).
    links : Sequence[Link], optional
        Default: each phase continues the previous one in every state and in time.
    cost : callable, optional
        A trajectory-level cost added to the phases' own: ``cost(ends)`` or ``cost(ends, p)``, ``ends`` the
        phases' :class:`PhaseEnds` by name or index (``lambda ends: ends["climb"].tf``: a Mayer term stated once,
        where one in every phase would be counted once per phase), ``p`` the trajectory's parameters by name.
    constraints : Sequence[Constraint], optional
        Linkage constraints between any phases' boundary values, their functions called as ``cost`` is
        (``Constraint("bounce", lambda e: e[1].x0["v"] + 0.9 * e[0].xf["v"], lower=0, upper=0)``).
    local_parameters : Sequence[str], optional
        Free parameters that each phase naming them keeps to itself; every other free parameter named by
        several phases is one parameter shared by all of them (the module docstring).
    objective_scale : float, optional
        The NLP minimises ``J / objective_scale``, ``J`` the sum of every phase's cost and ``cost``; each
        phase's cost is rescaled from its own ``objective_scale``. Default: the largest of the phases' that
        have a cost.
    """

    #: Whether the one NLP's Jacobian and Hessian blocks are compiled to C (:attr:`Transcription.compile`).
    compile: str | bool = "auto"

    def __init__(
        self,
        phases: Sequence[Transcription] | Mapping[str, Transcription],
        links: Sequence[Link] | None = None,
        *,
        cost: Callable[..., Any] | None = None,
        constraints: Sequence[Constraint] = (),
        local_parameters: Sequence[str] = (),
        objective_scale: float | None = None,
    ) -> None:
        if isinstance(phases, Mapping):
            self.names = [str(k) for k in phases]
            self.phases = list(phases.values())
        else:
            self.phases = list(phases)
            own = [getattr(ph, "problem", None) and ph.problem.name for ph in self.phases]
            own_names = cast("list[str]", own)  # (when all of them are names)
            self.names = own_names if len(set(own)) == len(own) and all(own) else [str(k) for k in range(len(own))]
        if not self.phases:
            raise ValueError("a multi-phase problem needs at least one phase")
        for k, ph in enumerate(self.phases):
            if not isinstance(ph, Transcription):
                raise TypeError(f"phase {k} must be a Transcription (HLGL, Radau, ...), got {type(ph).__name__}")
        if links is None:
            links = [Link(k, k + 1) for k in range(len(self.phases) - 1)]
        self.links = [self._resolve_link(link) for link in links]
        self._link_states = [self._check_link(link) for link in self.links]
        self._shared = self._shared_parameters(local_parameters)
        with_cost = [ph.problem.objective_scale for ph in self.phases if _has_cost(ph.problem)]
        if objective_scale is None:
            objective_scale = max(with_cost, default=1.0)
        if not (objective_scale > 0 and math.isfinite(objective_scale)):
            raise ValueError(f"objective_scale must be positive and finite, got {objective_scale}")
        self.objective_scale = float(objective_scale)
        self._options: dict[str, Any] = dict(
            links=self.links,
            cost=cost,
            constraints=tuple(constraints),
            local_parameters=tuple([local_parameters] if isinstance(local_parameters, str) else local_parameters),
            objective_scale=self.objective_scale,
        )
        sizes = [ph.n_variables for ph in self.phases]
        self.variable_offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        rows = [ph.n_constraints for ph in self.phases]
        self.row_offsets = np.concatenate([[0], np.cumsum(rows)[:-1]]).astype(np.int64)
        self.n_variables = int(sum(sizes))
        self._ends = self._ends_symbols()
        self._cost = self._trajectory_cost(cost)
        self._linkage = self._linkage_constraints(constraints)
        self.n_linkage_rows = 0 if self._linkage is None else self._linkage.size
        self.n_link_rows = (
            sum(len(names) for names in self._link_states)
            + sum(self._time_link_kind(link) == "constraint" for link in self.links)
            + sum(len(where) - 1 for where in self._shared.values())
            + self.n_linkage_rows
        )
        self.n_constraints = int(sum(rows)) + self.n_link_rows
        self._nlp: SeparableNLP | None = None
        self._solver: ca.Function | None = None
        self._solver_options: tuple[Any, ...] | None = None
        self._estimate_counts: list[int] | None = None
        #: the times a problem was cut at (:meth:`split`), else None
        self.cut_times: np.ndarray | None = None
        self.build_s = 0.0

    @classmethod
    def split(
        cls,
        problem: OptimalControlProblem,
        times: Sequence[float],
        scheme: Callable[[OptimalControlProblem], Transcription],
        *,
        cost: Callable[..., Any] | None = None,
        constraints: Sequence[Constraint] = (),
        **options: Any,
    ) -> MultiPhase:
        """One problem cut at fixed ``times`` into linked phases, so that costs and constraints can name those times.

        Each piece keeps the dynamics, bounds, running cost, path constraints and parameters (its free parameters
        shared: one parameter of the trajectory); the first keeps the initial conditions, the last the final ones;
        the Mayer term and the boundary constraints move to the trajectory level (with the first phase's copy of a
        phase-local parameter); the pieces' guesses continue the whole problem's. ``scheme(piece)`` transcribes a
        piece (``lambda pr: Radau(pr, 4, 3)``). ``cost`` and ``constraints`` are :class:`MultiPhase`'s, and
        ``ends.at(t)`` is the state at a cut time (or at t0, tf): a least-squares fit to measurements is a sum of
        ``(ends.at(t)["y"] - y_measured) ** 2``. The problem's t0 and tf must be fixed; ``options`` go to
        :class:`MultiPhase` (``local_parameters``, ``objective_scale``).
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

        controls = [replace(c, guess=whole(c)) for c in problem.controls]
        phases: dict[str, Transcription] = {}
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
            piece = problem.replace(
                name=f"{problem.name}_{k}",
                states=states,
                controls=controls,
                t0=float(a),
                tf=float(b),
                mayer=None,
                boundary_constraints=(),
            )
            phases[f"{problem.name}_{k}"] = scheme(piece)
        functions = problem.functions

        def total_cost(ends: PhasesEnds, p: NamedParameters) -> Any:
            out = 0.0 if cost is None else call(cost, [ends], p, has_parameters=bool(p.names), what="the cost")
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
        mp = cls(phases, cost=total_cost if has_cost else None, constraints=[*moved, *constraints], **options)
        mp.cut_times = cuts
        return mp

    # -- trajectory-level cost and linkage constraints ---------------------------------------------
    def _resolve_link(self, link: Link) -> Link:
        """``link`` with phase names replaced by indices (an unknown name raises, naming the phases)."""
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
        return replace(link, **ends)

    def _ends_symbols(self) -> tuple[ca.SX, ca.SX, np.ndarray, np.ndarray, PhasesEnds, NamedParameters]:
        """The symbols of every phase's boundary values: ``(z, q, variables, values, ends, p)``.

        ``z``: the scaled NLP variables at ``variables`` (each phase's x(t0), x(tf) and problem-wide variables);
        ``q``: the fixed final times, whose ``values`` a block carries; ``ends``: the :class:`PhasesEnds` in them;
        ``p``: the trajectory's parameters by name (each shared free one once, each that one phase alone names, each
        fixed one that the phases naming it give one value; a phase-local one is in ``ends[k].p``).
        """
        zs: list[ca.SX] = []
        qs: list[ca.SX] = []
        variables: list[np.ndarray] = []
        values: list[list[float]] = []
        ends: list[PhaseEnds] = []
        entries: dict[str, list[Any]] = {}  # name -> [(its symbol in a phase's p, free in that phase), ...]
        for k, ph in enumerate(self.phases):
            z, q, x0, xf, t0, tf, P = ph._boundary_symbols()
            first, last, _ = ph._boundary_indices()
            pr = ph.problem
            zs.append(z)
            qs.append(q)
            variables.append(self.variable_offsets[k] + np.concatenate([first, last, ph.global_indices()]))
            values.append(ph.global_variables.constants)
            states = pr.state_names
            ends.append(
                PhaseEnds(
                    self.names[k],
                    Named(x0, states, "state"),
                    Named(xf, states, "state"),
                    ca.SX(t0),
                    ca.SX(tf),
                    NamedParameters(ca.SX(P), pr.parameter_names),
                    None if pr.free_initial_time else pr.t0,
                    None if pr.free_final_time else cast(float, pr.tf),
                )
            )
            for j, name in enumerate(pr.parameter_names):
                fixed = pr.parameters.get(name)
                entries.setdefault(name, []).append((ends[-1].p[j], fixed))
        chosen = {}
        for name, found in entries.items():
            if name in self._shared:  # the free copies are one parameter: the first free one (a phase may fix it)
                chosen[name] = next(symbol for symbol, fixed in found if fixed is None)
                continue
            held = {v for _, v in found}
            if len(found) == 1 or (None not in held and len(held) == 1):
                chosen[name] = found[0][0]
        p = NamedParameters(
            ca.vertcat(*chosen.values()) if chosen else ca.SX(0, 1), list(chosen), "trajectory parameter"
        )
        return (
            ca.vertcat(*zs),
            ca.vertcat(*qs),
            np.concatenate(variables).astype(np.int64),
            np.array([v for vs in values for v in vs], dtype=float),
            PhasesEnds(ends),
            p,
        )

    def _call_on_ends(self, fn: Callable[..., Any], what: str) -> Any:
        ends, p = self._ends[4], self._ends[5]
        return call(fn, [ends], p, has_parameters=bool(p.names), what=what)

    def _trajectory_cost(self, cost: Callable[..., Any] | None) -> ca.Function | None:
        """``(z, q) -> J_trajectory`` (in the problem's units) of ``cost`` (None without)."""
        if cost is None:
            return None
        if not callable(cost):
            raise TypeError(f"cost must be a callable of the phases' ends, got {cost!r}")
        z, q = self._ends[:2]
        expr = column(self._call_on_ends(cost, "the trajectory cost"), "the trajectory cost")
        if expr.shape != (1, 1):
            raise ValueError(f"the trajectory cost must be a scalar, got shape {expr.shape}")
        return ca.Function("trajectory_cost", [z, q], [expr])

    def _linkage_constraints(self, constraints: Sequence[Constraint]) -> ConstraintSet | None:
        """The linkage constraints compiled into one function ``(z, q) -> g`` with bounds (None without)."""
        constraints = checked_constraints(constraints, "linkage constraints")
        z, q = self._ends[:2]
        return constraint_set("linkage", constraints, [z], ["z"], q, self._call_on_ends)

    def _trajectory_blocks(self, row: int) -> list[Block]:
        """The trajectory cost (scaled by :attr:`objective_scale`) and the linkage rows from ``row``."""
        _, _, variables, values, _, _ = self._ends
        var, par = variables[:, None], values[:, None]
        blocks: list[Block] = []
        if self._cost is not None:
            z, q = self._ends[:2]
            fun = ca.Function("trajectory_cost", [z, q], [self._cost(z, q) / self.objective_scale])
            blocks.append(Block("trajectory_cost", fun, var, par))
        if self._linkage is not None:
            z, q = self._ends[:2]
            fun = ca.Function("linkage", [z, q], [self._linkage.function(z, q) / ca.DM(self._linkage.scale)])
            blocks.append(Block("linkage_constraints", fun, var, par, row + np.arange(self._linkage.size)[:, None]))
        return blocks

    # -- shared parameters ----------------------------------------------------------------------
    def _shared_parameters(self, local: str | Sequence[str]) -> dict[str, list[tuple[int, int]]]:
        """``{name: [(phase, index among its free parameters), ...]}`` of the free parameters several phases name
        and ``local`` does not (checked: every name in ``local`` is a free parameter of some phase)."""
        local = [local] if isinstance(local, str) else list(local)
        where: dict[str, list[tuple[int, int]]] = {}
        for k, ph in enumerate(self.phases):
            for j, v in enumerate(ph.problem.free_parameters):
                where.setdefault(v.name, []).append((k, j))
        unknown = sorted(set(local) - set(where))
        if unknown:
            raise ValueError(
                f"local_parameters {unknown} are not free parameters of any phase (they are {sorted(where)})"
            )
        return {name: w for name, w in where.items() if len(w) > 1 and name not in local}

    def _parameter_index(self, k: int, j: int) -> int:
        """The NLP index (in the stacked vector) of phase ``k``'s free parameter ``j``."""
        ph = self.phases[k]
        return int(self.variable_offsets[k] + ph.global_indices()[ph.global_variables.free_positions[j]])

    def _parameter_blocks(self, row: int) -> list[Block]:
        """``(p_k - p_first) / scale = 0`` for every further phase naming a shared parameter (physical values)."""
        blocks: list[Block] = []
        for name, where in self._shared.items():
            (k0, j0), rest = where[0], where[1:]

            def physical(k: int, j: int, z: ca.SX) -> Any:
                return self.phases[k].global_variables.free_value(j, z)

            for k, j in rest:
                z = ca.SX.sym("z", 2)
                scale = float(self.phases[k0].problem.free_parameter_scaling.scale[j0])
                out = (physical(k, j, z[1]) - physical(k0, j0, z[0])) / scale
                var = np.array([[self._parameter_index(k0, j0)], [self._parameter_index(k, j)]], dtype=np.int64)
                blocks.append(
                    Block(
                        f"shared_{name}_{k0}_{k}",
                        ca.Function("shared", [z, ca.SX.sym("q", 0)], [out]),
                        var,
                        np.zeros((0, 1)),
                        np.array([[row]]),
                    )
                )
                row += 1
        return blocks

    @property
    def shared_parameters(self) -> list[str]:
        """The free parameters shared by several phases (one parameter of the trajectory each)."""
        return list(self._shared)

    # -- links ----------------------------------------------------------------------------------
    def _check_link(self, link: Link) -> list[tuple[int, int, str]]:
        """``(index in before, index in after, name)`` of the linked states; bad links raise, naming the link."""
        n = len(self.phases)
        kb, ka = cast(int, link.before), cast(int, link.after)  # (a resolved link: indices)
        if not (0 <= kb < n and 0 <= ka < n) or kb == ka:
            raise ValueError(f"{link.label}: phases must be two different indices in [0, {n})")
        before, after = self.phases[kb].problem, self.phases[ka].problem
        names = before.state_names if link.states == "all" else list(link.states)
        if isinstance(link.states, str) and link.states != "all":
            raise TypeError(f"{link.label}: states must be 'all' or a sequence of names, got {link.states!r}")
        missing = [s for s in names if s not in before.state_names or s not in after.state_names]
        if missing:
            raise ValueError(
                f"{link.label}: states {missing} are not states of both phases "
                f"(phase {link.before}: {before.state_names}; phase {link.after}: {after.state_names})"
            )
        unknown = sorted(set(link.jumps) - set(names))
        if unknown:
            raise ValueError(f"{link.label}: jumps of {unknown}, which the link does not join (it joins {names})")
        self._time_link_kind(link)  # validates
        return [(before.state_index(s), after.state_index(s), s) for s in names]

    def _time_link_kind(self, link: Link) -> str:
        """``"none"``, ``"consistent"`` (both times fixed and equal) or ``"constraint"`` (either is free)."""
        if not link.time:
            return "none"
        kb, ka = cast(int, link.before), cast(int, link.after)  # (a resolved link: indices)
        before, after = self.phases[kb].problem, self.phases[ka].problem
        if before.free_final_time or after.free_initial_time:
            return "constraint"
        if not np.isclose(cast(float, before.tf), after.t0, rtol=1e-12, atol=1e-12):
            raise ValueError(
                f"{link.label}: phase {link.before} ends at tf = {before.tf} but phase {link.after} starts at "
                f"t0 = {after.t0}; make the times agree, or free one of them (FreeFinalTime, FreeInitialTime)"
            )
        return "consistent"

    def _link_blocks(self) -> list[Block]:
        blocks: list[Block] = []
        row = int(sum(ph.n_constraints for ph in self.phases))
        for link, joined in zip(self.links, self._link_states):
            kb, ka = cast(int, link.before), cast(int, link.after)  # (a resolved link: indices)
            pb, pa = self.phases[kb], self.phases[ka]
            ob, oa = self.variable_offsets[kb], self.variable_offsets[ka]
            if joined:
                _, end_b, _ = pb._boundary_indices()
                start_a, _, _ = pa._boundary_indices()
                ib = np.array([i for i, _, _ in joined])
                ia = np.array([j for _, j, _ in joined])
                sb, sa = pb.problem.state_scaling.subset(ib), pa.problem.state_scaling.subset(ia)
                m = len(joined)
                z = ca.SX.sym("z", 2 * m)
                q = ca.SX.sym("q", m)  # the jumps
                out = (sa.from_nlp(z[m:]) - sb.from_nlp(z[:m]) - q) / ca.DM(sa.scale)
                var = np.concatenate([ob + end_b[ib], oa + start_a[ia]])[:, None]
                jumps = np.array([[float(link.jumps.get(name, 0.0))] for _, _, name in joined])
                rows = row + np.arange(m)[:, None]
                blocks.append(
                    Block(f"link_{link.before}_{link.after}", ca.Function("link", [z, q], [out]), var, jumps, rows)
                )
                row += m
            if self._time_link_kind(link) == "constraint":
                # t0_after - tf_before = 0 on the two phases' boundary symbols (each time however its phase holds it)
                zb, qb, _, _, _, tf_before, _ = pb._boundary_symbols()
                za, qa, _, _, t0_after, _, _ = pa._boundary_symbols()
                z, q = ca.vertcat(zb, za), ca.vertcat(qb, qa)
                parts: list[np.ndarray] = []
                par: list[float] = []
                for ph, offset in ((pb, ob), (pa, oa)):
                    first, last, _ = ph._boundary_indices()
                    parts.append(offset + np.concatenate([first, last, ph.global_indices()]))
                    par.extend(ph.global_variables.constants)
                values = [tf_before, t0_after]
                scale = max(abs(float(pb.problem.tf_guess)), 1.0)
                blocks.append(
                    Block(
                        f"link_time_{link.before}_{link.after}",
                        ca.Function("link_time", [z, q], [(values[1] - values[0]) / scale]),
                        np.concatenate(parts).astype(np.int64).reshape(-1, 1),
                        np.array(par, dtype=float).reshape(-1, 1),
                        np.array([[row]]),
                    )
                )
                row += 1
        shared = self._parameter_blocks(row)
        return blocks + shared + self._trajectory_blocks(row + len(shared))

    # -- the NLP ----------------------------------------------------------------------------
    def _phase_blocks(self) -> list[Block]:
        out: list[Block] = []
        for k, ph in enumerate(self.phases):
            ov, orow = self.variable_offsets[k], self.row_offsets[k]
            factor = ph.problem.objective_scale / self.objective_scale
            for b in ph._blocks() + ph._constraint_blocks():
                function = b.function
                if b.rows is None and factor != 1.0:  # an objective block, in the trajectory's objective scale
                    z, q = ca.SX.sym("z", function.size1_in(0)), ca.SX.sym("q", function.size1_in(1))
                    function = ca.Function(function.name(), [z, q], [function(z, q) * factor])
                out.append(
                    Block(
                        f"phase{k}_{b.name}",
                        function,
                        b.variables + ov,
                        b.constants,
                        None if b.rows is None else b.rows + orow,
                        b.linear,
                    )
                )
        return out

    def build(self) -> Self:
        """Build the NLP (idempotent); the wall time is kept in ``build_s``."""
        if self._nlp is None:
            t = time.perf_counter()
            self._blocks = self._phase_blocks() + self._link_blocks()
            self._nlp = SeparableNLP(self.n_variables, self.n_constraints, self._blocks, compile=self.compile)
            self.build_s = time.perf_counter() - t
        return self

    @property
    def nlp(self) -> SeparableNLP:
        return cast(SeparableNLP, self.build()._nlp)  # (built)

    def _bounds(self, parameters: Mapping[str, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
        lb, ub = zip(*(ph._bounds(self._phase_parameters(ph, parameters)) for ph in self.phases))
        return np.concatenate(lb), np.concatenate(ub)

    @staticmethod
    def _phase_parameters(ph: Transcription, parameters: Mapping[str, float] | None) -> dict[str, float] | None:
        """The part of ``parameters`` (new values of fixed parameters) that names ``ph``'s."""
        if parameters is None:
            return None
        return {k: v for k, v in parameters.items() if k in ph.problem.parameters}

    def _check_parameters(self, parameters: Mapping[str, float]) -> None:
        known = sorted({k for ph in self.phases for k in ph.problem.parameters})
        unknown = sorted(set(parameters) - set(known))
        if unknown:
            raise KeyError(f"unknown parameters {unknown}; the phases have {known}")
        for ph in self.phases:
            ph.parameter_values(self._phase_parameters(ph, parameters))

    def _parameter_slots(self) -> dict[str, np.ndarray]:
        """Per parameter name, its NLP indices in every phase that has it (one value for all of them)."""
        slots: dict[str, list[np.ndarray]] = {}
        for k, ph in enumerate(self.phases):
            for name, index in ph._parameter_slots().items():
                slots.setdefault(name, []).append(self.variable_offsets[k] + index)
        return {name: np.concatenate(parts) for name, parts in slots.items()}

    def _parameter_defaults(self) -> dict[str, float | None]:
        """Each parameter's value where its phases agree, None where they hold it at different values (a value
        given to a solve pins every phase's)."""
        values: dict[str, float | None] = {}
        for ph in self.phases:
            for name, value in ph._parameter_defaults().items():
                if name in values and values[name] != value:
                    values[name] = None
                else:
                    values.setdefault(name, value)
        return values

    def _objective_scale(self) -> float:
        return self.objective_scale

    def _time_span(self, w: ArrayLike) -> tuple[float, float]:
        """``(t0, tf)`` of a scaled NLP vector: the first phase's start and the last phase's end (as listed)."""
        w = np.asarray(w, dtype=float).ravel()
        first, last = self.phases[0], self.phases[-1]
        o0, o1 = int(self.variable_offsets[0]), int(self.variable_offsets[-1])
        return (
            first._time_span(w[o0 : o0 + first.n_variables])[0],
            last._time_span(w[o1 : o1 + last.n_variables])[1],
        )

    def _constraint_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        phase_lo, phase_hi = zip(*(ph._constraint_bounds() for ph in self.phases))
        z = np.zeros(self.n_link_rows - self.n_linkage_rows)
        lo, hi = [*phase_lo, z], [*phase_hi, z]
        if self._linkage is not None:
            lo.append(self._linkage.lower / self._linkage.scale)
            hi.append(self._linkage.upper / self._linkage.scale)
        return np.concatenate(lo), np.concatenate(hi)

    def initial_point(self, guesses: Sequence[Any] | MultiPhaseSolution | None = None) -> np.ndarray:
        """The start vector from one guess per phase (a :class:`~ocpkit.Guess`, a Solution or None), or from a
        :class:`MultiPhaseSolution` of the same phases (each phase from its own)."""
        if isinstance(guesses, MultiPhaseSolution):
            guesses = guesses.phases
        guesses = [None] * len(self.phases) if guesses is None else list(guesses)
        if len(guesses) != len(self.phases):
            raise ValueError(f"give one guess per phase: {len(self.phases)} phases, {len(guesses)} guesses")
        return np.concatenate([ph.initial_point(g) for ph, g in zip(self.phases, guesses)])

    @property
    def label(self) -> str:
        return "MultiPhase(" + ", ".join(f"{name}: {ph.label}" for name, ph in zip(self.names, self.phases)) + ")"

    @property
    def n_collocation_points(self) -> int:
        return sum(ph.n_collocation_points for ph in self.phases)

    @property
    def ipopt_defaults(self) -> dict[str, Any]:
        """The phases' IPOPT defaults where every phase asks for the same value (an ordering one phase's structure
        asks for, and another's does not, is left at ocpkit's default)."""
        first, *others = [ph.ipopt_defaults for ph in self.phases]
        return {k: v for k, v in first.items() if all(o.get(k, object()) == v for o in others)}

    def effective_ipopt_options(self, ipopt_options: dict[str, Any] | None = None) -> dict[str, Any]:
        """The IPOPT options a solve with these overrides runs with (as a single transcription's)."""
        return {**DEFAULT_IPOPT_OPTIONS, **self.ipopt_defaults, **(ipopt_options or {})}

    def solver(self, ipopt_options: dict[str, Any] | None = None) -> ca.Function:
        """The IPOPT instance for these option overrides (:meth:`effective_ipopt_options`): created once per set."""
        self.build()
        key = tuple(sorted((ipopt_options or {}).items()))
        if self._solver is None or key != self._solver_options:
            t = time.perf_counter()
            self._solver = self.nlp.solver(self.effective_ipopt_options(ipopt_options))
            self.build_s += time.perf_counter() - t
            self._solver_options = key
        return self._solver

    def _solve_once(
        self,
        guess: Any,
        ipopt_options: dict[str, Any] | None,
        allow_acceptable: bool,
        raise_on_failure: bool,
        parameters: Mapping[str, float] | None = None,
        estimate_multipliers: bool = False,
    ) -> MultiPhaseSolution:
        """One IPOPT solve (:func:`ocpkit.transcription.session.solve_once`)."""
        return session.solve_once(
            self, guess, ipopt_options, allow_acceptable, raise_on_failure, parameters, estimate_multipliers
        )

    # -- what the solve session asks of a mesh (ocpkit.transcription.session): each phase's, in phase order ---------
    def _mesh_fractions(self, solution: MultiPhaseSolution) -> np.ndarray:
        span = solution.tf - solution.t0
        return np.concatenate([np.diff(p.estimate_intervals) / span for p in solution.phases])

    def _path_where(self, solution: MultiPhaseSolution) -> np.ndarray:
        # a phase without path constraints has none violated (NaN from path_violations would blind the others')
        where = np.vstack([ph._path_where(p) for ph, p in zip(self.phases, solution.phases)])
        where[:, 1] = np.nan_to_num(where[:, 1], nan=0.0)
        return where

    def _cuts(self, solution: MultiPhaseSolution) -> list[np.ndarray]:
        return [c for ph, p in zip(self.phases, solution.phases) for c in ph._cuts(p)]

    def _refinement_hint(self, solution: MultiPhaseSolution) -> str:
        hints = [(name, ph._refinement_hint(p)) for name, ph, p in zip(self.names, self.phases, solution.phases)]
        return "; ".join(f"phase {name}: {h}" for name, h in hints if h)

    def _warn_if_inaccurate(self, solution: MultiPhaseSolution, threshold: float) -> None:
        for name, ph, p in zip(self.names, self.phases, solution.phases):
            ph._warn_if_inaccurate(p, threshold, label=f"phase {name!r}, {ph.label}", stacklevel=6)

    def refine(
        self, errors: np.ndarray, tolerance: float, cuts: Sequence[np.ndarray | Sequence[float]] | None = None
    ) -> MultiPhase:
        """The same phases, links, cost and constraints, each phase's mesh refined by its own :meth:`refine` on its
        share of ``errors`` and ``cuts`` (per estimate interval, in phase order); a phase left as it was keeps its
        transcription."""
        counts = self._estimate_counts
        if counts is None or int(sum(counts)) != len(errors):
            raise ValueError(f"{len(errors)} interval errors for phases of {counts} estimate intervals: solve first")
        bounds = np.concatenate([[0], np.cumsum(counts)])
        per_interval: list[Any] = [None] * len(errors) if cuts is None else list(cuts)
        phases = {}
        for k, (name, ph) in enumerate(zip(self.names, self.phases)):
            part = slice(bounds[k], bounds[k + 1])
            new = ph.refine(np.asarray(errors[part]), tolerance, per_interval[part])
            phases[name] = ph if session._same_mesh(new, ph) else new
        refined = MultiPhase(phases, **self._options)
        refined.cut_times = self.cut_times
        return refined

    # -- the solution ------------------------------------------------------------------------
    def _phase_objective(self, k: int, w: np.ndarray) -> float:
        """Phase ``k``'s objective at ``w``: the sum of its objective blocks, in the problem's units."""
        ph = self.phases[k]
        total = 0.0
        for b in ph._blocks():
            if b.rows is None:
                count = b.variables.shape[1]
                Z = w[b.variables + self.variable_offsets[k]]
                total += float(np.sum(np.asarray(b.function.map(count)(Z, b.constants))))
        return total * ph.problem.objective_scale

    def _solution(self, result: NLPResult) -> MultiPhaseSolution:
        g = np.asarray(self.nlp.constraint_function(result.w)).ravel()
        phases = []
        for k, ph in enumerate(self.phases):
            v = slice(self.variable_offsets[k], self.variable_offsets[k] + ph.n_variables)
            r = slice(self.row_offsets[k], self.row_offsets[k] + ph.n_constraints)
            to_phase = self.objective_scale / ph.problem.objective_scale  # multipliers in the phase's own scale
            part = NLPResult(
                w=result.w[v],
                objective=self._phase_objective(k, result.w) / ph.problem.objective_scale,
                lam_g=result.lam_g[r] * to_phase,
                lam_w=result.lam_w[v] * to_phase,
                status=result.status,
                iterations=result.iterations,
                solve_s=result.solve_s,
                success=result.success,
                stats=result.stats,
            )
            sol = ph._solution(part, g[r])
            sol.build_s = self.build_s
            phases.append(sol)
        self._estimate_counts = [len(p.estimate_intervals) - 1 for p in phases]
        link_rows = slice(self.n_constraints - self.n_link_rows, self.n_constraints)
        lo, hi = (b[link_rows] for b in self._constraint_bounds())
        link = g[link_rows]
        trajectory_cost = 0.0
        if self._cost is not None:
            z, _, variables, values, _, _ = self._ends
            trajectory_cost = float(self._cost(result.w[variables], values))
        return MultiPhaseSolution(
            phases=phases,
            links=self.links,
            status=result.status,
            iterations=result.iterations,
            objective=float(sum(p.objective for p in phases)) + trajectory_cost,
            trajectory_cost=trajectory_cost,
            decision_variables=self.n_variables - sum(len(ph.problem.parameters) for ph in self.phases),
            constraints=self.n_constraints,
            build_s=self.build_s,
            solve_s=result.solve_s,
            converged=result.success,
            link_residual=float(np.max(np.maximum(lo - link, link - hi), initial=0.0)),
            parameters=self._trajectory_parameters(phases),
            names=list(self.names),
            objective_scale=self.objective_scale,
            raw={"w": result.w, "lam_g": result.lam_g, "lam_w": result.lam_w, "transcription": self},
        )

    def _trajectory_parameters(self, phases: Sequence[Solution]) -> dict[str, float]:
        """The solved free parameters of the trajectory: each shared one once, and each that one phase alone names;
        phase-local ones (``local_parameters`` named by several phases) are in ``phases[k].parameters``."""
        count: dict[str, int] = {}
        for ph in self.phases:
            for v in ph.problem.free_parameters:
                count[v.name] = count.get(v.name, 0) + 1
        out: dict[str, float] = {}
        for sol in phases:
            for name, value in sol.parameters.items():
                if name in self._shared or count[name] == 1:
                    out.setdefault(name, value)
        return out


@dataclass
class MultiPhaseSolution(Trajectory):
    """The solution of a :class:`MultiPhase` problem.

    ``phases``: each phase's :class:`~ocpkit.Solution` (its objective is the phase's share);
    ``objective``: their sum, plus ``trajectory_cost`` (the value of :class:`MultiPhase`'s ``cost``); ``status``, ``iterations``, ``converged``, ``build_s``,
    ``solve_s``, ``decision_variables`` and ``constraints`` of the one NLP; ``link_residual``:
    the largest scaled violation of the links, the shared parameters' rows and the linkage constraints;
    ``names``: the phases' names (:meth:`phase` gives a phase's solution by name);
    ``parameters``: the solved free parameters of the trajectory (each shared one once). As a :class:`~ocpkit.Trajectory` it spans
    ``[phases[0].t0, phases[-1].tf]`` (phases that share their state and control names),
    the later phase holding at a shared time; :meth:`reintegrate` flies each phase
    from its own initial state (a link may jump).
    """

    phases: list[Solution]
    links: list[Link]
    status: str
    iterations: int
    objective: float
    #: the one NLP's free variables (``nlp_parameters`` is its deprecated name)
    decision_variables: int
    constraints: int
    build_s: float
    solve_s: float
    converged: bool
    link_residual: float
    #: the solved free parameters of the trajectory by name (each shared one once)
    parameters: dict[str, float] = field(default_factory=dict)
    trajectory_cost: float = 0.0
    names: list[str] = field(default_factory=list)
    objective_scale: float = 1.0
    #: the NLP vector, IPOPT's multipliers and the :class:`MultiPhase` solved (an exact warm start of it)
    raw: dict[str, Any] = field(default_factory=dict, repr=False)
    #: a refined solve's meshes and how it ended, as :class:`~ocpkit.Solution`'s
    mesh_history: list[Any] | None = field(default=None, repr=False)
    refinement_outcome: str | None = field(default=None, repr=False)
    refinement_reason: str = field(default="", repr=False)

    @property
    def linear_solver(self) -> str:
        """IPOPT's linear solver and its ordering in this solve (:attr:`ocpkit.Solution.linear_solver`)."""
        return str(self.raw.get("linear_solver", ""))

    def __post_init__(self) -> None:
        first = self.phases[0].problem
        self.problem = first
        self.t0 = self.phases[0].t0
        self.tf = self.phases[-1].tf
        self.breakpoints = unique(np.concatenate([p.breakpoints for p in self.phases]))
        self._uniform = all(
            (p.problem.state_names, p.problem.control_names) == (first.state_names, first.control_names)
            for p in self.phases
        )

    @property
    def nlp_parameters(self) -> int:
        """Deprecated name of :attr:`decision_variables`."""
        renamed("MultiPhaseSolution.nlp_parameters", "MultiPhaseSolution.decision_variables")
        return self.decision_variables

    def value(self, what: str | Callable[..., Any]) -> float | np.ndarray:
        """:meth:`Trajectory.value`, with the trajectory's parameters (:attr:`parameters`) by name too."""
        if isinstance(what, str) and what in self.parameters:
            return float(self.parameters[what])
        return super().value(what)

    def phase(self, key: str | int) -> Solution:
        """A phase's solution by name or index."""
        if isinstance(key, str):
            if key not in self.names:
                raise KeyError(f"unknown phase {key!r}; the phases are {self.names}")
            key = self.names.index(key)
        return self.phases[key]

    def _phase_of(self, t: np.ndarray) -> np.ndarray:
        starts = np.array([p.t0 for p in self.phases])
        return np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.phases) - 1)

    def _piecewise(self, t: ArrayLike, what: str) -> np.ndarray:
        if not self._uniform:
            raise ValueError("the phases have different states or controls: evaluate phases[k] instead")
        t = np.asarray(t, dtype=float)
        flat = t.ravel()
        k = self._phase_of(flat)
        dim = getattr(self.phases[0], what)(np.array([self.phases[0].t0])).shape[-1]
        out = np.empty((flat.size, dim))
        for j in unique(k):
            ph = self.phases[j]
            sel = k == j
            out[sel] = getattr(ph, what)(np.clip(flat[sel], ph.t0, ph.tf))
        return out.reshape(t.shape + (dim,))

    def _state(self, t: np.ndarray) -> np.ndarray:
        return self._piecewise(t, "state")

    def _control(self, t: np.ndarray) -> np.ndarray:
        return self._piecewise(t, "control")

    def sample(
        self, expr: Callable[..., Any], grid: ArrayLike | None = None, n: int = 401
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(t, values)`` of ``expr(x, u, t[, p])`` (:meth:`Trajectory.sample`), each time in its phase (the later one at
        a shared time), each phase with its own variables and parameters and the trajectory's (:attr:`parameters`)."""
        t = self.time_grid(n) if grid is None else self._check_times(grid)
        if t.size == 0:
            return t, self.phases[0]._sample(expr, t, self.parameters)
        flat = t.ravel()
        k = self._phase_of(flat)
        parts = {
            j: self.phases[j]._sample(
                expr, np.clip(flat[k == j], self.phases[j].t0, self.phases[j].tf), self.parameters
            )
            for j in unique(k)
        }
        first = next(iter(parts.values()))
        out = np.empty((flat.size,) + first.shape[1:])
        for j, values in parts.items():
            out[k == j] = values
        return t, out.reshape(t.shape + first.shape[1:])

    @property
    def error_estimate(self) -> float:
        """The largest of the phases' estimated relative state errors (:attr:`Solution.error_estimate`)."""
        return max(p.error_estimate for p in self.phases)

    @property
    def interval_errors(self) -> np.ndarray:
        """Every phase's :attr:`Solution.interval_errors`, in phase order."""
        return np.concatenate([p.interval_errors for p in self.phases])

    @cached_property
    def accuracy(self) -> MultiPhaseAccuracy:
        """Every part of the estimated error, over the phases (:class:`ocpkit.accuracy.MultiPhaseAccuracy`)."""
        from ..accuracy import MultiPhaseAccuracy

        return MultiPhaseAccuracy(self)

    def reintegrate(
        self, rtol: float = 1e-12, atol: float = 1e-12, n: int = 2001, controls: str = "bounded"
    ) -> Reintegration:
        """Each phase re-integrated from its own initial state (a link may jump), as one
        :class:`~ocpkit.Reintegration` over the phases' times (phases with the same states; otherwise
        ``phases[k].reintegrate()``). ``n`` points per phase."""
        if not all(p.problem.state_names == self.phases[0].problem.state_names for p in self.phases):
            raise ValueError("the phases have different states: reintegrate each, phases[k].reintegrate()")
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

    def flown_trajectory_cost(self) -> float:
        """The trajectory-level cost on the flown trajectory (0 without one): each phase's admissible control flown
        (:func:`ocpkit.flight.fly`) from its linked start, the previous phases' flown end plus the link's jump
        (its own NLP start in the states no link sets), so that a cost at a cut time (``ends.at(t)``) sees the
        flown state there; its part of :attr:`accuracy`'s objective."""
        mp = self.raw.get("transcription")
        if mp is None or mp._cost is None:
            return 0.0
        from ..flight import fly

        w = np.array(self.raw["w"], dtype=float)
        flown_ends: dict[int, np.ndarray] = {}
        for k, (ph, p) in enumerate(zip(mp.phases, self.phases)):
            first, last, _ = ph._boundary_indices()
            x0 = np.array(p.initial_state(), dtype=float)
            for link, joined in zip(mp.links, mp._link_states):
                if link.after == k and link.before in flown_ends:
                    for i_before, i_after, name in joined:
                        x0[i_after] = flown_ends[link.before][i_before] + float(link.jumps.get(name, 0.0))
            xf = fly(p, x0=x0).final_state
            flown_ends[k] = xf
            scaling = ph.problem.state_scaling
            w[mp.variable_offsets[k] + first] = scaling.to_nlp(x0)
            w[mp.variable_offsets[k] + last] = scaling.to_nlp(xf)
        _, _, variables, values, _, _ = mp._ends
        return float(mp._cost(w[variables], values))

    def _reintegrations(self, **options: Any) -> list[Reintegration]:
        return [p.reintegrate(**options) for p in self.phases]

    def max_reintegration_error(self, **kwargs: Any) -> float:
        """The largest re-integration error over the phases (units of each phase's state scales)."""
        return max(r.max_error for r in self._reintegrations(**kwargs))


__all__ = ["Link", "MultiPhase", "MultiPhaseSolution", "PhaseEnds", "PhasesEnds"]
