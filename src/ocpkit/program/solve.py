"""The solve policy of a :class:`~ocpkit.program.Program`: one solve, a warm start, a mesh refinement.

:func:`solve` is :meth:`Program.solve <ocpkit.program.Program.solve>`: the parameters checked, one IPOPT solve
(:func:`solve_once`: an exact warm start from a solution of the same program, or a start interpolated onto the mesh)
or a mesh refinement (:func:`solve_refined`: each mesh a program of the refined schemes, warm-started from the
previous solution with multiplier estimates), the failure policy of :func:`settle`, and the accuracy warnings (each
phase's estimate, path constraints between the points). It records on every solution it returns how it was solved
(:attr:`~ocpkit.Solution.solve_options`, :attr:`~ocpkit.Solution.linear_solver`), so that the same NLP can be solved
again as it was.
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._deprecation import renamed
from .._warnings import user_stacklevel
from ..accuracy import (
    AccuracyWarning,
    control_switches,
    path_junctions,
    path_violations,
    refinement_hint,
)
from ..errors import SolverError
from ..nlp import WARM_START, NLPResult, failure_hint, linear_solver, solve_nlp
from ..solution import Solution, SolveOptions
from ..verdict import SolutionNote, VerdictKind, check_kind
from .safeguard import control_safeguard, held_controls

if TYPE_CHECKING:
    from .program import Program


def settle(result: NLPResult, package: Callable[[NLPResult], Solution], raise_on_failure: bool) -> Solution:
    """The solution of an IPOPT result (``package(result)``), or :class:`SolverError` naming the status.

    A failed solve raises, with the last iterate attached, unless ``raise_on_failure`` is False
    (then the last iterate is returned, ``converged=False``); a non-finite iterate always raises.
    """
    solution = package(result) if np.all(np.isfinite(result.w)) else None
    if result.success:
        return solution  # type: ignore[return-value]  # (a successful iterate is finite)
    if raise_on_failure or solution is None:
        detail = failure_hint(result.status) if solution is not None else "the last iterate is not finite"
        raise SolverError("IPOPT", result.status, result.iterations, detail, result=solution)
    return solution


@dataclass(frozen=True)
class MeshIteration:
    """One solve of a mesh refinement: the mesh (interval lengths as fractions of ``tf - t0``), its size, the
    solution's error estimate, IPOPT's iterations and the times (build of this mesh, its start, IPOPT, the verdict,
    the whole iteration)."""

    iteration: int
    transcription: str
    fractions: np.ndarray
    collocation_points: int
    #: the NLP's free variables on this mesh (``nlp_parameters`` is its deprecated name)
    decision_variables: int
    error_estimate: float
    ipopt_iterations: int
    build_s: float
    solve_s: float
    total_s: float
    #: the parts of the estimate over the tolerance (:meth:`ocpkit.accuracy.Accuracy.failing`) when the state part
    #: met it; empty where the state part did not (the other parts are not computed then) or all met it
    failing: tuple[str, ...] = ()
    #: what drives the refinement on this mesh, which the stall rule follows (the state part while it is over the
    #: tolerance, else the largest of the others: path violations between points, the objective)
    worst: float = float("nan")
    #: how this mesh was started where it was not warm-started from the previous one, ``""`` (the first mesh from
    #: the guess, or a warm start), ``"cold start"`` or ``"uniform mesh"`` (a recovery, :data:`RECOVERIES`)
    recovery: str = ""
    #: the wall time of this mesh's start (the previous mesh's solution, or the first mesh's guess, interpolated onto
    #: it, and its multipliers estimated by :meth:`~ocpkit.nlp.SeparableNLP.multiplier_estimate`); NaN after a
    #: recovery (``recovery`` says which; its reason, what failed) and from a solution of the same mesh (an exact start)
    start_s: float = float("nan")
    #: the wall time of what the refinement computes about this mesh's solution (the interval estimates, the path
    #: constraints between the points, the flown objective once the state meets the tolerance)
    verdict_s: float = float("nan")
    #: IPOPT iterations spent in this mesh iteration on solves whose result was discarded (a warm start that failed,
    #: replaced by the interpolated point alone; of a runaway control's two solves, unbounded and in its box, the one
    #: not kept; a start that failed, and the recoveries tried in vain, before the recovery that solved the mesh,
    #: ``recovery``; recoveries tried in vain after a stall, as an early restart, or after a failed start none
    #: rescued), their time in ``total_s``, not ``solve_s``
    discarded_iterations: int = 0
    #: IPOPT's linear solver and ordering on this mesh (:attr:`Solution.linear_solver <ocpkit.Solution.linear_solver>`):
    #: a refinement that grows past :data:`~ocpkit.program.program.SHARED_COLUMN_POINTS` changes ordering there
    linear_solver: str = ""

    @property
    def nlp_parameters(self) -> int:
        """Deprecated name of :attr:`decision_variables`."""
        renamed("MeshIteration.nlp_parameters", "MeshIteration.decision_variables")
        return self.decision_variables


def solve(
    program: Program,
    guess: Any,
    *,
    ipopt_options: dict[str, Any] | None,
    allow_acceptable: bool,
    raise_on_failure: bool,
    error_threshold: float | None,
    mesh_tolerance: float | None,
    max_mesh_iterations: int,
    parameters: Mapping[str, float] | None,
    verdict: VerdictKind = "whole",
) -> Solution:
    """The solve policy (the module docstring; the options are :meth:`Program.solve
    <ocpkit.program.Program.solve>`'s)."""
    check_kind(verdict)
    if parameters is not None:
        program.check_parameters(parameters)  # names checked before anything is built
    if mesh_tolerance is not None:
        options = dict(ipopt_options=ipopt_options, allow_acceptable=allow_acceptable)
        solution = solve_refined(
            program, guess, mesh_tolerance, max_mesh_iterations, options, raise_on_failure, parameters
        )
        solution.held_controls = held_controls(solution)
        solution.verdict_tolerance, solution.verdict_kind = mesh_tolerance, verdict
        if solution.converged:
            # the refinement's own warning says which parts it did not meet: the notes are what is left to say
            for note in (n for n in solution.verdict.notes if not n.quiet):
                warnings.warn(str(note), SolutionNote, stacklevel=user_stacklevel())
        ipopt_options = refinement_ipopt_options(ipopt_options, mesh_tolerance)  # as its meshes were solved
    else:
        solution = solve_once(program, guess, ipopt_options, allow_acceptable, raise_on_failure, parameters)
        solution.held_controls = held_controls(solution)
        solution.verdict_kind = verdict
        if error_threshold is not None:
            solution.verdict_tolerance = error_threshold
            if solution.converged:
                solution.verdict.warn(stacklevel=user_stacklevel())
    record_solve(solution, ipopt_options, allow_acceptable)
    return solution


def record_solve(solution: Solution, ipopt_options: dict[str, Any] | None, allow_acceptable: bool) -> None:
    """Record on ``solution`` how it was solved: its :attr:`~ocpkit.Solution.solve_options`, for a re-solve of the
    same NLP (ocpkit.indirect re-solves from an extremal), and its :attr:`~ocpkit.Solution.linear_solver`, the linear
    algebra it ran with (a refinement's last mesh: the solution's own)."""
    solution.solve_options = SolveOptions(dict(ipopt_options or {}), allow_acceptable)
    solution.linear_solver = linear_solver(solution.program.effective_ipopt_options(ipopt_options))


def exact_start(program: Program, guess: object) -> NLPResult | None:
    """The NLP iterate and IPOPT's multipliers of a solution of this same program (its exact warm start), else
    None: the one rule of every solve and loop."""
    return guess.nlp_result if isinstance(guess, Solution) and guess.program is program else None


def solve_once(
    program: Program,
    guess: Any,
    ipopt_options: dict[str, Any] | None,
    allow_acceptable: bool,
    raise_on_failure: bool,
    parameters: Mapping[str, float] | None = None,
    estimate_multipliers: bool = False,
    record: StartRecord | None = None,
) -> Solution:
    """One IPOPT solve of ``program``. From a solution of this same program: its exact warm start (its NLP vector and
    IPOPT's multipliers, with :data:`~ocpkit.nlp.WARM_START`). From a solution of another mesh with
    ``estimate_multipliers``: the interpolated point with first-order multiplier estimates
    (:meth:`~ocpkit.nlp.SeparableNLP.multiplier_estimate`) and :data:`~ocpkit.nlp.WARM_START`, falling back to the
    interpolated point alone if that solve fails. The failure policy is :func:`settle`'s. ``record``, where given,
    receives the start's time and a discarded warm start's iterations."""
    record = StartRecord() if record is None else record
    lbw, ubw = program.bounds(parameters)
    lbg, ubg = program.constraint_bounds()

    def run(
        w0: np.ndarray,
        options: dict[str, Any] | None,
        multipliers: tuple[np.ndarray, np.ndarray] | None = None,
        bounds: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> NLPResult:
        lam_g0, lam_w0 = multipliers if multipliers is not None else (None, None)
        lb, ub = bounds if bounds is not None else (lbw, ubw)
        solver = program.solver(options)
        return solve_nlp(
            solver,
            np.clip(w0, lb, ub),
            lb,
            ub,
            lbg,
            ubg,
            allow_acceptable=allow_acceptable,
            lam_w0=lam_w0,
            lam_g0=lam_g0,
        )

    guard = control_safeguard(program)

    def held(result: NLPResult, w0: np.ndarray) -> NLPResult:
        # an unbounded control that ran away is solved again from the same start in its box (.safeguard); of the
        # two solves, the one not kept is discarded (its iterations are the record's)
        if guard is None or not guard.exceeded(result.w):
            return result
        boxed = run(w0, ipopt_options, bounds=guard.bounds(lbw, ubw))
        kept = kept_of(result, boxed)
        record.discarded_iterations += (boxed if kept is result else result).iterations
        return kept

    def kept_of(result: NLPResult, boxed: NLPResult) -> NLPResult:
        assert guard is not None  # (held solved in the box only where there is one)
        if not result.success or (boxed.success and not guard.on_box(boxed.w)):
            return boxed if boxed.success or not result.success else result
        if not boxed.success:
            return result
        # both converged, the box binding: the one the mesh resolves better (a legitimate large control's
        # unbounded solution, or the box's where the unbounded one exploits the scheme)
        errors = [_largest_estimate(program.solution(r)) for r in (result, boxed)]
        return boxed if errors[1] < errors[0] else result

    warm_options = {**WARM_START, **(ipopt_options or {})}
    previous = exact_start(program, guess)
    if previous is not None:
        result = run(np.clip(previous.w, lbw, ubw), warm_options, (previous.lam_g, previous.lam_w))
        return settle(result, program.solution, raise_on_failure)
    program.build()  # (its time is the mesh's build_s, not its start's)
    started = time.perf_counter()
    w0 = np.clip(program.initial_point(guess), lbw, ubw)
    if estimate_multipliers and isinstance(guess, Solution):
        # a solution that reaches the box (a previous mesh held there) starts in it, not from a runaway
        boxed = guard is not None and guard.reaches(w0)
        lb, ub = guard.bounds(lbw, ubw) if guard is not None and boxed else (lbw, ubw)
        multipliers = program.nlp.multiplier_estimate(np.clip(w0, lb, ub), lb, ub)
        record.start_s = time.perf_counter() - started
        result = run(w0, warm_options, multipliers, (lb, ub))
        if result.success:
            return settle(result if boxed else held(result, w0), program.solution, raise_on_failure)
        record.discarded_iterations += result.iterations
    else:
        record.start_s = time.perf_counter() - started
    return settle(held(run(w0, ipopt_options), w0), program.solution, raise_on_failure)


@dataclass
class StartRecord:
    """How a mesh was started: the start's wall time (interpolation, multiplier estimates) and the IPOPT iterations
    discarded on the way (:func:`solve_once`'s failed warm start, and the solve a runaway control's box replaced or
    did not; the refinement adds a failed start's and the recoveries' tried in vain), which a :class:`MeshIteration`
    reports."""

    start_s: float = float("nan")
    discarded_iterations: int = 0


def _largest_estimate(solution: Solution) -> float:
    estimate = np.asarray(solution.interval_errors, dtype=float)
    return float(np.max(np.where(np.isfinite(estimate), estimate, np.inf))) if estimate.size else 0.0


# -- what refinement asks of a solution, phase by phase ------------------------------------------------------------------
def mesh_fractions(solution: Solution) -> np.ndarray:
    """The solution's estimate intervals as fractions of its time span (a refinement's history), phase by phase."""
    span = solution.tf - solution.t0
    return np.concatenate([np.diff(p.estimate_intervals) / span for p in solution.phases])


def path_where(solution: Solution) -> np.ndarray:
    """Per estimate interval, phase by phase, ``(position of its worst path violation, its size)``
    (:func:`~ocpkit.accuracy.path_violations`); nothing violated where a phase has no path constraints."""
    where = np.vstack([path_violations(p, p.estimate_intervals)[2] for p in solution.phases])
    where[:, 1] = np.nan_to_num(where[:, 1], nan=0.0)
    return where


def cuts(solution: Solution) -> list[list[np.ndarray]]:
    """Per phase, per estimate interval, where the next mesh cuts it: control switches and path-constraint
    junctions."""
    out = []
    for p in solution.phases:
        switches = control_switches(p, p.estimate_intervals)
        junctions = path_junctions(p, p.estimate_intervals)
        out.append([np.union1d(a, b) for a, b in zip(switches, junctions)])
    return out


def hint(solution: Solution) -> str:
    """What may keep the estimate from falling (:func:`~ocpkit.accuracy.refinement_hint`), phase by phase."""
    if solution.single:
        return refinement_hint(solution.phases[0])
    hints = [(p.name, refinement_hint(p)) for p in solution.phases]
    return "; ".join(f"phase {name}: {h}" for name, h in hints if h)


def _split(values: np.ndarray | Sequence[Any], counts: Sequence[int]) -> list[Any]:
    bounds = np.concatenate([[0], np.cumsum(counts)]).astype(int)
    return [values[a:b] for a, b in zip(bounds[:-1], bounds[1:])]


#: IPOPT's ``bound_relax_factor``: it relaxes every bound, a variable's or an inequality constraint's, by this much
#: (relative to the bound's size, absolute below one), so that a converged solution may lie that far beyond an
#: active bound, and its cost be better than the optimum by the bound's multiplier times as much
IPOPT_BOUND_RELAX = 1e-8
#: A refinement to ``mesh_tolerance`` relaxes IPOPT's bounds by at most this share of it (:func:`refinement_ipopt_options`)
BOUND_RELAX_SHARE = 1e-2


def refinement_ipopt_options(ipopt_options: dict[str, Any] | None, tolerance: float) -> dict[str, Any] | None:
    """The IPOPT overrides of a refinement to ``tolerance``: ``ipopt_options`` with ``bound_relax_factor`` at
    :data:`BOUND_RELAX_SHARE` times the tolerance where that is below IPOPT's :data:`IPOPT_BOUND_RELAX`, unless the
    overrides set it.

    Below about 1e-7 the relaxation is what the verdict measures: the path constraints between the points and the
    flown objective keep IPOPT's 1e-8 however fine the mesh. Rayleigh's problem with its mixed constraint, refined
    with HLGL to 1e-9 under IPOPT's default, grew from 720 to 14,108 points with the path violation at 2.3e-9 (not met
    after 15 meshes); with the bound relaxed by 1e-11 it meets 1e-9 on 216 points. Bryson-Denham's cost to 1e-8 is
    4 - 2.7e-7 under the default and 4 - 8.9e-9 with the bounds relaxed by 1e-10 (its optimum is 4)."""
    relax = BOUND_RELAX_SHARE * tolerance
    if (ipopt_options and "bound_relax_factor" in ipopt_options) or relax >= IPOPT_BOUND_RELAX:
        return ipopt_options
    return {**(ipopt_options or {}), "bound_relax_factor": relax}


def solve_refined(
    program: Program,
    guess: Any,
    tolerance: float,
    max_iterations: int,
    options: dict[str, Any],
    raise_on_failure: bool,
    parameters: Mapping[str, float] | None,
) -> Solution:
    """Solve and refine ``program`` until every part of the error estimate meets ``tolerance`` (:meth:`Program.solve
    <ocpkit.program.Program.solve>`'s ``mesh_tolerance``), with the history and the outcome on the returned
    solution."""
    if not (tolerance > 0 and np.isfinite(tolerance)):
        raise ValueError(f"mesh_tolerance must be positive, got {tolerance!r}")
    if max_iterations < 1:
        raise ValueError(f"max_mesh_iterations must be at least 1, got {max_iterations!r}")
    options = {**options, "ipopt_options": refinement_ipopt_options(options["ipopt_options"], tolerance)}
    mesh = program
    history: list[MeshIteration] = []
    solution: Solution | None = None
    best: Solution | None = None
    outcome, reason = "met", ""
    recoveries: list[str] = []  # what each recovery was taken for, and how
    tried = ""  # the recoveries tried in vain, for the outcome's reason
    # a recovery taken after a stall or a divergence (:func:`_diverged`): the next mesh iteration's solution, its
    # recovery, its start time and the IPOPT iterations of the recoveries tried in vain before it
    pending: tuple[Solution, str, float, int] | None = None
    since = 0  # the stall rule counts the meshes since the last recovery
    # the solution a stall's (or a divergence's) recovery set out from, its reason, its mesh count and what the
    # recovery was: where the refinement from the recovery ends in a failure, the refinement ends as that stall did
    # (a recovery never makes an outcome worse)
    stall: tuple[Solution, str, int, str] | None = None
    restarted_early = False  # the early restart of a diverging refinement (:func:`_diverged`) is tried once
    in_vain = ""  # what that restart tried, where it did no better (said in the outcome's reason)
    for iteration in range(max_iterations):
        start = time.perf_counter()
        recovery = ""
        started = StartRecord()
        if pending is not None:
            solution, recovery, start, started.discarded_iterations = pending
            mesh, pending = solution.program, None
        else:
            failure: SolverError | None = None
            try:
                solution = solve_once(
                    mesh,
                    guess if solution is None else solution,
                    options["ipopt_options"],
                    options["allow_acceptable"],
                    raise_on_failure,
                    parameters,
                    estimate_multipliers=True,
                    record=started,
                )
            except SolverError as exc:
                failure = exc
            except Exception as exc:  # noqa: BLE001 - any failure inside refinement is reported with what it had
                if not history:  # the first mesh: the solve's own error (bad input)
                    raise
                raise _refinement_failure(exc, iteration, mesh, best, history) from exc
            failed = failure is not None or solution is None or not solution.converged
            if history and failed and len(recoveries) < MAX_RECOVERIES:
                status = failure.status if failure is not None else getattr(solution, "status", "")
                order = _recoveries_from(history[-1])  # the mesh whose solution the failed start came from
                # the failed start's iterations (its warm start's, and its start from the interpolated point's)
                failed_start = started.discarded_iterations + _iterations_of(failure, None if failure else solution)
                rescued, tried, in_vain_iterations = _recover(
                    mesh, guess, options, parameters, math.inf, history[0], order
                )
                if rescued is not None:
                    solution, recovery = rescued
                    # the recovery's solve, not the failed start's: its iterations and the tries before it discarded
                    started = StartRecord(discarded_iterations=failed_start + in_vain_iterations)
                    recoveries.append(
                        f"mesh iteration {iteration} ({mesh.label}) failed from the previous mesh's solution "
                        f"({status}): {_RECOVERED[recovery]} ({solution.program.label})"
                    )
                    mesh, failure, since = solution.program, None, len(history)
                else:  # the recoveries' iterations, in this mesh iteration's time (its record, where it gets one)
                    started.discarded_iterations += in_vain_iterations
            if failure is not None:
                if not history:  # the first mesh: the solve's own error (IPOPT's status)
                    raise failure
                if stall is not None:
                    solution, history = _fall_back(stall, best, history)
                    outcome, reason = "stalled", _after_stall(stall, iteration, mesh, failure)
                    reason = _and(reason, in_vain)
                    warnings.warn(reason, AccuracyWarning, stacklevel=user_stacklevel())
                    break
                raise _refinement_failure(
                    failure, iteration, mesh, best, history, tried=_and(tried, in_vain)
                ) from failure
        assert solution is not None  # (solved, recovered, or raised above)
        estimated_from = time.perf_counter()
        try:
            estimate = solution.interval_errors
        except Exception as exc:  # noqa: BLE001
            if not history:
                raise
            raise _refinement_failure(exc, iteration, mesh, best, history) from exc
        estimate_s = time.perf_counter() - estimated_from
        history.append(
            MeshIteration(
                iteration,
                mesh.label,
                mesh_fractions(solution),
                mesh.n_collocation_points,
                solution.decision_variables,
                float(estimate.max()),
                solution.iterations,
                mesh.build_s,
                solution.solve_s,
                time.perf_counter() - start,
                recovery=recovery,
                start_s=started.start_s,
                discarded_iterations=started.discarded_iterations,
                linear_solver=linear_solver(solution.program.effective_ipopt_options(options["ipopt_options"])),
            )
        )
        # an interval whose estimate is not a number (NaN states) is treated as far over the tolerance
        errors = np.where(np.isfinite(estimate), estimate, 1e3)
        if solution.converged and (best is None or errors.max() <= _worst(_history_of(best)[-1])):
            best = solution
            best.mesh_history = list(history)
        if not solution.converged:
            if stall is not None:
                failed_on = solution.status
                solution, history = _fall_back(stall, best, history)
                outcome, reason = "stalled", _and(_after_stall(stall, iteration, mesh, failed_on), in_vain)
                warnings.warn(reason, AccuracyWarning, stacklevel=user_stacklevel())
                break
            outcome, reason = "failed", f"IPOPT's status {solution.status} on {mesh.label}"
            if tried:
                reason = f"{reason}; recovery tried in vain: {tried}"
            reason = _and(reason, in_vain)
            break
        target = path_target = tolerance
        verdict_from = time.perf_counter()
        try:
            # path constraints between points at every mesh (cheap); the objective once the state meets the
            # tolerance (it integrates the flown control)
            where = path_where(solution)
            accuracy = solution.accuracy if errors.max() <= tolerance else None
        except Exception as exc:  # noqa: BLE001
            raise _refinement_failure(exc, iteration, mesh, best, history) from exc
        done = time.perf_counter()
        history[-1] = dataclasses.replace(history[-1], verdict_s=estimate_s + done - verdict_from, total_s=done - start)
        if best is solution:  # with this mesh's times (a fall-back returns it; its stall rule reads no time)
            best.mesh_history = list(history)
        # what drives this refinement: the state while it is over the tolerance, else the other parts
        worst = float(errors.max())
        if accuracy is not None:
            failing = accuracy.failing(tolerance)
            if not failing:
                break
            worst = max(float(np.max(where[:, 1], initial=0.0)), accuracy.objective)
            if "objective" in failing and accuracy.objective > 0:
                flown = abs(accuracy.objective_flown - accuracy.objective_nlp)
                if accuracy.objective_path > flown:
                    # what the violations between points are worth in cost: they must fall by its excess
                    largest = float(np.max(where[:, 1], initial=0.0))
                    path_target = max(min(largest, tolerance) * tolerance / accuracy.objective, 1e-3 * tolerance)
                else:
                    # the state error drives the objective's: tighten by the excess (at most a thousandfold)
                    target = tolerance * max(min(1.0, accuracy.state / accuracy.objective), 1e-3)
            history[-1] = dataclasses.replace(history[-1], failing=tuple(failing), worst=worst)
        else:
            history[-1] = dataclasses.replace(history[-1], worst=worst)
        # an interval whose path constraints are violated between its points by more than their target is
        # refined as if that violation were its error: on a constrained arc the constraint oscillates about its
        # bound between the points, by less as the degree rises or the interval shrinks; where an arc begins or
        # ends, path_junctions cuts the interval there instead
        violated = where[:, 1] > path_target
        errors = np.where(violated, np.maximum(errors, where[:, 1] * target / path_target), errors)
        stalled = _stalled(history[since:])
        diverged = "" if stalled or restarted_early else _diverged(history[since:])
        if diverged and len(recoveries) < MAX_RECOVERIES and iteration + 1 < max_iterations:
            # a mesh refined from a spurious optimum inherits it (DIVERGED_ESTIMATE): restart now, on a uniform mesh
            # first (the mesh holds the artefact), not five meshes later; a restart must bring the estimate below
            # order one, and where none does, the refinement goes on from this mesh
            recovering, restarted_early = time.perf_counter(), True
            bar = min(STALL_FALL * history[-1].error_estimate, DIVERGED_ESTIMATE)
            order = _recoveries_from(history[-1])  # (its estimate is of order one: the uniform mesh first)
            rescued, tried_early, in_vain_iterations = _recover(
                mesh, guess, options, parameters, bar, history[0], order
            )
            diverged_at = f"{diverged} on mesh iteration {iteration} ({mesh.label})"
            if rescued is not None:
                recoveries.append(f"{diverged_at}: {_RECOVERED[rescued[1]]} ({rescued[0].program.label})")
                pending, since = (*rescued, recovering, in_vain_iterations), len(history)
                diverged_reason = f"{program.label}: mesh refinement diverged short of {tolerance:g}"
                stall = (solution, diverged_reason, len(history), "the refinement from its early restart")
                continue
            in_vain = f"an early restart did no better ({diverged_at}): {tried_early}"
            history[-1] = _charged(history[-1], time.perf_counter() - recovering, in_vain_iterations)
            if best is solution:  # (its history, with the restarts' time and iterations)
                best.mesh_history = list(history)
        if stalled and len(recoveries) < MAX_RECOVERIES and iteration + 1 < max_iterations:
            recovering = time.perf_counter()
            order = _recoveries_from(history[-1])
            rescued, tried, in_vain_iterations = _recover(
                mesh, guess, options, parameters, STALL_FALL * worst, history[0], order
            )
            if rescued is not None:
                recoveries.append(
                    f"refinement stalled on mesh iteration {iteration} ({mesh.label}, estimate {worst:.1e}): "
                    f"{_RECOVERED[rescued[1]]} ({rescued[0].program.label})"
                )
                pending, since = (*rescued, recovering, in_vain_iterations), len(history)
                stall_reason = _stall_reason(program, tolerance, history, stalled, solution, "")
                stall = (solution, stall_reason, len(history), "a recovery from the stall")
                continue
            history[-1] = _charged(history[-1], time.perf_counter() - recovering, in_vain_iterations)
        if stalled:
            outcome, reason = (
                "stalled",
                _stall_reason(program, tolerance, history, stalled, solution, _and(tried, in_vain)),
            )
            warnings.warn(reason, AccuracyWarning, stacklevel=user_stacklevel())
            break
        if iteration + 1 < max_iterations:
            try:
                counts = mesh.estimate_counts(solution)
                refined = mesh.refine(_split(errors, counts), target, cuts(solution))
            except Exception as exc:  # noqa: BLE001
                raise _refinement_failure(exc, iteration, mesh, best, history, "refining") from exc
            if refined is mesh:  # no interval asks for more: the next mesh would be this one
                parts = f" (failing: {', '.join(history[-1].failing)})" if history[-1].failing else ""
                outcome = "stopped"
                reason = (
                    f"{program.label}: mesh refinement stopped short of {tolerance:g}{parts}: no interval is over "
                    f"what the failing parts ask of it, so the next mesh would be this one; stopped on "
                    f"{history[-1].transcription}"
                )
                reason = _and(reason, in_vain)
                warnings.warn(reason, AccuracyWarning, stacklevel=user_stacklevel())
                break
            mesh = refined
    else:
        assert solution is not None  # (at least one iteration ran)
        parts = f"failing: {', '.join(history[-1].failing)}; " if history[-1].failing else ""
        why = hint(solution)
        outcome = "not met"
        reason = (
            f"{program.label}: mesh tolerance {tolerance:g} not met after {max_iterations} mesh iterations "
            f"({parts}state estimate {history[-1].error_estimate:.1e} on {history[-1].transcription})"
            + (f"; {why}" if why else "")
        )
        reason = _and(reason, in_vain)
        warnings.warn(reason, AccuracyWarning, stacklevel=user_stacklevel())
    assert solution is not None  # (at least one iteration ran)
    if recoveries:
        said = "; ".join(recoveries)
        if outcome == "met":
            reason = f"{program.label}: mesh tolerance {tolerance:g} met after a recovery: {said}"
        else:
            reason = f"{reason}; after a recovery: {said}"
    solution.mesh_history = history
    solution.refinement_outcome, solution.refinement_reason = outcome, reason
    return solution


def _stall_reason(
    program: Program, tolerance: float, history: Sequence[MeshIteration], stalled: str, solution: Solution, tried: str
) -> str:
    """The reason of a stalled refinement: the tolerance, the failing parts, the stall rule's words, the last mesh,
    what may keep the estimate from falling (:func:`hint`) and the recoveries tried in vain."""
    why = hint(solution)
    parts = f" (failing: {', '.join(history[-1].failing)})" if history[-1].failing else ""
    return (
        f"{program.label}: mesh refinement stalled short of {tolerance:g}{parts}: {stalled}; stopped on "
        f"{history[-1].transcription}"
        + (f"; {why}" if why else "")
        + (f"; recovery tried in vain: {tried}" if tried else "")
    )


def _fall_back(
    stall: tuple[Solution, str, int, str], best: Solution | None, history: list[MeshIteration]
) -> tuple[Solution, list[MeshIteration]]:
    """Where the recovery from a stall (or a divergence) ends in a failure: the better of the stalled solution and the
    best one since (by what drove each mesh, :func:`_worst`), with its own history (the reason says what followed)."""
    stalled, _, at, _ = stall
    if best is not None and best is not stalled and _worst(_history_of(best)[-1]) < _worst(history[at - 1]):
        return best, _history_of(best)
    return stalled, history[:at]


def _after_stall(
    stall: tuple[Solution, str, int, str], iteration: int, mesh: Program, failure: SolverError | str
) -> str:
    """A stall's (or a divergence's) reason, where the refinement from its recovery ended in a failure on mesh
    ``iteration``: the refinement returns the stalled solution, or a better one found since (a recovery never makes an
    outcome worse)."""
    _, reason, _, recovery = stall
    status = failure.status if isinstance(failure, SolverError) else failure
    return (
        f"{reason}; {recovery} failed on mesh iteration {iteration} ({mesh.label}: IPOPT's status "
        f"{status}), so the best solution before it is returned"
    )


def _and(reason: str, more: str) -> str:
    """``reason``, and ``more`` after it where there is more to say."""
    return f"{reason}; {more}" if reason and more else reason or more


#: The recoveries of a refinement whose warm start leads nowhere (a refined mesh's solve fails from the previous
#: mesh's solution, or the refinement stalls), in the order tried: the same mesh cold-started from the refinement's
#: own guess, then the scheme's uniform mesh (:meth:`Program.uniform <ocpkit.program.Program.uniform>`) of as many
#: points, cold-started likewise. A coarse mesh can hold a spurious optimum the dynamics do not fly (an estimate of
#: order one), and every mesh refined from it inherits it: its warm start, and its mesh, adapted to that artefact.
#: So where the refinement stands on such an estimate (:data:`DIVERGED_ESTIMATE`), the uniform mesh is tried first
#: (``_recoveries_from``), and where it diverges, the two are tried at once, the uniform mesh first.
RECOVERIES = ("cold start", "uniform mesh")
#: At most this many recoveries in one refinement
MAX_RECOVERIES = 2
#: A recovery's solve stops after this many times the IPOPT iterations of the refinement's first mesh (solved from
#: the refinement's own guess, as a recovery is), at least :data:`RECOVERY_MIN_ITERATIONS` and at most the solve's
#: ``max_iter``, so that a recovery's cost is bounded by the problem's own, whatever the mesh. The factor is above what
#: the published record's recoveries needed: the reference collection's chains took at most 187 iterations (those
#: their history records and those tried in vain, replayed), notebook 07's COPS hang glider 1782 and 2088, 3.2 and 7.1
#: times its first mesh's 554 and 293 (cold starts on finer meshes can take many times the first mesh's iterations:
#: twice the first mesh's stopped that row short of its tolerance). It stopped one: the same glider's solve at defaults
#: in notebook 11, whose cold start on a 612-point mesh ended at 1720 and whose uniform mesh then recovered (13 meshes,
#: not 19, the value within 1.5e-10). Those three cold starts stood on estimates of order one (1.9, 11 and 1.7e3),
#: from which the uniform mesh now comes first (``_recoveries_from``) and recovers in 114, 182 and 104 iterations, so
#: the cap stops none of the record's recoveries now. Where the first mesh takes 300 iterations or more (that
#: glider's 1e-9 chains, 554-631) the cap is IPOPT's own 3000.
RECOVERY_ITERATIONS = 10
#: The fewest IPOPT iterations a recovery's solve is allowed (:data:`RECOVERY_ITERATIONS`), whatever the first mesh took
RECOVERY_MIN_ITERATIONS = 200
_RECOVERED = {
    "cold start": "restarted cold from the guess on the same mesh",
    "uniform mesh": "restarted cold from the guess on a uniform mesh of as many points",
}


def _recovery_options(
    mesh: Program, ipopt_options: dict[str, Any] | None, first: MeshIteration
) -> tuple[dict[str, Any], int | None]:
    """The IPOPT overrides of a recovery's solve: the refinement's, with ``max_iter`` capped at
    :data:`RECOVERY_ITERATIONS` times the ``first`` mesh's iterations (:data:`RECOVERY_MIN_ITERATIONS` at least);
    and the cap where it is below the solve's own ``max_iter``, else None."""
    ipopt_options = dict(ipopt_options or {})
    allowed = int(mesh.effective_ipopt_options(ipopt_options)["max_iter"])
    cap = max(RECOVERY_MIN_ITERATIONS, RECOVERY_ITERATIONS * first.ipopt_iterations)
    if cap >= allowed:
        return ipopt_options, None
    return {**ipopt_options, "max_iter": cap}, cap


def _recoveries_from(standing: MeshIteration) -> tuple[str, ...]:
    """The order of :data:`RECOVERIES` for a refinement standing on the mesh ``standing`` (the stalled or diverging
    mesh, or the one a failed start came from): the uniform mesh first where its state estimate is of order one
    (:data:`DIVERGED_ESTIMATE`) or not a number. A cold start on a mesh adapted to a spurious optimum is slow and finds
    it again: COPS's hang glider from Radau 60 x 1, stalled at an estimate of 11 on 898 points of degree up to 34, took
    2088 IPOPT iterations (30 s) to the same artefact cold, and 182 (2.4 s) to the optimum on the uniform mesh; from
    Radau 4 x 50, whose third mesh (1470 points) failed from a solution at 1.9, 1782 (46 s) against 114 (2.3 s).
    Below that estimate the same mesh comes first: of the reference collection's 22 recoveries taken, one stood above
    it (the hanging chain's, at 0.18), and the uniform mesh first everywhere took 88 s against 75 s over the 21
    refinements that took them, with the same outcomes."""
    return RECOVERIES if standing.error_estimate < DIVERGED_ESTIMATE else RECOVERIES[::-1]


def _recover(
    mesh: Program,
    guess: Any,
    options: dict[str, Any],
    parameters: Mapping[str, float] | None,
    bar: float,
    first: MeshIteration,
    order: Sequence[str] = RECOVERIES,
) -> tuple[tuple[Solution, str] | None, str, int]:
    """The first of the recoveries (:data:`RECOVERIES`, in ``order``) whose solve converges with a state estimate
    below ``bar``, with its name, what the ones tried before it gave, and their IPOPT iterations (None, all of them
    and all their iterations where none does); each solve within its iteration cap (:data:`RECOVERY_ITERATIONS` times
    the ``first`` mesh's)."""
    tried, spent = [], 0
    for how in order:
        solution, record = None, StartRecord()  # (a runaway control's solve its box replaced: discarded)
        try:
            candidate = mesh if how == "cold start" else mesh.uniform()
            ipopt_options, cap = _recovery_options(candidate, options["ipopt_options"], first)
            solution = solve_once(
                candidate, guess, ipopt_options, options["allow_acceptable"], False, parameters, record=record
            )
            estimate = solution.interval_errors
        except Exception as exc:  # noqa: BLE001 - a recovery that fails is reported, the next one tried
            tried.append(f"{how}: {type(exc).__name__}: {exc}")
            spent += record.discarded_iterations + _iterations_of(exc, solution)
            continue
        spent += record.discarded_iterations
        worst = float(np.max(np.where(np.isfinite(estimate), estimate, 1e3)))
        if solution.converged and worst < bar:
            return (solution, how), "; ".join(tried), spent
        spent += solution.iterations
        what = solution.status if not solution.converged else f"estimate {worst:.1e}, not below {bar:.1e}"
        if cap is not None and not solution.converged and solution.iterations >= cap:
            what += f" (a recovery's cap: {cap} iterations; the first mesh took {first.ipopt_iterations})"
        tried.append(f"{how} on {candidate.label}: {what}")
    return None, "; ".join(tried), spent


def _charged(mesh: MeshIteration, seconds: float, iterations: int) -> MeshIteration:
    """``mesh``'s record with recoveries tried in vain from it: their wall time in its ``total_s``, their IPOPT
    iterations in its ``discarded_iterations``."""
    return dataclasses.replace(
        mesh, total_s=mesh.total_s + seconds, discarded_iterations=mesh.discarded_iterations + iterations
    )


def _iterations_of(failure: BaseException | None, solution: Solution | None) -> int:
    """The IPOPT iterations of a solve whose result is discarded: its error's where IPOPT's failure raised, else its
    ``solution``'s (a last iterate returned unconverged, or a solution judged afterwards), else none (it raised
    before IPOPT ran)."""
    if isinstance(failure, SolverError) and failure.iterations is not None:
        return int(failure.iterations)
    return int(solution.iterations) if solution is not None else 0


def _history_of(solution: Solution) -> list[MeshIteration]:
    return list(solution.mesh_history or [])


#: Refinement stalls when, over STALL_MESHES meshes, the state estimate fell by less than 1 / STALL_FALL while the mesh
#: grew by more than STALL_GROWTH (a singular arc or a non-smooth control the scheme cannot resolve)
STALL_MESHES, STALL_FALL, STALL_GROWTH = 5, 0.5, 1.5


def _worst(h: MeshIteration) -> float:
    return h.worst if np.isfinite(h.worst) else h.error_estimate


#: The state estimate, of order one, from which a refinement diverges when a refined mesh's estimate is at least this,
#: no lower than the previous mesh's, and the mesh grew by more than STALL_GROWTH. Such an estimate says the solution
#: does not fly; a coarse mesh's spurious optimum is inherited by each mesh refined from it, through its warm start and
#: through intervals adapted to the artefact. Radau 4 x 50 on the hang glider lands on x(t_f) = 1500 m, its bound
#: (estimate 0.23), and the mesh refined from it to 1e-6 on the same (0.31 on 769 points); a cold start on a uniform
#: mesh of as many points finds the optimum (2.1e-3). The restart must bring the estimate below this value: from
#: global Radau 20, a uniform mesh of 33 points still at 2.6 would otherwise count as one, and end the early restarts.
#: From a mesh at this estimate or more, every recovery tries the uniform mesh first (``_recoveries_from``).
DIVERGED_ESTIMATE = 0.1


def _diverged(history: Sequence[MeshIteration]) -> str:
    """Why refinement diverges (:data:`DIVERGED_ESTIMATE`, on the state estimate), or the empty string."""
    if len(history) < 2:
        return ""
    then, now = history[-2], history[-1]
    if (
        now.error_estimate >= DIVERGED_ESTIMATE
        and now.error_estimate >= then.error_estimate
        and now.collocation_points > STALL_GROWTH * then.collocation_points
    ):
        return (
            f"the state estimate did not fall ({then.error_estimate:.1e}, then {now.error_estimate:.1e}) while the "
            f"mesh grew from {then.collocation_points} to {now.collocation_points} points"
        )
    return ""


def _stalled(history: Sequence[MeshIteration]) -> str:
    """Why refinement stalls (module constants, on what drives each mesh: :attr:`MeshIteration.worst`), or the
    empty string."""
    if len(history) <= STALL_MESHES:
        return ""
    then, now = history[-1 - STALL_MESHES], history[-1]
    if _worst(now) > STALL_FALL * _worst(then) and now.collocation_points > STALL_GROWTH * then.collocation_points:
        return (
            f"over the last {STALL_MESHES} meshes the estimate went from {_worst(then):.1e} to {_worst(now):.1e} "
            f"while the mesh grew from {then.collocation_points} to {now.collocation_points} points"
        )
    return ""


def _refinement_failure(
    exc: Exception,
    iteration: int,
    mesh: Program,
    best: Solution | None,
    history: Sequence[MeshIteration],
    doing: str = "on",
    tried: str = "",
) -> SolverError:
    """The :class:`~ocpkit.SolverError` of a failure on mesh ``iteration``: IPOPT's own status for a failed
    solve, the exception's type and message for anything else; the failed solve's last iterate as ``result``
    and the best converged solution before it as ``best`` (with its ``mesh_history``); ``tried``: the recoveries
    that failed before it (:func:`_recover`)."""
    where = (
        f"on mesh iteration {iteration} ({mesh.label})"
        if doing == "on"
        else f"refining mesh iteration {iteration} ({mesh.label}) for the next"
    )
    if best is None:
        kept = "no earlier mesh converged"
    else:
        last = _history_of(best)[-1]
        kept = f"the best solution so far (estimate {last.error_estimate:.1e} on {last.transcription}) is error.best"
    why = hint(best) if best is not None else ""
    if why:
        kept = f"{kept}; {why}"
    if tried:
        kept = f"{kept}; recovery tried in vain: {tried}"
    if isinstance(exc, SolverError):
        detail = f"{where}: {exc.detail}; {kept}" if exc.detail else f"{where}; {kept}"
        error = SolverError(exc.solver, exc.status, exc.iterations, detail, result=exc.result, best=best)
    else:
        error = SolverError("mesh refinement", type(exc).__name__, None, f"{exc} {where}; {kept}", best=best)
    error.mesh_history = list(history)
    return error


__all__ = [
    "STALL_FALL",
    "STALL_GROWTH",
    "STALL_MESHES",
    "MAX_RECOVERIES",
    "RECOVERIES",
    "RECOVERY_ITERATIONS",
    "RECOVERY_MIN_ITERATIONS",
    "DIVERGED_ESTIMATE",
    "BOUND_RELAX_SHARE",
    "IPOPT_BOUND_RELAX",
    "MeshIteration",
    "StartRecord",
    "cuts",
    "exact_start",
    "hint",
    "refinement_ipopt_options",
    "mesh_fractions",
    "path_where",
    "record_solve",
    "settle",
    "solve",
    "solve_once",
    "solve_refined",
]
