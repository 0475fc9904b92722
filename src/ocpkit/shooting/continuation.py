"""Continuation of shooting solutions in a problem parameter: natural-parameter and pseudo-arclength.

:func:`follow` is natural-parameter continuation, the one engine of every discrete
continuation here (:func:`homotopy`, :func:`ocpkit.indirect.follow_extremal`, the
compendium's studies and its explorer): solve at the next parameter value from a
prediction built on the solutions so far, with the step chosen by a small step rule
(:class:`Schedule`: given values, halved on failure; :class:`GeometricSteps`: a ratio
that shrinks on failure and grows back on success; :class:`Toward`: a point of a
parameter space, approached by halved steps) and one or several predictors or starts.

Both :func:`follow` and :func:`arclength` return a :class:`ContinuationPath`, whose
``converged``, ``status`` (an :class:`~ocpkit.Outcome`), ``detail`` and ``iterations``
(points solved) are those of every indirect result; it is also the list of its
``(value, result)`` points.

It stalls where the path of extremals folds back in the parameter, as the
minimum-time orbit transfer does when the thrust decreases; :func:`arclength`
follows the path through folds instead. There the unknown
``X = (z, theta)``, with ``theta`` the parameter (or its logarithm), follows the
curve ``S(z, theta) = 0`` by arclength (Allgower & Georg, *Numerical Continuation
Methods*, Ch. 2):

* the unknowns are scaled by their initial magnitudes (``max(|X0_i|, 1)``) so that
  arclength is not dominated by the largest costate;
* tangent ``t``: the unit null vector of ``[dS/dz, dS/dtheta]``, oriented like the last one;
* predictor ``X + h t``; corrector: Newton on ``S(X) = 0, t . (X - X_pred) = 0``;
* step control: shrink on a failed corrector, grow after quick convergence.

Where the path crosses a target parameter value the solution there is refined by
the shooting solver; a target crossed several times (several branches) yields
several solutions, and the caller keeps the one it needs (for minimum time, the
smallest tf).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from .._deprecation import renamed
from ..errors import SolverError
from ..outcome import Outcome
from .shooting import Shooting, ShootingResult

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

# -- natural-parameter continuation -------------------------------------------------------------


class Schedule:
    """Step rule: the given ``values`` in turn; a failed step is halved (``midpoint``) at most ``max_halvings`` times."""

    def __init__(
        self,
        values: Sequence[float],
        *,
        midpoint: Callable[[float, float], float] = lambda a, b: 0.5 * (a + b),
        max_halvings: int = 6,
    ) -> None:
        self._values = [float(v) for v in values]
        self._next = 0
        self._pending: list[float] = []
        self.midpoint, self.max_halvings = midpoint, max_halvings

    def propose(self, current: float | None) -> float | None:
        if not self._pending:
            if self._next >= len(self._values):
                return None
            self._pending.append(self._values[self._next])
            self._next += 1
        return self._pending[-1]

    def reject(self, current: float | None, value: float, error: BaseException | None, solved: int) -> None:
        if current is None or len(self._pending) > self.max_halvings:
            raise SolverError(
                "continuation",
                f"failed at {value:.6g}",
                solved,
                f"after {len(self._pending) - 1} halvings of the step; last error: {error}",
                unit="points solved",
                outcome=Outcome.STEP_TOO_SMALL,
            ) from error
        self._pending.append(self.midpoint(current, value))

    def accept(self, value: float) -> None:
        self._pending.pop()


def geometric_midpoint(a: float, b: float) -> float:
    return math.sqrt(a * b)


class GeometricSteps:
    """Step rule: from the current value towards ``stop`` by the ratio ``factor``, through every target.

    The next value is ``max(current factor, stop)`` (``min`` when increasing), moved
    back to the nearest target it would skip. A failure shrinks the ratio halfway to
    one (and gives up beyond ``slowest``); a success grows it back
    (``1 - (1 - factor) grow``, within ``[floor, cap]``). ``factor < 1`` decreases.
    """

    def __init__(
        self,
        stop: float,
        *,
        targets: Iterable[float] = (),
        factor: float = 0.8,
        slowest: float = 0.995,
        floor: float = 0.7,
        cap: float = 0.8,
        grow: float = 1.5,
    ) -> None:
        if not 0 < factor < 1:
            raise ValueError(f"factor must lie in (0, 1), got {factor}")
        self.stop, self.factor, self.slowest, self.floor, self.cap, self.grow = stop, factor, slowest, floor, cap, grow
        self.targets = sorted({float(t) for t in targets}, reverse=True)

    def propose(self, current: float) -> float | None:
        if current <= self.stop * (1 + 1e-12):
            return None
        value = max(current * self.factor, self.stop)
        for target in self.targets:
            if value < target < current:
                value = target
        return value

    def reject(self, current: float, value: float, error: BaseException | None, solved: int) -> None:
        self.factor = 1 - (1 - self.factor) / 2
        if self.factor > self.slowest:
            raise SolverError(
                "continuation",
                f"stalled at {current:.6g}",
                solved,
                f"the step ratio passed {self.slowest}; last error: {error}",
                unit="points solved",
                outcome=Outcome.STEP_TOO_SMALL,
            ) from error

    def accept(self, value: float) -> None:
        self.factor = max(self.floor, min(self.cap, 1 - (1 - self.factor) * self.grow))


class Toward:
    """Step rule: from the current point of a parameter space (a vector, e.g. each parameter's share of its range)
    to ``target``: the target itself first; where it fails, the point ``step`` of the way there (``step`` starting
    at one half), halved on each failure; from each point solved, the target again. It gives up when the step falls
    below ``0.5 ** halvings``, after ``3 halvings`` intermediate points, or where the current point is the target
    (nothing to step along). The explorer's continuation (``compendium.explorer``)."""

    def __init__(self, target: ArrayLike, halvings: int = 3) -> None:
        self.target = np.asarray(target, dtype=float)
        self.halvings = int(halvings)
        self.step, self.passes = 0.5, 0
        self._aim, self._reached = True, False

    def propose(self, current: np.ndarray) -> np.ndarray | None:
        if self._reached:
            return None
        if self._aim:
            return self.target
        self.passes += 1
        return current + self.step * (self.target - current)

    def reject(self, current: np.ndarray, value: np.ndarray, error: BaseException | None, solved: int) -> None:
        if self._aim:
            self._aim = False  # the target failed from here: step towards it
        else:
            self.step *= 0.5
        near = np.allclose(current, self.target, rtol=0.0, atol=1e-12)
        if self.passes >= 3 * self.halvings or self.step < 0.5**self.halvings or near:
            raise SolverError(
                "continuation",
                "target not reached",
                solved,
                f"{self.passes} intermediate points tried, the step down to {self.step:g}; last error: {error}",
                unit="points solved",
                outcome=Outcome.STEP_TOO_SMALL,
            ) from error

    def accept(self, value: np.ndarray) -> None:
        if self._aim:
            self._reached = True
        else:
            self._aim = True  # an intermediate point solved: the target from there


class StepRule(Protocol):
    """What :func:`follow` asks of a step rule (:class:`Schedule`, :class:`GeometricSteps`, :class:`Toward`): the
    next value from the current one (None: the path is done), what to do when every guess failed there (raise a
    :class:`~ocpkit.SolverError` to give up), and that a value was solved."""

    def propose(self, current: Any) -> Any: ...

    def reject(self, current: Any, value: Any, error: BaseException | None, solved: int) -> None: ...

    def accept(self, value: Any) -> None: ...


class Point(tuple[Any, Any]):
    """One point of a continuation's history: the pair ``(value, z)`` (``value, z = point``), ``z`` the unknowns
    solved there (None for a result without ``z``), and the whole ``result`` as an attribute."""

    result: Any

    def __new__(cls, value: Any, z: Any, result: Any = None) -> Point:
        point = super().__new__(cls, (value, z))
        point.result = result
        return point


def follow(
    solve_at: Callable[[Any, Any], Any],
    z0: ArrayLike | None,
    start: Any,
    steps: StepRule,
    *,
    predictor: Callable[[list[Point], Any], Any] | None = None,
    choose: Callable[[list[Any]], Any] | str | None = None,
    log: Callable[[Any, Any, float], Any] | None = None,
    cancelled: Callable[[], bool] | None = None,
    remember: Callable[[Any, Any], Any] | None = None,
    raise_on_failure: bool = True,
    first: Any = None,
    parameter: str = "",
) -> ContinuationPath:
    """Natural-parameter continuation from ``z0`` (a solution at ``start``, or just a start when ``start`` is None;
    ``first``: the result there, where there is one; ``z0`` None: its ``z``).

    ``steps`` proposes the parameter values (:class:`Schedule`, :class:`GeometricSteps`, :class:`Toward`: any
    :class:`StepRule`); a value may be a number or a point of a parameter space. ``predictor(history, value)``
    turns the solutions so far, ``history = [(value, z), ...]`` (:class:`Point`: each also has its ``.result``),
    into a guess or a list of guesses (default: the last solution's ``z``); ``solve_at(value, guess)`` returns a
    result or raises :class:`~ocpkit.SolverError` (a result whose ``converged`` is False fails too). With several
    guesses every one is solved and ``choose`` picks among the results (default: the first); ``choose="first"``
    solves them in turn and stops at the first that succeeds. A step where every guess fails goes back to
    ``steps``, which shortens it or gives up.

    ``log(value, result, elapsed)`` after each point solved, ``remember(value, result)`` too (a cache of solved
    points); ``cancelled()``, asked before every solve but the first: True stops the path (status
    :attr:`~ocpkit.Outcome.CANCELLED`, never raised). Where ``steps`` gives up, its
    :class:`~ocpkit.SolverError` is raised (:attr:`~ocpkit.Outcome.STEP_TOO_SMALL`), or, with
    ``raise_on_failure=False``, the path so far is returned with ``converged`` False, that ``status`` and the
    error's words as ``detail``.

    Returns a :class:`ContinuationPath` (named ``parameter``) of every value solved, in order, the start
    excluded; it is also the list of ``(value, result)`` pairs the function returned before.
    """
    z_start = np.asarray(z0, dtype=float) if z0 is not None else getattr(first, "z", None)
    history: list[Point] = [Point(start, z_start, first)]
    predict = predictor or (lambda h, v: h[-1][1])
    lazy = choose == "first"
    pick: Callable[[list[Any]], Any] = (
        (lambda results: results[0]) if choose is None or isinstance(choose, str) else choose
    )
    path = ContinuationPath(parameter, start=start)
    t0 = time.perf_counter()
    attempted = False
    while True:
        current = history[-1][0]
        value = steps.propose(current)
        if value is None:
            break
        guesses = predict(history, value)
        guesses = guesses if isinstance(guesses, list) else [guesses]
        results: list[Any] = []
        error: SolverError | None = None
        for g in guesses:
            if attempted and cancelled is not None and cancelled():
                return path.ended(Outcome.CANCELLED, "cancelled by a newer request")
            attempted = True
            try:
                result = solve_at(value, g)
            except SolverError as exc:
                error = exc
                continue
            if not getattr(result, "converged", True):  # a result that says it failed
                status = getattr(result, "status", None)
                error = SolverError(
                    "solve",
                    str(status),
                    getattr(result, "iterations", None),
                    str(getattr(result, "detail", "")),
                    result=result,
                    outcome=status if isinstance(status, Outcome) else None,
                )
                continue
            results.append(result)
            if lazy:
                break
        if not results:
            path.failures += 1
            try:
                steps.reject(current, value, error, len(path.results))
            except SolverError as exc:
                if raise_on_failure:
                    raise
                return path.ended(exc.outcome or Outcome.STEP_TOO_SMALL, str(exc))
            continue
        result = pick(results)
        steps.accept(value)
        point = Point(value, getattr(result, "z", None), result)
        history.append(point)
        path.values.append(value)
        path.z.append(point[1])
        path.results.append(result)
        path.iterations = len(path.results)
        if remember is not None:
            remember(value, result)
        if log:
            log(value, result, time.perf_counter() - t0)
    return path.ended(Outcome.CONVERGED, f"{len(path.results)} points solved")


def homotopy(
    regularized: Shooting,
    lambdas: Sequence[float],
    z0: ArrayLike,
    *,
    parameter: str = "lam",
    final: Shooting | None = None,
    **solve_options: Any,
) -> list[ShootingResult]:
    """Continuation on a cost parameter: solve for each value of ``lambdas`` in turn, each warm-starting the next.

    ``regularized`` solves the problems with ``parameter`` in ``lambdas``; ``final``
    (typically the bang-bang law at the end value) solves once more from the last
    solution. Returns every solve's result; a solve that fails raises :class:`~ocpkit.SolverError`.
    """
    problem = regularized.problem
    if parameter not in problem.parameters:
        raise KeyError(f"{problem.name!r} has no parameter {parameter!r}; it has {sorted(problem.parameters)}")
    solve_options = {**solve_options, "raise_on_failure": True}

    def solve_at(lam: float, z: np.ndarray) -> ShootingResult:
        return regularized.solve(z, problem.parameter_vector({parameter: lam}), **solve_options)

    results = [r for _, r in follow(solve_at, z0, None, Schedule(lambdas, max_halvings=0))]
    if final is not None:
        results.append(final.solve(results[-1].z, final.problem.parameter_values, **solve_options))
    return results


@dataclass
class ContinuationPath:
    """The points of a continuation (:func:`follow`, :func:`arclength`): the ``parameter``, its ``values``, the
    unknowns ``z`` and the ``results`` there (for :func:`arclength`, the unknowns again), and how it ended, with the
    names of every indirect result: ``converged`` (the path reached its end), ``status``
    (:class:`~ocpkit.Outcome`: ``CONVERGED``, ``STEP_TOO_SMALL``, ``MAX_ITERATIONS``, ``FOLD``, ``CANCELLED``),
    ``detail`` and ``iterations`` (the points solved); ``steps`` tried and ``failures`` among them. For
    :func:`arclength`, ``values`` and ``z`` begin with the start, and ``targets`` holds the refined solutions at
    each target crossed (``refinement_failures`` the crossings that did not refine). It is also the list of its
    ``(value, result)`` pairs (``for value, result in path``, ``path[-1]``, ``len(path)``), as :func:`follow`
    returned before. ``message`` is the deprecated name of ``detail``."""

    parameter: str = ""
    values: list[Any] = field(default_factory=list)
    z: list[Any] = field(default_factory=list)
    results: list[Any] = field(default_factory=list)
    targets: dict[float, list[ShootingResult]] = field(default_factory=dict)  # value -> one per crossing
    steps: int = 0
    failures: int = 0
    #: value -> messages of crossings that did not refine
    refinement_failures: dict[float, list[str]] = field(default_factory=dict)
    converged: bool = True
    status: Outcome = Outcome.CONVERGED
    detail: str = ""
    iterations: int = 0
    #: the value the path started from (:func:`follow`'s ``start``)
    start: Any = None

    def ended(self, status: Outcome, detail: str) -> ContinuationPath:
        """This path, ended with ``status`` (converged exactly for :attr:`~ocpkit.Outcome.CONVERGED`) and
        ``detail``."""
        self.status, self.detail, self.converged = status, detail, status is Outcome.CONVERGED
        return self

    @property
    def message(self) -> str:
        """Deprecated name of ``detail``."""
        renamed(f"{type(self).__name__}.message", f"{type(self).__name__}.detail")
        return self.detail

    def __iter__(self) -> Iterator[tuple[Any, Any]]:
        return iter(zip(self.values, self.results))

    def __len__(self) -> int:
        return len(self.results)

    def __getitem__(self, index: int) -> tuple[Any, Any]:
        return list(zip(self.values, self.results))[index]

    @property
    def turning_points(self) -> list[int]:
        """Indices where the parameter reverses direction along the path (folds)."""
        v = np.asarray(self.values, dtype=float)
        d = np.diff(v)
        return [i + 1 for i in range(len(d) - 1) if d[i] * d[i + 1] < 0]

    def best(self, value: float, key: Callable[[ShootingResult], Any] = lambda r: r.tf) -> ShootingResult:
        """The crossing of ``value`` that minimises ``key`` (default: the final time)."""
        if value not in self.targets or not self.targets[value]:
            if value in self.refinement_failures:
                raise KeyError(
                    f"the path crossed {self.parameter} = {value} but the shooting there failed: "
                    + "; ".join(self.refinement_failures[value])
                )
            raise KeyError(f"the path did not reach {self.parameter} = {value}")
        return min(self.targets[value], key=key)


def arclength(
    shooting: Shooting,
    z0: ArrayLike,
    parameter: str,
    start: float,
    stop: float,
    *,
    targets: Iterable[float] = (),
    log: bool = True,
    h0: float = 0.05,
    hmin: float = 1e-7,
    hmax: float = 0.5,
    tol: float = 1e-9,
    max_steps: int = 5000,
    max_corrector: int = 8,
    fd_step: float = 1e-7,
    stop_at_turn: bool = False,
    raise_on_failure: bool = False,
) -> ContinuationPath:
    """Follow ``S(z, parameter) = 0`` from ``(z0, start)`` until the parameter passes ``stop``.

    ``z0`` must solve the problem at ``start``. ``log``: continue in the logarithm
    of the parameter (a thrust, a scale). Targets are refined with
    ``shooting.solve(..., tol=tol)`` each time the path crosses them. ``stop_at_turn``: stop
    once the path has folded back (the parameter has reversed direction and moved
    back past the turning point by 5 % of the distance travelled).

    The path's ``status`` says how it ended: :attr:`~ocpkit.Outcome.CONVERGED` at ``stop``,
    :attr:`~ocpkit.Outcome.STEP_TOO_SMALL` where the step fell below ``hmin``,
    :attr:`~ocpkit.Outcome.FOLD` where ``stop_at_turn`` stopped it, :attr:`~ocpkit.Outcome.MAX_ITERATIONS` after
    ``max_steps``; ``detail`` in words. ``raise_on_failure=True`` raises a :class:`~ocpkit.SolverError` (the path
    its ``.result``) for any end but ``stop``.
    """
    problem = shooting.problem
    names = list(problem.parameters)
    if parameter not in names:
        raise KeyError(f"{problem.name!r} has no parameter {parameter!r}; it has {names}")
    k = names.index(parameter)
    base = problem.parameter_values.copy()
    to_theta = np.log if log else (lambda v: v)
    from_theta = np.exp if log else (lambda v: v)
    theta_stop = to_theta(stop)
    direction = np.sign(to_theta(stop) - to_theta(start))
    if direction == 0:
        raise ValueError("start and stop must differ")
    target_values = {float(to_theta(t)): float(t) for t in targets}  # keyed by the caller's own values
    target_thetas = sorted(target_values)

    def params(theta: float) -> np.ndarray:
        P = base.copy()
        P[k] = from_theta(theta)
        return P

    scale = np.concatenate([np.maximum(np.abs(np.asarray(z0, dtype=float)), 1.0), [1.0]])

    def F_and_J(Xs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Residual and Jacobian in the scaled unknowns ``Xs = X / scale``."""
        X = Xs * scale
        z, theta = X[:-1], X[-1]
        S, Jz = shooting.jacobian_matrix(z, params(theta))
        Sp = shooting.residual(z, params(theta + fd_step))
        return S, np.hstack([Jz, ((Sp - S) / fd_step)[:, None]]) * scale

    def tangent(J: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
        _, _, vt = np.linalg.svd(J)
        t = vt[-1]
        if previous is None:
            return t if np.sign(t[-1]) == direction else -t
        return t if t @ previous >= 0 else -t

    path = ContinuationPath(parameter, start=start)
    X = np.concatenate([np.asarray(z0, dtype=float), [to_theta(start)]]) / scale
    S, J = F_and_J(X)
    if np.linalg.norm(S) > 1e3 * tol:
        raise ValueError(f"z0 does not solve the problem at {parameter} = {start}: |S| = {np.linalg.norm(S):.2e}")
    t = tangent(J, None)
    h = h0

    def add(X: np.ndarray) -> None:
        z = X[:-1] * scale[:-1]
        path.values.append(from_theta(X[-1]))
        path.z.append(z)
        path.results.append(z)  # (the unknowns are the result of a point of the curve)
        path.iterations = len(path.values) - 1

    add(X)
    while path.steps < max_steps:
        path.steps += 1
        Xp = X + h * t
        Y, ok = Xp.copy(), False
        for _ in range(max_corrector):
            try:
                S, J = F_and_J(Y)
            except (SolverError, ValueError):
                break
            G = np.concatenate([S, [t @ (Y - Xp)]])
            if np.linalg.norm(S) <= tol:
                ok = True
                break
            try:
                dY = np.linalg.solve(np.vstack([J, t]), -G)
            except np.linalg.LinAlgError:
                break
            Y = Y + dY
            if not np.all(np.isfinite(Y)):
                break
        if not ok:
            path.failures += 1
            h *= 0.5
            if h < hmin:
                path.ended(Outcome.STEP_TOO_SMALL, f"step size below {hmin} at {parameter} = {from_theta(X[-1]):.6g}")
                break
            continue
        # targets crossed between X and Y
        for tt in target_thetas:
            if (X[-1] - tt) * (Y[-1] - tt) <= 0 and X[-1] != tt:
                a = (tt - X[-1]) / (Y[-1] - X[-1])
                guess = (X[:-1] + a * (Y[:-1] - X[:-1])) * scale[:-1]
                try:
                    r = shooting.solve(guess, params(tt), tol=tol)
                    path.targets.setdefault(target_values[tt], []).append(r)
                except SolverError as exc:
                    path.refinement_failures.setdefault(target_values[tt], []).append(str(exc))
        t_new = tangent(J, t)
        X, t = Y, t_new
        add(X)
        if direction * (X[-1] - theta_stop) >= 0:
            path.ended(Outcome.CONVERGED, "reached the end of the interval")
            break
        if stop_at_turn and path.turning_points:
            theta = np.array([to_theta(v) for v in path.values])
            turn = theta[path.turning_points[0]]
            if abs(theta[-1] - turn) > 0.05 * abs(turn - theta[0]):
                path.ended(Outcome.FOLD, f"folded back at {parameter} = {from_theta(turn):.6g}")
                break
        h = min(hmax, h * 1.5)
    else:
        path.ended(Outcome.MAX_ITERATIONS, f"stopped after {max_steps} steps")
    if raise_on_failure and not path.converged:
        raise SolverError(
            "pseudo-arclength continuation",
            str(path.status),
            path.iterations,
            path.detail,
            unit="points solved",
            result=path,
            outcome=path.status,
        )
    return path
