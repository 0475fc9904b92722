"""One solve session for every mesh: a single transcription or linked phases (:class:`MultiPhase`).

:func:`solve` is the policy of :meth:`Transcription.solve` and :meth:`MultiPhase.solve`: the parameters
checked, one IPOPT solve (an exact warm start from a solution of the same mesh) or a mesh refinement
(:func:`solve_refined`), the failure policy of :func:`~ocpkit.transcription.base.settle`, and the accuracy
warnings. What it asks of a mesh object: ``label``, ``build_s``, ``n_collocation_points``, ``nlp``,
``solver(options)``, ``effective_ipopt_options(options)``, ``initial_point(guess)``, ``_bounds(parameters)``, ``_constraint_bounds()``, ``_solution``,
``_solve_once``, ``refine(errors, tolerance, cuts)``, ``_check_parameters``, ``_warn_if_inaccurate`` and, per
estimate interval of a solution, ``_mesh_fractions``, ``_path_where`` and ``_cuts``, and ``_refinement_hint``; of a
solution:
``interval_errors``, ``accuracy``, ``converged``, ``status``, ``iterations``, ``decision_variables``, ``solve_s``,
``raw["transcription"]``. It records on every solution it returns ``raw["solve_options"]`` (the IPOPT options and
``allow_acceptable`` it was solved with), so that the same NLP can be solved again as it was, and
``raw["linear_solver"]`` (IPOPT's linear solver and ordering, :func:`~ocpkit.nlp.linear_solver`).
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Generic, TypeVar, cast

import numpy as np

from .._deprecation import renamed
from ..accuracy import AccuracyWarning
from ..errors import SolverError
from ..nlp import WARM_START, NLPResult, linear_solver, solve_nlp

if TYPE_CHECKING:
    from .base import Transcription
    from .loop import SolveLoop
    from .phases import MultiPhase

#: What :meth:`SolveSession.solve` returns: a :class:`~ocpkit.Solution` for a :class:`~ocpkit.Transcription`, a
#: :class:`~ocpkit.MultiPhaseSolution` for linked phases (:class:`~ocpkit.MultiPhase`).
SolutionType = TypeVar("SolutionType")


@dataclass(frozen=True)
class MeshIteration:
    """One solve of a mesh refinement: the mesh (interval lengths as fractions of ``tf - t0``), its size, the
    solution's error estimate, IPOPT's iterations and the times (build of this mesh, IPOPT, the whole iteration)."""

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

    @property
    def nlp_parameters(self) -> int:
        """Deprecated name of :attr:`decision_variables`."""
        renamed("MeshIteration.nlp_parameters", "MeshIteration.decision_variables")
        return self.decision_variables


class SolveSession(Generic[SolutionType]):
    """The one ``solve`` of a mesh object (:class:`Transcription`, :class:`MultiPhase`): :func:`solve`."""

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
    ) -> SolutionType:
        """Solve with IPOPT from ``guess``: a :class:`~ocpkit.Solution`, or for linked phases
        (:class:`~ocpkit.MultiPhase`: every phase in one NLP) a :class:`~ocpkit.MultiPhaseSolution`.

        Parameters
        ----------
        guess : Guess, Solution or None
            A :class:`~ocpkit.Solution` of this same transcription object is an exact warm start: its NLP
            vector and IPOPT's multipliers, with IPOPT's warm-start options (:data:`~ocpkit.nlp.WARM_START`); another
            Solution is interpolated onto this mesh. Linked phases take one guess per phase, or a
            :class:`~ocpkit.MultiPhaseSolution` (of the same object: an exact warm start).
        ipopt_options : dict
            Overrides of :data:`ocpkit.nlp.DEFAULT_IPOPT_OPTIONS` (without the ``ipopt.`` prefix).
        allow_acceptable : bool
            Accept IPOPT's ``Solved_To_Acceptable_Level`` as success.
        raise_on_failure : bool
            True (default): a failed solve raises :class:`~ocpkit.SolverError` naming IPOPT's
            status, with the last iterate as ``error.result``. False: the last iterate is
            returned as a :class:`Solution` with ``converged=False``.
        error_threshold : float or None
            Warn (:class:`~ocpkit.accuracy.AccuracyWarning`) when the solution's estimated relative
            state error (:attr:`Solution.error_estimate`, :mod:`ocpkit.accuracy`) exceeds it, naming
            the interval, or when a path constraint is violated between the scheme's points by more
            than it (in units of the constraint's scale, :func:`~ocpkit.accuracy.path_violations`);
            None: no estimate at solve time. The objective's part of the error costs an integration
            of the flown control: it is in :attr:`Solution.accuracy`, and refinement checks it.
        mesh_tolerance : float or None
            Refine the mesh (:meth:`Transcription.refine <ocpkit.transcription.base.Transcription.refine>`,
            :meth:`MultiPhase.refine <ocpkit.transcription.phases.MultiPhase.refine>`) until every part of the
            error estimate (:class:`~ocpkit.accuracy.Accuracy`: the state's, the objective's, each path constraint's
            violation between points) is at most this, at most ``max_mesh_iterations`` solves, each
            warm-started from the previous solution; the returned solution's ``mesh_history`` lists
            every iteration (and a warning names the parts if the tolerance is not met). Where the
            state meets the tolerance and another part does not, the next mesh cuts the intervals at
            their worst path violation, and refines to a tolerance tightened by the objective's
            excess. A failed solve on any mesh raises :class:`~ocpkit.SolverError` with the best
            solution before it (``error.best``); an estimate that stops falling while the mesh grows
            (:data:`STALL_MESHES`) stops the refinement with a warning saying so, naming a singular
            arc where a control enters linearly and an angle not declared periodic
            (:func:`~ocpkit.accuracy.refinement_hint`).
        max_mesh_iterations : int
            At most this many meshes (default 25: bang-bang and singular problems from coarse meshes
            take 13 to 20; a stalled refinement stops sooner).
        parameters : Mapping[str, float], optional
            New values of some of the problem's parameters (:attr:`OptimalControlProblem.parameters`) for
            this solve. They are NLP variables pinned by their bounds, so the NLP and the IPOPT instance are
            built once and reused for any values: a study of many values builds once. The solution's
            problem carries the values solved with.
        """
        return solve(
            self,
            guess,
            ipopt_options=ipopt_options,
            allow_acceptable=allow_acceptable,
            raise_on_failure=raise_on_failure,
            error_threshold=error_threshold,
            mesh_tolerance=mesh_tolerance,
            max_mesh_iterations=max_mesh_iterations,
            parameters=parameters,
        )

    def loop(
        self,
        *,
        ipopt_options: dict[str, Any] | None = None,
        allow_acceptable: bool = False,
        raise_on_failure: bool = True,
    ) -> SolveLoop:
        """A :class:`~ocpkit.transcription.loop.SolveLoop` of this mesh: many solves (parameter values, starts) at
        the cost of the IPOPT call, each result's Solution built only when asked for.

        ``loop(parameters, guess=...)`` returns a :class:`~ocpkit.transcription.loop.LoopResult` (the NLP's
        arrays, the objective, IPOPT's status and iterations; ``.solution`` the full Solution), equal to
        ``solve(guess, parameters=parameters, error_threshold=None)`` with the same options, to the last bit.
        """
        from .loop import SolveLoop

        meshed = cast("Transcription | MultiPhase", self)  # (the mesh objects are these)
        return SolveLoop(
            meshed, ipopt_options=ipopt_options, allow_acceptable=allow_acceptable, raise_on_failure=raise_on_failure
        )


def solve(
    meshed: Any,
    guess: Any,
    *,
    ipopt_options: dict[str, Any] | None,
    allow_acceptable: bool,
    raise_on_failure: bool,
    error_threshold: float | None,
    mesh_tolerance: float | None,
    max_mesh_iterations: int,
    parameters: Mapping[str, float] | None,
) -> Any:
    """The solve policy (the module docstring; the options are :meth:`Transcription.solve`'s)."""
    if parameters is not None:
        meshed._check_parameters(parameters)  # names checked before anything is built
    if mesh_tolerance is not None:
        solution = solve_refined(
            meshed,
            guess,
            mesh_tolerance,
            max_mesh_iterations,
            dict(
                ipopt_options=ipopt_options,
                allow_acceptable=allow_acceptable,
                raise_on_failure=raise_on_failure,
                parameters=parameters,
            ),
        )
    else:
        solution = meshed._solve_once(guess, ipopt_options, allow_acceptable, raise_on_failure, parameters)
        if error_threshold is not None and solution.converged:
            meshed._warn_if_inaccurate(solution, error_threshold)
    record_solve(meshed, solution, ipopt_options, allow_acceptable)
    return solution


def record_solve(meshed: Any, solution: Any, ipopt_options: dict[str, Any] | None, allow_acceptable: bool) -> None:
    """Record on ``solution.raw`` how it was solved: ``solve_options``, for a re-solve of the same NLP
    (ocpkit.indirect re-solves from an extremal), and ``linear_solver``, the linear algebra it ran with (a
    refinement's last mesh: the solution's own)."""
    if isinstance(getattr(solution, "raw", None), dict):
        solution.raw["solve_options"] = {
            "ipopt_options": dict(ipopt_options or {}),
            "allow_acceptable": allow_acceptable,
        }
        mesh = solution.raw.get("transcription", meshed)
        solution.raw["linear_solver"] = linear_solver(mesh.effective_ipopt_options(ipopt_options))
        for phase in getattr(solution, "phases", ()):  # a multi-phase solution's phases: the one NLP's
            if isinstance(getattr(phase, "raw", None), dict):
                phase.raw["linear_solver"] = solution.raw["linear_solver"]


def solve_once(
    meshed: Any,
    guess: Any,
    ipopt_options: dict[str, Any] | None,
    allow_acceptable: bool,
    raise_on_failure: bool,
    parameters: Mapping[str, float] | None = None,
    estimate_multipliers: bool = False,
) -> Any:
    """One IPOPT solve of ``meshed``. From a solution of this same object: its exact warm start (its NLP vector and
    IPOPT's multipliers, with :data:`~ocpkit.nlp.WARM_START`). From a solution of another mesh with
    ``estimate_multipliers``: the interpolated point with first-order multiplier estimates
    (:meth:`~ocpkit.nlp.SeparableNLP.multiplier_estimate`) and :data:`~ocpkit.nlp.WARM_START`, falling back to the
    interpolated point alone if that solve fails. The failure policy is :func:`~ocpkit.transcription.base.settle`'s."""
    from .base import settle

    lbw, ubw = meshed._bounds(parameters)
    lbg, ubg = meshed._constraint_bounds()

    def run(
        w0: np.ndarray, options: dict[str, Any] | None, multipliers: tuple[np.ndarray, np.ndarray] | None = None
    ) -> NLPResult:
        lam_g0, lam_w0 = multipliers if multipliers is not None else (None, None)
        solver = meshed.solver(options)
        return solve_nlp(
            solver, w0, lbw, ubw, lbg, ubg, allow_acceptable=allow_acceptable, lam_w0=lam_w0, lam_g0=lam_g0
        )

    warm_options = {**WARM_START, **(ipopt_options or {})}
    raw = getattr(guess, "raw", None)  # a solution (an ocpkit.Guess has none)
    if raw is not None and raw.get("transcription") is meshed and "lam_g" in raw:
        result = run(np.clip(raw["w"], lbw, ubw), warm_options, (raw["lam_g"], raw["lam_w"]))
        return settle(result, meshed._solution, raise_on_failure)
    w0 = np.clip(meshed.initial_point(guess), lbw, ubw)
    if estimate_multipliers and raw is not None:
        result = run(w0, warm_options, meshed.nlp.multiplier_estimate(w0, lbw, ubw))
        if result.success:
            return settle(result, meshed._solution, raise_on_failure)
    return settle(run(w0, ipopt_options), meshed._solution, raise_on_failure)


def solve_refined(meshed: Any, guess: Any, tolerance: float, max_iterations: int, options: dict[str, Any]) -> Any:
    """Solve and refine ``meshed`` (a :class:`Transcription` or a :class:`MultiPhase`) until every part of the error
    estimate meets ``tolerance`` (:meth:`Transcription.solve`'s ``mesh_tolerance``), with the history and the
    outcome on the returned solution."""
    if not (tolerance > 0 and np.isfinite(tolerance)):
        raise ValueError(f"mesh_tolerance must be positive, got {tolerance!r}")
    if max_iterations < 1:
        raise ValueError(f"max_mesh_iterations must be at least 1, got {max_iterations!r}")
    transcription = meshed
    history: list[MeshIteration] = []
    solution: Any = None
    best: Any = None
    outcome, reason = "met", ""
    for iteration in range(max_iterations):
        start = time.perf_counter()
        try:
            solution = transcription._solve_once(
                guess if solution is None else solution,
                options["ipopt_options"],
                options["allow_acceptable"],
                options["raise_on_failure"],
                options["parameters"],
                estimate_multipliers=True,
            )
            estimate = solution.interval_errors
        except Exception as exc:  # noqa: BLE001 - any failure inside refinement is reported with what it had
            if not history:  # the first mesh: the solve's own error (bad input, or IPOPT's status)
                raise
            raise _refinement_failure(exc, iteration, transcription, best, history) from exc
        history.append(
            MeshIteration(
                iteration,
                transcription.label,
                transcription._mesh_fractions(solution),
                transcription.n_collocation_points,
                solution.decision_variables,
                float(estimate.max()),
                solution.iterations,
                transcription.build_s,
                solution.solve_s,
                time.perf_counter() - start,
            )
        )
        # an interval whose estimate is not a number (NaN states) is treated as far over the tolerance
        errors = np.where(np.isfinite(estimate), estimate, 1e3)
        if solution.converged and (best is None or errors.max() <= _worst(best.mesh_history[-1])):
            best = solution
            best.mesh_history = list(history)
        if not solution.converged:
            outcome, reason = "failed", f"IPOPT's status {solution.status} on {transcription.label}"
            break
        target = path_target = tolerance
        try:
            # path constraints between points at every mesh (cheap); the objective once the state meets the
            # tolerance (it integrates the flown control)
            where = transcription._path_where(solution)
            accuracy = solution.accuracy if errors.max() <= tolerance else None
        except Exception as exc:  # noqa: BLE001
            raise _refinement_failure(exc, iteration, transcription, best, history) from exc
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
        stalled = _stalled(history)
        if stalled:
            hint = transcription._refinement_hint(solution)
            parts = f" (failing: {', '.join(history[-1].failing)})" if history[-1].failing else ""
            outcome = "stalled"
            reason = (
                f"{meshed.label}: mesh refinement stalled short of {tolerance:g}{parts}: {stalled}; stopped on "
                f"{history[-1].transcription}" + (f"; {hint}" if hint else "")
            )
            warnings.warn(reason, AccuracyWarning, stacklevel=4)  # the caller of solve()
            break
        if iteration + 1 < max_iterations:
            try:
                switches = transcription._cuts(solution)
                try:
                    transcription = transcription.refine(errors, target, switches)
                except TypeError as exc:  # a subclass with the two-argument refine of before the cuts
                    if "positional argument" not in str(exc):
                        raise
                    transcription = transcription.refine(errors, target)
            except Exception as exc:  # noqa: BLE001
                raise _refinement_failure(exc, iteration, transcription, best, history, "refining") from exc
            if "compile" in vars(meshed):  # the user's choice, set on the object: every mesh keeps it
                transcription.compile = meshed.compile
            if _same_mesh(transcription, solution.raw["transcription"]):
                transcription = solution.raw["transcription"]  # the solved one, which the solution belongs to
                parts = f" (failing: {', '.join(history[-1].failing)})" if history[-1].failing else ""
                outcome = "stopped"
                reason = (
                    f"{meshed.label}: mesh refinement stopped short of {tolerance:g}{parts}: no interval is over "
                    f"what the failing parts ask of it, so the next mesh would be this one; stopped on "
                    f"{history[-1].transcription}"
                )
                warnings.warn(reason, AccuracyWarning, stacklevel=4)  # the caller of solve()
                break
    else:
        parts = f"failing: {', '.join(history[-1].failing)}; " if history[-1].failing else ""
        hint = transcription._refinement_hint(solution)
        outcome = "not met"
        reason = (
            f"{meshed.label}: mesh tolerance {tolerance:g} not met after {max_iterations} mesh iterations "
            f"({parts}state estimate {history[-1].error_estimate:.1e} on {history[-1].transcription})"
            + (f"; {hint}" if hint else "")
        )
        warnings.warn(reason, AccuracyWarning, stacklevel=4)  # the caller of solve()
    solution.mesh_history = history
    solution.refinement_outcome, solution.refinement_reason = outcome, reason
    solution.raw["transcription"] = transcription
    return solution


#: Refinement stalls when, over STALL_MESHES meshes, the state estimate fell by less than 1 / STALL_FALL while the mesh
#: grew by more than STALL_GROWTH (a singular arc or a non-smooth control the scheme cannot resolve)
STALL_MESHES, STALL_FALL, STALL_GROWTH = 5, 0.5, 1.5


def _same_mesh(a: Any, b: Any) -> bool:
    """Whether two transcriptions of a refinement have the same mesh (a refinement that changed nothing); linked
    phases, when every phase has."""
    if hasattr(a, "phases") or hasattr(b, "phases"):
        pa, pb = getattr(a, "phases", None), getattr(b, "phases", None)
        return pa is not None and pb is not None and len(pa) == len(pb) and all(map(_same_mesh, pa, pb))
    if type(a) is not type(b) or a.n_variables != b.n_variables:
        return False
    ma, mb = getattr(a, "mesh", None), getattr(b, "mesh", None)
    if ma is None or mb is None:
        return a.label == b.label
    same_counts = np.array_equal(getattr(a, "counts", np.zeros(0)), getattr(b, "counts", np.zeros(0)))
    return same_counts and np.array_equal(ma.fractions, mb.fractions)


def _worst(h: MeshIteration) -> float:
    return h.worst if np.isfinite(h.worst) else h.error_estimate


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
    exc: Exception, iteration: int, transcription: Any, best: Any, history: Sequence[MeshIteration], doing: str = "on"
) -> SolverError:
    """The :class:`~ocpkit.SolverError` of a failure on mesh ``iteration``: IPOPT's own status for a failed
    solve, the exception's type and message for anything else; the failed solve's last iterate as ``result``
    and the best converged solution before it as ``best`` (with its ``mesh_history``)."""
    where = (
        f"on mesh iteration {iteration} ({transcription.label})"
        if doing == "on"
        else f"refining mesh iteration {iteration} ({transcription.label}) for the next"
    )
    if best is None:
        kept = "no earlier mesh converged"
    else:
        kept = (
            f"the best solution so far (estimate {best.mesh_history[-1].error_estimate:.1e} on "
            f"{best.mesh_history[-1].transcription}) is error.best"
        )
    hint = transcription._refinement_hint(best) if best is not None else ""
    if hint:
        kept = f"{kept}; {hint}"
    if isinstance(exc, SolverError):
        detail = f"{where}: {exc.detail}; {kept}" if exc.detail else f"{where}; {kept}"
        error = SolverError(exc.solver, exc.status, exc.iterations, detail, result=exc.result, best=best)
    else:
        error = SolverError("mesh refinement", type(exc).__name__, None, f"{exc} {where}; {kept}", best=best)
    error.mesh_history = list(history)
    return error
