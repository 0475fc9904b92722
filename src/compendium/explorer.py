"""Move a slider, see the new optimal trajectory: :func:`explore`.

What is explored is a family of problems: each value of the sliders (continuous parameters) and of the drop-downs
(discrete choices) is solved again, warm-started from the solved value nearest to it (a continuation along the
slider's path), and the curves are redrawn in place.

* A family says how one value is solved from another. :class:`TranscriptionFamily`: a transcription built once
  (or one per combination of choices, ``build(**choices)``, each built when first chosen), solved at the new
  parameter values from the nearest solution: exactly where it is of the same transcription, else interpolated.
  :class:`ShootingFamily`: the extremals of an indirect shooting, each found from the nearest one (its unknowns,
  or a prediction from them, e.g. the final time scaled), the shooting rebuilt at each value (so a boundary
  condition may move with the parameter).
* :class:`ExploreSession` is the solving half, usable without a screen: ``solve(values)`` returns a value solved
  before as it was; else it starts from the nearest solved values (ranked by how many choices differ, then by
  distance in each parameter's share of its range), then from the next nearest, then, stepping halfway from the
  nearest towards the target, from the points in between (ocpkit's continuation engine,
  :func:`ocpkit.shooting.continuation.follow` with :class:`~ocpkit.shooting.continuation.Toward`). It never raises
  for a failed solve (the :class:`SolveReport` says so: no solution, the status of the solve at the value asked);
  it raises a ``KeyError`` naming an unknown parameter or choice, and a ``ValueError`` naming a parameter outside
  its range or a choice that is not one of its options. A transcription's solves use an IPOPT instance of their own
  (:data:`EXPLORER_IPOPT`) and one lock per transcription, so a solve of the same transcription in the notebook's
  thread, or by another explorer, never runs in the same instance at the same time (that crashes the process).
* :class:`LatestOnly` runs one solve at a time in a background thread, always the newest value asked for: values
  asked while a solve runs replace one another, so dragging never queues stale work, and a continuation stops when
  a newer value waits; a drag still solves as it goes (``max_wait``). A result whose values were superseded before
  it finished is kept as a warm start but not drawn; an exception is shown as the status (``ERROR: ...``, no curve)
  and the thread goes on.
* :class:`Explorer` (what :func:`explore` returns) shows a slider per parameter, a drop-down per choice, the chosen
  histories (:class:`History`: a state, a control, a function of the trajectory, or a difference from a reference;
  a figure of ipympl's, its lines updated in place) and a status line: the solver's status, its iterations, the
  solve time, the accuracy (error estimate, or |S| for a shooting), the objective and what the family adds ("solving
  ..." while a value is solved). A failed solve draws no curve and says so in the status; an inaccurate one
  (accuracy above the threshold) is drawn grey. ``close()`` ends its thread; an explorer no longer shown keeps its
  transcriptions and solutions until it is closed (or its cell's output is cleared and it is collected).

It degrades to a picture: displayed where no widget can live (a stored notebook on GitHub, nbviewer, the HTML
report, papermill and nbval), the explorer shows a static figure of the default solution and a sentence saying it
is interactive in JupyterLab (the display carries both, and each front end shows what it can). It writes nothing
under ``figures/`` or ``data/derived/``.
"""

from __future__ import annotations

import base64
import contextlib
import html
import io
import threading
import time
import weakref
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ocpkit import Outcome, SolverError

#: what the static picture says
STATIC_NOTE = "Interactive in JupyterLab: run this cell there to move the sliders."

#: the explorer's IPOPT option overrides: its default output level, given, so that the transcription builds the
#: explorer an IPOPT instance of its own (one instance cannot run two solves at once: the process would crash)
EXPLORER_IPOPT = {"print_level": 0}

_LOCKS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_LOCKS_GUARD = threading.Lock()


@contextlib.contextmanager
def _solving(transcription):
    """One explorer's solve of ``transcription`` at a time (several explorers may share a transcription)."""
    with _LOCKS_GUARD:
        lock = _LOCKS.setdefault(transcription, threading.Lock())
    with lock:
        yield


def _import_ipympl() -> None:
    """Import ipympl without its side effect: its package ``__init__`` makes ipympl matplotlib's backend when
    matplotlib is loaded (``matplotlib.use``, which also closes every open figure), so every figure drawn after an
    explorer, in the notebook's inline backend, would become a widget. Imported while matplotlib is out of
    ``sys.modules``, it leaves the backend as it was; its backend module is then imported as usual."""
    import sys

    if "ipympl" in sys.modules:
        return
    matplotlib = sys.modules.pop("matplotlib", None)
    try:
        import ipympl  # noqa: F401
    finally:
        if matplotlib is not None:
            sys.modules["matplotlib"] = matplotlib


@dataclass(frozen=True)
class SolveReport:
    """One solve of an :class:`ExploreSession`: the ``values`` asked for (parameters, and choices by label), the
    ``solution`` (None where the solve failed), the solver's ``status`` and ``iterations``, the wall time
    ``solve_s`` (every attempt), the ``error_estimate`` (the family's ``measure`` of accuracy: a transcription's
    error estimate, a shooting's |S|) and the ``objective`` (named ``objective_label``; NaN without a solution), the
    solved values it was warm-started from (``start``; None: the family's own first solution), the ``attempts``
    and what the family adds (``note``). A value solved before is that solution again (no attempt)."""

    values: dict
    solution: object | None
    status: str
    iterations: int
    solve_s: float
    error_estimate: float = float("nan")
    objective: float = float("nan")
    start: dict | None = None
    attempts: int = 1
    measure: str = "error estimate"
    note: str = ""
    objective_label: str = "objective"

    @property
    def solved(self) -> bool:
        return self.solution is not None

    def accurate(self, threshold: float) -> bool:
        return self.solved and bool(self.error_estimate <= threshold)

    def status_line(self) -> str:
        if not self.solved:
            return f"FAILED: {self.status} ({self.attempts} attempts, {1e3 * self.solve_s:.0f} ms); no curve drawn"
        parts = [
            self.status,
            f"{self.iterations} iterations",
            f"{1e3 * self.solve_s:.0f} ms",
            f"{self.measure} {self.error_estimate:.1e}",
        ]
        if self.objective_label:
            parts.append(f"{self.objective_label} {self.objective:.8g}")
        return " · ".join(parts + ([self.note] if self.note else []))


def _options(name: str, spec) -> dict:
    """A choice's options as ``{label: value}`` (a list's items are their own labels, so they must be hashable)."""
    if isinstance(spec, Mapping):
        options = dict(spec)
    else:
        options = {}
        for option in spec:
            try:
                hash(option)
            except TypeError:
                raise TypeError(
                    f"choice {name!r}: the option {option!r} cannot be its own label; give {{label: value}}"
                ) from None
            options[option] = option
    if not options:
        raise ValueError(f"choice {name!r} has no options")
    return options


def _is_option(label, options: Mapping) -> bool:
    try:
        return label in options
    except TypeError:  # an unhashable label is none of them
        return False


class TranscriptionFamily:
    """The direct solutions of a transcription over its problem's parameters, and over discrete choices.

    ``transcription``: a built one; or ``build(**choices)``, called with the choices' values (``choices``:
    ``{name: options}``, a list or ``{label: value}``; the first option each one's default unless ``defaults``
    names another label) and each combination built when first chosen, the last ``keep_built`` kept. A solve
    starts from the nearest solved solution: exactly where it is of the same transcription, else interpolated onto
    the new mesh (:meth:`ocpkit.transcription.base.Transcription.initial_point`). ``solve_options``: passed to every
    ``solve`` (default ``error_threshold=None``: the explorer reports the estimate itself); ``note(solution)``:
    what the status line adds. A combination is built in the explorer's thread, under this family's lock."""

    measure = "error estimate"
    objective_label = "objective"

    def __init__(
        self,
        transcription=None,
        *,
        build: Callable | None = None,
        choices: Mapping[str, object] | None = None,
        defaults: Mapping[str, object] | None = None,
        solve_options: Mapping | None = None,
        note: Callable | None = None,
        keep_built: int = 16,
    ):
        if (transcription is None) == (build is None):
            raise ValueError("give a built transcription or build(**choices), not both")
        if transcription is not None and (choices or defaults):
            raise ValueError("choices need build(**choices): a built transcription has none")
        self.options = {name: _options(name, spec) for name, spec in (choices or {}).items()}
        defaults = dict(defaults or {})
        unknown = sorted(set(defaults) - set(self.options))
        if unknown:
            raise KeyError(f"defaults {unknown} are not choices; the choices are {sorted(self.options)}")
        self.choice_defaults = {}
        for name, options in self.options.items():
            label = defaults.get(name, next(iter(options)))
            if not _is_option(label, options):
                raise ValueError(f"choice {name!r}: default {label!r} is not one of {list(options)}")
            self.choice_defaults[name] = label
        self._build, self.note, self.keep_built = build, note, max(1, int(keep_built))
        self._built: OrderedDict = OrderedDict()
        self._loops: dict = {}  # per built transcription (by id), dropped with it
        self._lock = threading.Lock()
        if transcription is not None:
            self._built[()] = transcription
        options = dict(solve_options or {})
        # an IPOPT instance of the explorer's own (the transcription keeps one per set of option overrides): a solve
        # of the transcription elsewhere, in the notebook's own thread, may run while the explorer's does
        options["ipopt_options"] = {**EXPLORER_IPOPT, **(options.get("ipopt_options") or {})}
        self.solve_options = {"error_threshold": None, **options, "raise_on_failure": True}

    def transcription(self, labels: Mapping | None = None) -> object:
        """The transcription of these choices (by label; default: the defaults), built once."""
        if self._build is None:
            return self._built[()]
        labels = {**self.choice_defaults, **(labels or {})}
        key = tuple(labels[n] for n in self.options)
        with self._lock:
            if key in self._built:
                self._built.move_to_end(key)
                return self._built[key]
        built = self._build(**{n: self.options[n][label] for n, label in labels.items()})
        with self._lock:
            built = self._built.setdefault(key, built)
            while len(self._built) > self.keep_built:
                _, evicted = self._built.popitem(last=False)
                self._loops.pop(id(evicted), None)  # its loop holds it: dropped together
        return built

    def _loop(self, transcription):
        """The transcription's solve loop (:meth:`~ocpkit.program.Program.loop`: a solve at the IPOPT call's cost,
        the same result as ``solve``), made once per transcription; None where the solve options ask for more
        than one IPOPT solve of one mesh."""
        options = dict(self.solve_options)
        if options.pop("error_threshold", None) is not None or options.pop("mesh_tolerance", None) is not None:
            return None
        if not set(options) <= {"ipopt_options", "allow_acceptable", "raise_on_failure"}:
            return None
        with self._lock:
            loop = self._loops.get(id(transcription))
        program = getattr(transcription, "program", transcription)  # a scheme bound to its problem, or a Program
        if loop is None or loop.program is not program:
            # built outside the family's lock (the NLP, IPOPT, perhaps a compilation); the first one built is kept
            built = transcription.loop(
                ipopt_options=options.get("ipopt_options"), allow_acceptable=options.get("allow_acceptable", False)
            )
            with self._lock:
                loop = self._loops.get(id(transcription))
                if loop is None or loop.program is not program:
                    loop = self._loops[id(transcription)] = built
        return loop

    def parameters(self) -> Mapping[str, float]:
        """The problem's parameters and their own values (those of the default choices' transcription)."""
        problem = self.transcription().problem
        return {n: problem.parameters[n] for n in problem.parameters}

    def first(self):
        """The default choices' transcription solved at the problem's own values."""
        transcription = self.transcription()
        with _solving(transcription):
            return transcription.solve(**self.solve_options)

    @staticmethod
    def solved_at(solution) -> Mapping[str, float]:
        return solution.problem.parameters

    def attempt(self, values: Mapping, labels: Mapping, start, start_values: Mapping):
        """The solution at ``values`` of the choices ``labels`` from ``start``; raises :class:`~ocpkit.SolverError`
        where it fails."""
        transcription = self.transcription(labels)
        with _solving(transcription):  # one solve of a transcription at a time, among explorers
            loop = self._loop(transcription)
            if loop is None:  # options a loop does not take (a mesh refinement, an error threshold)
                solution = transcription.solve(start, parameters=dict(values), **self.solve_options)
            else:
                solution = loop(dict(values), guess=start).solution
        if not solution.converged:  # (raise_on_failure is forced, but a solution that says so is never drawn)
            raise SolverError("IPOPT", solution.status, solution.iterations)
        return solution

    def describe(self, solution) -> dict:
        return {
            "status": solution.status,
            "iterations": solution.iterations,
            "error_estimate": float(solution.state_error),
            "objective": float(solution.objective),
            "objective_label": self.objective_label,
            "note": "" if self.note is None else str(self.note(solution)),
        }

    @staticmethod
    def trajectory(solution):
        return solution


class ShootingFamily:
    """The extremals of a shooting problem over its parameters, each found from the nearest one (a continuation).

    ``build(values)``: the :class:`~ocpkit.shooting.Shooting` at those parameter values (every value of ``values``,
    the explored ones changed; it is rebuilt for each, so a boundary condition may move with them); ``first``: a
    converged :class:`~ocpkit.shooting.ShootingResult` at ``values``; ``predict(start_values, z, values)``: the
    unknowns to start from at ``values``, given those ``z`` solved at ``start_values`` (default: ``z`` itself);
    ``solve_options``: passed to ``Shooting.solve`` (default: MINPACK's hybrid method, 100 evaluations);
    ``note(result)``: what the status line adds (e.g. the fuel and the switchings); ``objective_label``: the name of
    the objective there ("": not shown). The status line's status and iterations are the run's (its
    :class:`~ocpkit.Outcome` and its Newton iterations, Jacobian evaluations), its accuracy the residual |S|. A
    shooting whose integration fails is a failed solve, as one that does not converge. It has no discrete
    choices."""

    measure = "|S|"
    options: dict = {}
    choice_defaults: dict = {}

    def __init__(
        self,
        build: Callable[[dict], object],
        first,
        values: Mapping[str, float],
        *,
        predict: Callable | None = None,
        solve_options: Mapping | None = None,
        note: Callable | None = None,
        objective_label: str = "objective",
    ):
        if not getattr(first, "converged", False):
            raise ValueError("first must be a converged shooting result (the family is followed from it)")
        self.build, self.predict, self.note, self.objective_label = build, predict, note, objective_label
        self.values = {n: float(v) for n, v in values.items()}
        self._first = first
        self.solve_options = {"solver": "hybr", "maxfev": 100, **(solve_options or {}), "raise_on_failure": True}
        self._lock = threading.Lock()

    def parameters(self) -> Mapping[str, float]:
        return dict(self.values)

    def first(self):
        return self._first

    def solved_at(self, result) -> Mapping[str, float]:
        if result is not self._first:
            raise ValueError("a shooting family starts from its own first result: give first to ShootingFamily")
        return self.values

    def attempt(self, values: Mapping, labels: Mapping, start, start_values: Mapping):
        """The extremal at ``values`` from ``start`` (solved at ``start_values``); raises
        :class:`~ocpkit.SolverError` where the shooting fails."""
        values = {**self.values, **{n: float(v) for n, v in values.items()}}
        start_values = {**self.values, **start_values}
        z = start.z if self.predict is None else self.predict(start_values, np.asarray(start.z), values)
        with self._lock:
            try:
                return self.build(values).solve(np.asarray(z, dtype=float), **self.solve_options)
            except (ValueError, ArithmeticError) as exc:  # e.g. the integration from these unknowns fails
                raise SolverError("shooting", f"{type(exc).__name__}: {exc}") from exc

    def describe(self, result) -> dict:
        return {
            "status": str(result.status),
            "iterations": int(result.iterations),
            "error_estimate": float(result.norm),
            "objective": float(result.objective),
            "objective_label": self.objective_label,
            "note": "" if self.note is None else str(self.note(result)),
        }

    @staticmethod
    def trajectory(result):
        return result.trajectory


class ExploreSession:
    """Solves a family of problems at values chosen one after another (module docstring).

    ``target``: a built transcription (its problem's parameters are explored); ``build(**choices)`` returning one,
    with ``choices`` (``{name: options}``, a list or ``{label: value}``) and their ``defaults`` (labels; else each
    one's first option); or a family (:class:`TranscriptionFamily`, :class:`ShootingFamily`), which holds its
    choices, solve options and note itself. ``parameters``: ``{name: (low, high)}``, continuous parameters of the
    problem. ``first``: a solution to start from (default: the family's first, a transcription solved at the
    problem's own values; a shooting family's is its own); ``solve_options`` and ``note(solution)``: a
    transcription's (:class:`TranscriptionFamily`); ``halvings``: how many times the continuation halves its step
    towards a value it cannot reach directly; ``keep``: how many solutions are kept as warm starts.

    ``defaults`` are the parameters' values of the first solution, ``choice_defaults`` the choices' labels."""

    def __init__(
        self,
        target,
        parameters: Mapping[str, tuple[float, float]] | None = None,
        *,
        choices: Mapping[str, object] | None = None,
        defaults: Mapping[str, object] | None = None,
        first=None,
        solve_options: Mapping | None = None,
        note: Callable | None = None,
        halvings: int = 3,
        keep: int = 200,
    ):
        parameters = dict(parameters or {})
        if hasattr(target, "attempt"):
            if solve_options or note or choices or defaults:
                raise ValueError("give choices, defaults, solve_options and note to the family, not to the session")
            family = target
        elif choices:
            if not callable(target) or hasattr(target, "solve"):
                raise TypeError("with choices, give build(**choices) returning a transcription")
            family = TranscriptionFamily(
                build=target, choices=choices, defaults=defaults, solve_options=solve_options, note=note
            )
        else:
            if defaults:
                raise ValueError("defaults are the choices' labels; there are no choices")
            family = TranscriptionFamily(target, solve_options=solve_options, note=note)
        self.family = family
        self.options, self.choice_defaults = family.options, dict(family.choice_defaults)
        if not parameters and not self.options:
            raise ValueError("give at least one parameter ({name: (low, high)}) or choice to explore")
        own = family.parameters()
        ranges = {}
        for name, bounds in parameters.items():
            if name in self.options:
                raise ValueError(f"{name!r} is both a parameter and a choice")
            if name not in own:
                raise KeyError(f"unknown parameter {name!r}; the problem has {sorted(own)}")
            lo, hi = (float(b) for b in bounds)
            if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
                raise ValueError(f"parameter {name!r}: its range must be finite with low < high, got {bounds!r}")
            ranges[name] = (lo, hi)
        self.ranges = ranges
        self.names = list(ranges)
        self.halvings, self.keep = int(halvings), int(keep)
        self._lock = threading.Lock()
        self.solved: list[tuple[np.ndarray, tuple, object]] = []  # (values in range units, labels, solution)
        if first is None:
            first = family.first()
        solved_with = family.solved_at(first)  # the values the solution was solved at
        self.defaults = {n: float(solved_with.get(n, own[n])) for n in self.names}
        self._remember(self._point(self.defaults), self._labels(self.choice_defaults), first)
        self.first = first

    @property
    def transcription(self):
        """The transcription of the default choices (a transcription family's)."""
        return self.family.transcription()

    def _point(self, values: Mapping[str, object], check: bool = True) -> np.ndarray:
        unknown = sorted(set(values) - set(self.names) - set(self.options))
        if unknown:
            raise KeyError(
                f"unknown parameters or choices {unknown}; this explorer varies {self.names + list(self.options)}"
            )
        out = []
        for n in self.names:
            v = float(values.get(n, self.defaults[n]))
            lo, hi = self.ranges[n]
            if check and not (np.isfinite(v) and lo <= v <= hi):
                raise ValueError(f"parameter {n!r} = {v!r} is outside its range [{lo:g}, {hi:g}]")
            out.append((v - lo) / (hi - lo))
        return np.array(out)

    def _labels(self, values: Mapping[str, object]) -> tuple:
        out = []
        for n, options in self.options.items():
            label = values.get(n, self.choice_defaults[n])
            if not _is_option(label, options):
                raise ValueError(f"choice {n!r} = {label!r} is not one of {list(options)}")
            out.append(label)
        return tuple(out)

    def _values(self, point: np.ndarray) -> dict:
        return {n: float(lo + p * (hi - lo)) for n, p, (lo, hi) in zip(self.names, point, self.ranges.values())}

    def _choices(self, labels: tuple) -> dict:
        return dict(zip(self.options, labels))

    def _remember(self, point, labels, solution) -> None:
        with self._lock:
            same = lambda s: np.array_equal(s[0], point) and s[1] == labels  # noqa: E731
            self.solved = [s for s in self.solved if not same(s)]  # the newest at a point
            self.solved.append((point, labels, solution))
            del self.solved[: max(0, len(self.solved) - self.keep)]

    def nearest(self, values: Mapping[str, object], count: int = 2) -> list[tuple[np.ndarray, tuple, object]]:
        """The ``count`` solved points nearest to ``values``: ranked by how many choices differ, then by distance
        (in each parameter's share of its range)."""
        target, labels = self._point(values), self._labels(values)
        with self._lock:
            ranked = sorted(
                self.solved,
                key=lambda s: (sum(a != b for a, b in zip(s[1], labels)), float(np.linalg.norm(s[0] - target))),
            )
        return ranked[:count]

    def solve(self, values: Mapping[str, object], superseded: Callable[[], bool] = lambda: False) -> SolveReport:
        """The family solved at ``values`` (the others at their defaults), from the nearest solved points, else by
        continuation from the nearest (module docstring). A failed solve is a :class:`SolveReport` without a
        solution, never an exception; its status is that of the solve at ``values`` from the nearest solved point.
        ``superseded()``, asked between attempts: True stops the search (status ``"superseded"``).

        The search is :func:`ocpkit.shooting.continuation.follow` towards the target point (each parameter's share
        of its range) by :class:`~ocpkit.shooting.continuation.Toward` (the target from the nearest solved points
        in turn, the first that solves; then halfway from the nearest, the step halved on each failure, the target
        again from each point solved), every point solved on the way remembered as a warm start."""
        from ocpkit.shooting.continuation import Toward, follow

        target, labels = self._point(values), self._labels(values)
        asked = {n: float(values.get(n, self.defaults[n])) for n in self.names} | self._choices(labels)
        params = {n: asked[n] for n in self.names}
        near = self.nearest(asked)
        point, its_labels, start = near[0]
        if its_labels == labels and np.array_equal(point, target):  # solved before: that solution again
            return self._done(asked, target, labels, start, 0.0, 0, point, its_labels)
        # what the search met: the attempts, their time, the first one's failure, the start of the last one
        met = {"attempts": 0, "spent": 0.0, "status": "", "iterations": 0, "from": near[0]}

        def attempt(value: np.ndarray, guess: tuple):
            from_point, from_labels, from_solution = guess
            at = params if np.array_equal(value, target) else self._values(value)
            t = time.perf_counter()
            try:
                solution = self.family.attempt(at, self._choices(labels), from_solution, self._values(from_point))
            except SolverError as exc:
                if met["attempts"] == 0:  # the status shown is the solve at the value asked, from the nearest
                    met["status"], met["iterations"] = exc.status, exc.iterations or 0
                raise
            finally:
                met["attempts"] += 1
                met["spent"] += time.perf_counter() - t
            met["from"] = guess
            return solution

        def starts(history: list, value: np.ndarray) -> list:
            if len(history) == 1 and np.array_equal(value, target):  # the target: from each nearest point in turn
                return list(near)
            last = history[-1]
            return [(last[0], its_labels if len(history) == 1 else labels, last.result)]

        path = follow(
            attempt,
            None,
            point,
            Toward(target, self.halvings),
            predictor=starts,
            choose="first",
            cancelled=superseded,
            remember=lambda value, solution: self._remember(value, labels, solution),
            raise_on_failure=False,
            first=start,
        )
        if path.converged:
            from_point, from_labels, _ = met["from"]
            return self._done(
                asked, target, labels, path.results[-1], met["spent"], met["attempts"], from_point, from_labels
            )
        if path.status is Outcome.CANCELLED:
            return SolveReport(asked, None, "superseded", 0, met["spent"], attempts=met["attempts"])
        return SolveReport(
            asked,
            None,
            met["status"],
            met["iterations"],
            met["spent"],
            start=self._values(near[0][0]) | self._choices(near[0][1]),
            attempts=met["attempts"],
            measure=self.family.measure,
        )

    def _done(self, asked, target, labels, solution, spent, attempts, start_point, start_labels) -> SolveReport:
        self._remember(target, labels, solution)
        return SolveReport(
            asked,
            solution,
            solve_s=spent,
            start=self._values(start_point) | self._choices(start_labels),
            attempts=attempts,
            measure=self.family.measure,
            **self.family.describe(solution),
        )

    def outcome_of_first(self) -> SolveReport:
        """The first solution as a :class:`SolveReport` (what the explorer shows before any move)."""
        s = self.first
        return SolveReport(
            dict(self.defaults) | dict(self.choice_defaults),
            s,
            solve_s=float(getattr(s, "solve_s", getattr(s, "cpu_s", 0.0))),
            measure=self.family.measure,
            **self.family.describe(s),
        )


class LatestOnly:
    """``work(request)`` in a background thread for the newest request only (module docstring); ``deliver(result)``
    is called with each result whose request was not superseded while it ran. A request starts after ``debounce``
    seconds without a newer one, or ``max_wait`` seconds after it was first asked, whichever comes first (a drag
    that sends a value every 16 ms still solves as it goes). ``work`` may ask :meth:`superseded` to stop early. An
    exception in ``work`` or ``deliver`` becomes ``failed(request, exception)``, delivered: the thread goes on."""

    def __init__(
        self,
        work: Callable,
        deliver: Callable,
        failed: Callable | None = None,
        *,
        debounce: float = 0.02,
        max_wait: float = 0.1,
    ):
        self.work, self.deliver, self.failed = work, deliver, failed
        self.debounce, self.max_wait = float(debounce), float(max_wait)
        self._pending = None
        self._since = 0.0
        self._stamp = 0
        self._busy = False
        self._stopped = False
        self._cv = threading.Condition()
        self.delivered = 0
        self.dropped = 0
        self.errors: list[BaseException] = []
        self._thread = threading.Thread(target=self._run, name="explorer", daemon=True)
        self._thread.start()

    def submit(self, request) -> None:
        with self._cv:
            if self._pending is not None:
                self.dropped += 1
            else:
                self._since = time.monotonic()
            self._pending = request
            self._stamp += 1
            self._cv.notify_all()

    def busy(self) -> bool:
        """Whether a request waits or runs."""
        with self._cv:
            return self._pending is not None or self._busy

    def superseded(self) -> bool:
        """Whether a newer request waits (the running one may stop)."""
        with self._cv:
            return self._pending is not None or self._stopped

    def idle(self, timeout: float = 30.0) -> bool:
        """Wait until no request is pending or running (True), or ``timeout`` seconds (False)."""
        end = time.monotonic() + timeout
        with self._cv:
            while self._pending is not None or self._busy:
                left = end - time.monotonic()
                if left <= 0 or not self._cv.wait(left):
                    return self._pending is None and not self._busy
        return True

    def stop(self) -> None:
        """End the thread (after the request running, if any)."""
        with self._cv:
            self._stopped, self._pending = True, None
            self._cv.notify_all()

    def _next(self):
        with self._cv:
            while self._pending is None and not self._stopped:
                self._cv.wait()
            while not self._stopped:
                stamp, waited = self._stamp, time.monotonic() - self._since
                quiet = min(self.debounce, max(0.0, self.max_wait - waited))
                newer = lambda s=stamp: self._stamp != s or self._stopped  # noqa: E731
                if quiet <= 0 or not self._cv.wait_for(newer, timeout=quiet):
                    break  # quiet long enough, or waited long enough
            if self._stopped:
                return None, False
            request, self._pending, self._busy = self._pending, None, True
            return request, True

    def _run(self) -> None:
        while True:
            request, ok = self._next()
            if not ok:
                return
            try:
                try:
                    result = self.work(request)
                except Exception as exc:  # noqa: BLE001  (any error is shown, and the explorer goes on)
                    self.errors.append(exc)
                    if self.failed is None:
                        continue
                    result = self.failed(request, exc)
                with self._cv:
                    stale = self._pending is not None
                    if stale:
                        self.dropped += 1
                if not stale:
                    try:
                        self.deliver(result)
                        self.delivered += 1
                    except Exception as exc:  # noqa: BLE001
                        self.errors.append(exc)
                        if self.failed is not None:
                            with contextlib.suppress(Exception):
                                self.deliver(self.failed(request, exc))
            finally:
                with self._cv:
                    self._busy = False
                    self._cv.notify_all()


@dataclass
class History:
    """A panel of the explorer: ``column`` a state or control of the problem, drawn against time (``label`` on the
    axis; ``scale`` multiplies the values), or any quantity ``function(trajectory, t)`` computes (e.g. the thrust's
    magnitude), named ``column``; ``samples`` points in time (a bang-bang control needs many)."""

    column: str
    label: str = ""
    scale: float = 1.0
    function: Callable | None = None
    samples: int = 200

    def values(self, trajectory, t: np.ndarray) -> np.ndarray:
        """The quantity along ``trajectory`` at times ``t`` (unscaled)."""
        problem = trajectory.problem
        if self.function is not None:
            return np.asarray(self.function(trajectory, t), dtype=float)
        if self.column in problem.state_names:
            return trajectory.state(t)[:, problem.state_names.index(self.column)]
        if self.column in problem.control_names:
            return trajectory.control(t)[:, problem.control_names.index(self.column)]
        raise KeyError(
            f"unknown history {self.column!r}; the states are {list(problem.state_names)}, the controls "
            f"{list(problem.control_names)} (or give a function)"
        )

    def data(self, trajectory, samples: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(t, scale * values)`` at ``samples`` times evenly spaced over the trajectory."""
        t = np.linspace(trajectory.t0, trajectory.tf, self.samples if samples is None else samples)
        return t, self.scale * np.asarray(self.values(trajectory, t), dtype=float)

    @classmethod
    def against(cls, reference, column: str, label: str = "", scale: float = 1.0, samples: int = 200) -> History:
        """The difference of ``column`` from ``reference`` (a trajectory: a converged solution, say) at the same
        normalised time ``(t - t0) / (tf - t0)``, as :meth:`ocpkit.trajectory.Trajectory.difference` compares."""
        at = cls(column)
        at.values(reference, np.array([reference.t0]))  # an unknown column is an error here

        def difference(trajectory, t):
            s = (t - trajectory.t0) / (trajectory.tf - trajectory.t0)
            return at.values(trajectory, t) - at.values(reference, reference.t0 + s * (reference.tf - reference.t0))

        return cls(f"{column} - reference", label or f"{column} − reference", scale, difference, samples)


@dataclass
class Explorer:
    """The sliders (``sliders``, one per parameter), the drop-downs (``choosers``, one per choice), the live figure
    and the status line of :func:`explore` (module docstring); ``outcome`` the outcome drawn last, ``timings`` the
    last move's split (``solve_s``, ``data_s``, ``redraw_s``)."""

    session: ExploreSession
    histories: list
    threshold: float = 1e-3
    steps: int = 100
    time_label: str = "t"
    outcome: SolveReport | None = None
    timings: dict = field(default_factory=dict)

    def __post_init__(self):
        import ipywidgets as widgets
        from matplotlib.figure import Figure

        self.histories = [h if isinstance(h, History) else History(h) for h in self.histories]
        first = self._trajectory(self.session.first)
        for h in self.histories:
            h.data(first, 2)  # an unknown column is an error here, not in the thread
        self.figure = Figure(figsize=(8, 1.2 + 1.6 * len(self.histories)), layout="constrained")
        axes = self.figure.subplots(len(self.histories), 1, sharex=True, squeeze=False)[:, 0]
        self.lines, self.reference = [], []
        for ax, h in zip(axes, self.histories):
            t, y = h.data(first)
            (ref,) = ax.plot(t, y, color="0.6", lw=1.0, ls="--", label="default")
            (line,) = ax.plot(t, y, color="C0", lw=1.6, label="this value")
            ax.set_ylabel(h.label or h.column)
            self.lines.append(line)
            self.reference.append(ref)
        axes[0].legend(fontsize=8, loc="best")
        axes[-1].set_xlabel(self.time_label)
        # the layout computed once: redrawn on every move, the constrained layout took half of Agg's drawing time
        self.figure.draw_without_rendering()
        self.figure.set_layout_engine("none")
        self.axes = list(axes)
        self.sliders = {}
        for name, (lo, hi) in self.session.ranges.items():
            default = self.session.defaults[name]
            step = (hi - lo) / self.steps
            if default > lo:  # the default on the slider's grid (the front end snaps a value to it, and sends it back)
                step = (default - lo) / max(1, round((default - lo) / step))
            s = widgets.FloatSlider(
                value=default,
                min=lo,
                max=hi,
                step=step,
                description=name,
                continuous_update=True,
                readout_format=".4g",
                layout=widgets.Layout(width="480px"),
            )
            s.observe(self._moved, names="value")
            self.sliders[name] = s
        self.choosers = {}
        for name, options in self.session.options.items():
            d = widgets.Dropdown(
                options=[(str(label), label) for label in options],  # (a label may itself be a tuple)
                value=self.session.choice_defaults[name],
                description=name,
                layout=widgets.Layout(width="480px"),
            )
            d.observe(self._moved, names="value")
            self.choosers[name] = d
        self.outcome = self.session.outcome_of_first()
        self.status = widgets.HTML(value=self._status_html(self.outcome))
        self.worker = LatestOnly(self._solve, self._draw, self._failed)
        self._canvas = None

    def _trajectory(self, solution):
        return self.session.family.trajectory(solution)

    def _status_html(self, outcome: SolveReport) -> str:
        colour = "#b00020" if not outcome.solved else ("#666" if not outcome.accurate(self.threshold) else "#1b5e20")
        note = "" if not outcome.solved or outcome.accurate(self.threshold) else " (inaccurate: drawn grey)"
        line = html.escape(outcome.status_line() + note)
        return f"<span style='color:{colour};font-family:monospace'>{line}</span>"

    def values(self) -> dict:
        """The sliders' values; one within rounding of its default (the front end's grid, in its own floating point,
        may send 185.19999999999996 back for 185.2) is the default."""
        out = {}
        for n, s in self.sliders.items():
            v, default, (lo, hi) = float(s.value), self.session.defaults[n], self.session.ranges[n]
            out[n] = default if abs(v - default) <= 1e-9 * (hi - lo) else v
        return out | {n: d.value for n, d in self.choosers.items()}

    def _moved(self, _change=None) -> None:
        values = self.values()
        if self.outcome is not None and values == self.outcome.values and not self.worker.busy():
            return  # the front end's echo of the value drawn (snapped to its grid): nothing to solve
        self.worker.submit(values)
        asked = ", ".join(f"{n} = {v:.4g}" if isinstance(v, float) else f"{n} = {v}" for n, v in values.items())
        self.status.value = f"<span style='color:#666;font-family:monospace'>solving {html.escape(asked)} …</span>"

    def _failed(self, values, exc) -> tuple:
        message = f"ERROR: {type(exc).__name__}: {exc}"
        return SolveReport(dict(values), None, message, 0, 0.0), None

    def close(self) -> None:
        """Stop the explorer's thread and close its widgets (the solutions it kept are released with it)."""
        self.worker.stop()
        canvas = [self._canvas] if self._canvas is not None else []
        for w in [*self.sliders.values(), *self.choosers.values(), self.status, *canvas]:
            w.close()

    def _solve(self, values):
        t = time.perf_counter()
        outcome = self.session.solve(values, superseded=self.worker.superseded)
        trajectory = self._trajectory(outcome.solution) if outcome.solved else None
        data = [h.data(trajectory) for h in self.histories] if outcome.solved else None
        self.timings = {"solve_s": outcome.solve_s, "data_s": time.perf_counter() - t - outcome.solve_s}
        return outcome, data

    def _draw(self, result) -> None:
        outcome, data = result
        if outcome.status == "superseded":
            return  # a newer value is on its way
        t = time.perf_counter()
        self.outcome = outcome
        grey = outcome.solved and not outcome.accurate(self.threshold)
        for line, ax, d in zip(self.lines, self.axes, data or [None] * len(self.lines)):
            line.set_visible(d is not None)
            if d is not None:
                line.set_data(*d)
                line.set_color("0.55" if grey else "C0")
                ax.relim()
                ax.autoscale_view()
        self.status.value = self._status_html(outcome)
        if self._canvas is not None:
            self._canvas.draw_idle()
        self.timings["redraw_s"] = time.perf_counter() - t

    def widget(self):
        """The explorer as one ipywidgets box: sliders, drop-downs, status line, live figure (ipympl's canvas)."""
        import ipywidgets as widgets

        if self._canvas is None:
            import warnings

            import matplotlib.pyplot as plt

            _import_ipympl()
            from ipympl.backend_nbagg import new_figure_manager_given_figure

            # ipympl's toolbar calls traitlets in a way it deprecates (not ours); with interactive mode off, ipympl
            # keeps no reference of its own to the figure (plt.ion would queue it for a show that never comes)
            with warnings.catch_warnings(), plt.ioff():
                warnings.filterwarnings("ignore", "Passing unrecognized arguments", DeprecationWarning)
                manager = new_figure_manager_given_figure(id(self.figure), self.figure)
            self._canvas = manager.canvas
            self._canvas.header_visible = False
            self._canvas.toolbar_visible = False
        return widgets.VBox([*self.sliders.values(), *self.choosers.values(), self.status, self._canvas])

    @property
    def static_note(self) -> str:
        """What the static picture says (:data:`STATIC_NOTE`; "make the choices" where there is no slider)."""
        return STATIC_NOTE if self.sliders else STATIC_NOTE.replace("move the sliders", "make the choices")

    def static_png(self) -> bytes:
        """The default solution's figure as a PNG (what a front end without widgets shows)."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(figsize=self.figure.get_size_inches(), layout="constrained")
        axes = fig.subplots(len(self.histories), 1, sharex=True, squeeze=False)[:, 0]
        for ax, h, ref in zip(axes, self.histories, self.reference):
            ax.plot(*ref.get_data(), color="C0", lw=1.6)
            ax.set_ylabel(h.label or h.column)
        axes[-1].set_xlabel(self.time_label)
        values = ", ".join(
            [f"{n} = {v:.4g}" for n, v in self.session.defaults.items()]
            + [f"{n} = {v}" for n, v in self.session.choice_defaults.items()]
        )
        first = self.session.outcome_of_first()
        about = f"; {first.note}" if first.note else ""
        fig.suptitle(f"The default solution ({values}{about}). {self.static_note}", fontsize=8, wrap=True)
        buf = io.BytesIO()
        FigureCanvasAgg(fig).print_png(buf)
        return buf.getvalue()

    def _repr_mimebundle_(self, include=None, exclude=None):
        bundle = dict(self.widget()._repr_mimebundle_(include=include, exclude=exclude) or {})
        bundle["image/png"] = base64.b64encode(self.static_png()).decode("ascii")
        bundle["text/plain"] = self.static_note
        return bundle


def explore(
    target,
    parameters: Mapping[str, tuple[float, float]] | None = None,
    histories: Sequence | None = None,
    *,
    choices: Mapping[str, object] | None = None,
    defaults: Mapping[str, object] | None = None,
    first=None,
    threshold: float = 1e-3,
    solve_options: Mapping | None = None,
    note: Callable | None = None,
    time_label: str = "t",
) -> Explorer:
    """An explorer of ``target`` over ``parameters`` (``{name: (low, high)}``, parameters of its problem: a slider
    each) and ``choices`` (``{name: options}``, a list or ``{label: value}``: a drop-down each), drawing
    ``histories`` (state or control names, or :class:`History`) against time (module docstring). ``target``: a
    built transcription; ``build(**choices)`` returning one (called with the choices' values); or a family
    (:class:`TranscriptionFamily`, :class:`ShootingFamily`: extremals followed by continuation), which holds its
    choices, solve options and note. ``defaults``: the choices' default labels (else each one's first option);
    ``first``: a solution to start from (default: solved at the problem's own values); ``threshold``: the accuracy
    (error estimate, |S|) above which a solution is drawn grey; ``solve_options`` and ``note(solution)`` (what the
    status line adds): a transcription's; ``time_label``: the time axis's."""
    if not histories:
        raise ValueError("give the histories to draw: state or control names, or History")
    session = ExploreSession(
        target,
        parameters,
        choices=choices,
        defaults=defaults,
        first=first,
        solve_options=solve_options,
        note=note,
    )
    return Explorer(session, list(histories), threshold=threshold, time_label=time_label)


__all__ = [
    "STATIC_NOTE",
    "ExploreSession",
    "Explorer",
    "History",
    "LatestOnly",
    "ShootingFamily",
    "SolveReport",
    "TranscriptionFamily",
    "explore",
]
