"""The verdict of a direct solve: every part of its estimated error against a tolerance, and what else to read.

A :class:`Verdict` judges a :class:`~ocpkit.Solution` (its :attr:`~ocpkit.Solution.verdict`):

* **parts** (:class:`~ocpkit.accuracy.Accuracy`), each compared with the tolerance: ``state``, the relative state
  error of the Patterson-Hager-Rao estimate (:func:`~ocpkit.accuracy.interval_errors`); ``objective``, the gap
  between the NLP's cost and the cost its admissible control achieves when flown, with what the path constraints'
  violations between the points are worth (:func:`~ocpkit.accuracy.flown_objective`,
  :func:`~ocpkit.accuracy.path_cost_sensitivity`); ``path <label>``, each path constraint's largest violation
  between the scheme's points, in units of its scale (:func:`~ocpkit.accuracy.path_violations`).
* **notes** (:class:`Note`), what no error estimate shows and a user should know: a free time or a free parameter
  that ends on its bound (the optimum may lie beyond it), a control on one of its bounds over the whole horizon (the
  bound decides the solution), an unbounded control held on the box its runaway solve was given
  (:mod:`ocpkit.program.safeguard`: the solution is the bounded problem's), a state that no function reads (an
  output: it changes nothing).

``solve()`` computes the whole verdict of every direct solve with its ``error_threshold`` as the tolerance and warns
once per failing part (:class:`~ocpkit.accuracy.AccuracyWarning`, naming the part, its value, the tolerance and the
remedy; the state's per phase, a phase's path constraints in one warning) and once per note (:class:`SolutionNote`;
a state no function reads is noted quietly: it is often an output by design). ``solve(verdict="fast")`` skips the
one costly part, the objective's (it integrates the flown control), for loops and sliders; the verdict then records
that it was skipped (``Verdict.skipped``, :meth:`Verdict.describe`), and no warning says it.
``Verdict.accuracy`` flies the control at :func:`flight_tolerance` of the verdict's tolerance;
:attr:`~ocpkit.Solution.accuracy` (what refinement reads) at the flight's own, tighter one: their objective parts
agree to far below the tolerance.
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, cast

import numpy as np

from .accuracy import (
    AccuracyWarning,
    path_violation_message,
    path_violations,
    periodic_control_hint,
    singular_arc_hint,
    state_error_message,
)
from .statement import declared_turn
from .statement.symbols import readers

if TYPE_CHECKING:
    from .accuracy import Accuracy
    from .solution import PhaseSolution, Solution
    from .statement import OptimalControlProblem

#: The tolerance of a verdict when the solve gave none (``solve()``'s default ``error_threshold``)
DEFAULT_TOLERANCE = 1e-3
#: The kinds of verdict, ``"whole"`` (every part) or ``"fast"`` (all but the objective's, with no flight of the control)
VerdictKind = Literal["whole", "fast"]
#: The names of the kinds, as a solve takes them (``solve(verdict=...)``)
KINDS: tuple[str, ...] = ("whole", "fast")
#: How close to a bound (a fraction of the bounds' range, or of the bound's size where larger) counts as on it
ON_BOUND = 1e-6

REFINE = "refine the mesh (solve(mesh_tolerance=...))"


class SolutionNote(UserWarning):
    """What a solve's verdict notes about its solution (:class:`Note`): not an error, something to read."""


@dataclass(frozen=True)
class Note:
    """One note of a :class:`Verdict`: ``subject`` (``"tf"``, ``"parameter k"``, ``"control u"``, ``"state z"``;
    ``"phase p: ..."`` in a multi-phase solution), ``text``, the sentence that says it and what to do, and ``quiet``."""

    subject: str
    text: str
    #: whether it is recorded in the verdict but not warned (a state no function reads is often an output by design,
    #: the downrange of a minimum-time ascent)
    quiet: bool = False

    def __str__(self) -> str:
        return f"{self.subject}: {self.text}"


def worst_of(values: Iterable[float]) -> float:
    """The largest of ``values``, NaN where any is NaN (an estimate that is not a number fails; Python's ``max``
    would drop it)."""
    return float(np.max(np.fromiter(values, dtype=float)))


def check_kind(verdict: str) -> None:
    """Raise a ValueError naming ``verdict`` unless it is one of :data:`KINDS`."""
    if verdict not in KINDS:
        raise ValueError(
            f"verdict must be one of {KINDS!r} (the whole verdict, or all but the objective's part), got {verdict!r}"
        )


class Verdict:
    """The whole verdict of a solution (module docstring): its parts against ``tolerance``, and its notes.

    ``state``, ``objective`` (None when skipped) and ``path`` (label to value) are the parts; ``parts`` all the
    computed ones by name; ``skipped`` the names of the parts not computed (``("objective",)`` for
    ``kind="fast"``); ``notes`` the :class:`Note` s; ``passed`` whether every computed part is within the tolerance;
    ``complete`` whether every part was computed; ``accuracy`` the :class:`~ocpkit.accuracy.Accuracy` behind the
    objective's part (the NLP's and the flown cost), None when skipped.
    """

    def __init__(self, solution: Solution, tolerance: float = DEFAULT_TOLERANCE, kind: VerdictKind = "whole") -> None:
        check_kind(kind)
        if not (tolerance > 0 and math.isfinite(tolerance)):
            raise ValueError(f"a verdict's tolerance must be positive and finite, got {tolerance!r}")
        self.solution = solution
        self.tolerance = float(tolerance)
        self.kind = kind
        self.state = worst_of(p.state_error for p in solution.phases)
        self.accuracy: Accuracy | None = None
        if kind == "whole":
            self.accuracy = _accuracy(solution, flight_tolerance(self.tolerance))
        self.objective: float | None = None if self.accuracy is None else float(self.accuracy.objective)
        # each phase's largest violation per path constraint (the accuracy's where it was computed), and over them
        self.phase_path: list[dict[str, float]] = []
        phases = getattr(self.accuracy, "phases", [self.accuracy])
        for i, p in enumerate(solution.phases):
            if self.accuracy is not None:
                self.phase_path.append(dict(phases[i].path))
            else:
                labels, worst, _ = path_violations(p, p.estimate_intervals)
                self.phase_path.append(dict(zip(labels, worst.tolist())))
        self.path: dict[str, float] = {}
        for part in self.phase_path:
            for label, value in part.items():
                self.path[label] = worst_of((self.path.get(label, 0.0), value))
        self.skipped: tuple[str, ...] = () if kind == "whole" else ("objective",)
        self.notes: list[Note] = notes(solution)

    @property
    def parts(self) -> dict[str, float]:
        """Every computed part by name (``state``, ``objective``, ``path <label>``)."""
        out = {"state": self.state}
        if self.objective is not None:
            out["objective"] = self.objective
        return out | {f"path {k}": v for k, v in self.path.items()}

    @property
    def failing(self) -> list[str]:
        """The names of the parts over the tolerance (a part that is not a number fails)."""
        return [k for k, v in self.parts.items() if not v <= self.tolerance]

    @property
    def passed(self) -> bool:
        """Whether every computed part is within the tolerance (``complete`` says whether every part was)."""
        return not self.failing

    @property
    def complete(self) -> bool:
        """Whether every part was computed (False with ``solve(verdict="fast")``: the objective's was not)."""
        return not self.skipped

    @property
    def worst(self) -> tuple[str, float]:
        """The largest computed part and its name."""
        parts = self.parts
        name = max(parts, key=lambda k: parts[k] if not math.isnan(parts[k]) else math.inf)
        return name, parts[name]

    def describe(self) -> str:
        """One line: each part with its value (``(over)`` past the tolerance), the skipped parts, the notes."""
        bad = set(self.failing)
        items = [f"{k} {v:.1e}" + (" (over)" if k in bad else "") for k, v in self.parts.items()]
        items += [f"{k} not computed (solve(verdict='fast'))" for k in self.skipped]
        head = ("passed" if self.passed else "failed") + f" at {self.tolerance:g}: " + ", ".join(items)
        if self.accuracy is not None:
            head += f"; J {self.accuracy.objective_nlp:.10g}, flown {self.accuracy.objective_flown:.10g}"
        return head + "".join(f"; note {n}" for n in self.notes)

    def __repr__(self) -> str:
        return f"Verdict({self.describe()})"

    # -- saying it -------------------------------------------------------------------------------------------------
    def messages(self) -> list[tuple[str, type[Warning]]]:
        """What :meth:`warn` says: one message per failing part (state, objective, path), then one per note."""
        solution, tol = self.solution, self.tolerance
        out: list[tuple[str, type[Warning]]] = []
        for p, phase, path in zip(solution.phases, solution.program.phases, self.phase_path):
            label = phase.scheme.label if solution.single else f"phase {p.name!r}, {phase.scheme.label}"
            hint = functools.partial(periodic_control_hint, p)
            found = [
                state_error_message(label, p.interval_errors, p.estimate_intervals, tol, hint),
                path_violation_message(label, path, tol),
            ]
            out += [(m, AccuracyWarning) for m in found if m]
        if self.objective is not None and not self.objective <= tol:
            out.append((_objective_message(solution, self), AccuracyWarning))
        out += [(str(n), SolutionNote) for n in self.notes if not n.quiet]
        return out

    def warn(self, stacklevel: int = 2) -> None:
        """Warn once per failing part (:class:`~ocpkit.accuracy.AccuracyWarning`) and once per note
        (:class:`SolutionNote`), pointing at ``stacklevel`` (:func:`warnings.warn`'s, counted from the caller)."""
        for message, category in self.messages():
            warnings.warn(message, category, stacklevel=stacklevel + 1)


def flight_tolerance(tolerance: float) -> float:
    """The tolerance at which a verdict at ``tolerance`` flies the control for its objective's part: 1e-5 of it,
    within [:data:`ocpkit.flight.TOLERANCE`, 1e-8] (the flown cost then moves its part by about 1e-6 of the
    tolerance or less on notebook 07's problems; flying at 1e-8 rather than 1e-12 takes a third of the time)."""
    from .flight import TOLERANCE

    return float(min(max(tolerance * 1e-5, TOLERANCE), 1e-8))


def _accuracy(solution: Solution, tol: float) -> Accuracy:
    """The solution's accuracy where it is at hand (a refinement computed it), else one flown at ``tol`` (a
    multi-phase solution's own, flown at the flight's default)."""
    if "accuracy" in vars(solution) or not solution.single:
        return solution.accuracy
    phase = solution.phases[0]
    if "accuracy" in vars(phase):
        return phase.accuracy
    from .accuracy import Accuracy

    return Accuracy(phase, tol)


# -- the objective's message -----------------------------------------------------------------------------------------
def _objective_message(solution: Solution, verdict: Verdict) -> str:
    a = verdict.accuracy
    assert a is not None  # the objective's part is computed with its accuracy
    label = solution.transcription
    head = f"{label}: objective error {a.objective:.1e} exceeds {verdict.tolerance:g}"
    if a.objective_failure:
        return (
            f"{head}: the solution's control cannot be flown to check its cost ({a.objective_failure}); "
            f"{REFINE}, or check the dynamics along the solution (reintegrate())"
        )
    claims = "better" if a.objective_flown > a.objective_nlp else "worse"  # (every objective is minimised)
    text = (
        f"{head}: the NLP's cost J = {a.objective_nlp:.10g}, its control flown achieves {a.objective_flown:.10g} "
        f"(the NLP claims a {claims} cost than its control gives)"
    )
    if a.objective_path > 0:
        text += f", and the path constraints' violations between points are worth {a.objective_path:.2e} in cost"
    text += f"; {REFINE}"
    hints = [h for h in (singular_arc_hint(p) for p in solution.phases) if h]
    return text + (f"; {hints[0]}" if hints else "")


# -- notes ----------------------------------------------------------------------------------------------------------------
def notes(solution: Solution) -> list[Note]:
    """The notes of a solution (module docstring), phase by phase: free times and free parameters on a bound,
    controls on a bound over the whole horizon, and, in a one-phase solution, states that no function reads."""
    out: list[Note] = []
    for p in solution.phases:
        prefix = "" if solution.single else f"phase {p.name}: "
        found = _time_notes(p) + _control_notes(p) + (_unread_state_notes(p.statement) if solution.single else [])
        out += [Note(prefix + n.subject, n.text, n.quiet) for n in found]
    for name, limit in solution.held_controls.items():
        out.append(
            Note(
                f"control {name}",
                f"the unbounded control ran away in its solve and was held in the box +/-{limit:.4g} (a multiple of "
                "its guess); the solution ends on it, so it solves the bounded problem: refine the mesh "
                "(solve(mesh_tolerance=...)), or declare the control's bounds (Control(..., lower=..., upper=...))",
            )
        )
    # each free parameter once (a shared one is every phase's), with the trajectory's declaration where it has one
    trajectory = getattr(solution.statement, "declared", {})
    seen: set[str] = set()
    for p in solution.phases:
        for v in p.statement.free_parameters:
            value = p.parameters.get(v.name, solution.parameters.get(v.name))
            if v.name in seen or value is None:
                continue
            seen.add(v.name)
            v = trajectory.get(v.name) or v
            if side := _on_bound(value, v.lower, v.upper):
                out.append(
                    Note(
                        f"parameter {v.name}",
                        f"the free parameter ends on its {side} bound ({value:.10g} in [{v.lower:g}, {v.upper:g}]): "
                        "the optimum may lie beyond it; widen the bound if it is not a physical limit",
                    )
                )
    return out


def _band(bound: float, lower: float, upper: float) -> float:
    """How close to ``bound`` counts as on it: :data:`ON_BOUND` of the bounds' range, or of the bound's size where
    that is larger (or the range infinite)."""
    span = upper - lower if math.isfinite(upper - lower) and upper > lower else abs(bound)
    return ON_BOUND * max(span, abs(bound), 1e-12)


def _on_bound(value: float, lower: float, upper: float) -> str:
    """``"lower"`` or ``"upper"`` when ``value`` is within :func:`_band` of that finite bound, else ``""``."""
    for side, bound in (("lower", lower), ("upper", upper)):
        if math.isfinite(bound) and abs(value - bound) <= _band(bound, lower, upper):
            return side
    return ""


def _time_notes(phase: PhaseSolution) -> list[Note]:
    from .statement import Duration, FreeFinalTime

    st = phase.statement
    out = []
    ends: list[tuple[str, FreeFinalTime | None, float]] = [("t0", st.initial_time, phase.t0)]
    if isinstance(st.tf, Duration):
        ends.append(("duration", st.tf, phase.tf - phase.t0))
    elif isinstance(st.tf, FreeFinalTime):
        ends.append(("tf", st.tf, phase.tf))
    words = {"t0": "initial time", "tf": "final time", "duration": "duration"}
    for name, free, value in ends:
        if free is None or not (side := _on_bound(value, free.lower, free.upper)):
            continue
        out.append(
            Note(
                name,
                f"the free {words[name]} ends on its {side} bound ({value:.10g} in [{free.lower:g}, {free.upper:g}]): "
                f"the optimum may lie beyond it; widen the bound ({type(free).__name__}(lower, upper, guess)) if it "
                "is not a physical limit",
            )
        )
    return out


def _control_notes(phase: PhaseSolution) -> list[Note]:
    """A control on one bound at all its points but perhaps one end (a scheme's end value may be left where its
    guess put it when nothing reads it: HLGL's at t_f on a problem whose cost reads no control)."""
    values, times = np.asarray(phase.control_values, dtype=float), np.asarray(phase.control_times, dtype=float)
    if values.shape[0] < 2:
        return []
    inner = ~np.isin(np.arange(times.size), [int(np.argmin(times)), int(np.argmax(times))])
    out = []
    for j, c in enumerate(phase.problem.controls):
        if not c.upper > c.lower or declared_turn(c) is not None:
            continue  # (an angle's bounds a turn apart are where it wraps, not a limit)
        for side, bound in (("lower", c.lower), ("upper", c.upper)):
            if not math.isfinite(bound):
                continue
            on = np.abs(values[:, j] - bound) <= _band(bound, c.lower, c.upper)
            if on[inner].all() and np.count_nonzero(~on) <= 1:
                out.append(
                    Note(
                        f"control {c.name}",
                        f"the control is on its {side} bound {bound:g} over the whole horizon: the bound decides the "
                        "solution; if it is not a physical limit, widen it, or state the control as a constant",
                    )
                )
    return out


def _unread_states(problem: OptimalControlProblem) -> tuple[str, ...]:
    """The states no function of ``problem`` reads (the other states' dynamics, the running and Mayer costs, the path
    and boundary constraints) and no bound constrains (none on its path, none at tf, a fixed or no initial value)."""
    key = ("unread states", tuple((s.name, s.lower, s.upper, s.initial, s.final) for s in problem.states))
    cache = problem.functions.derived
    if key not in cache:
        cache[key] = _find_unread_states(problem)
    return cast("tuple[str, ...]", cache[key])


def _find_unread_states(problem: OptimalControlProblem) -> tuple[str, ...]:
    read = readers(problem.functions)
    used = read.states_along | read.states_mayer | read.states_boundary
    out = []
    for i, s in enumerate(problem.states):
        bounded = math.isfinite(s.lower) or math.isfinite(s.upper) or s.final is not None
        if i in used or bounded or (s.initial is not None and s.fixed_initial is None):
            continue
        out.append(s.name)
    return tuple(out)


def _unread_state_notes(problem: OptimalControlProblem) -> list[Note]:
    return [
        Note(
            f"state {name}",
            "no function reads this state (the other states' dynamics, the costs, the constraints) and no bound "
            "constrains it: an output of the solution that changes nothing; drop it if it is not meant to be one",
            quiet=True,
        )
        for name in _unread_states(problem)
    ]
