"""From a direct solution to a certified extremal of the maximum principle, in one call: :func:`to_extremal`.

The chain (Martinon & Gergaud's hybrid: the direct method's robustness, then the indirect one's precision):

1. the switching structure of the direct solution (:func:`ocpkit.structure.control_structure`); a state constraint
   that never decreases (a budget, ``y' = u >= 0``, ``y <= A``) and that the direct solution ends on is read as the
   terminal condition it amounts to, its boundary arcs as bang arcs (:func:`ocpkit.monotone.as_terminal`);
2. the shooting problem, derived with no line of the user's, by one of two methods (``method="auto"`` picks):

   * ``"arcs"``: multiple shooting over the detected arcs with the junction times unknowns
     (:class:`ocpkit.shooting.arcs.ArcShooting`): bang, regular (``H_u = 0``), singular (the feedback from the
     switching function's derivatives, Poisson brackets with H) and boundary arcs (mixed constraints, and state
     constraints of orders one and two, with the costate's jumps at the junctions and touch points of order two),
     boundary equalities with their multipliers, non-autonomous problems; started
     from the direct solution's states and costates at every estimated junction; the method wherever the
     structure has a singular or boundary arc, or the problem constraints or explicit time;
   * ``"switching"``: simple shooting of the slides' engine (:class:`ocpkit.shooting.Shooting`, switchings
     located and corrected inside the integration, the variational Jacobian) with the control law derived from
     ``H = H0 + psi u + w |u| + b u^2`` (:func:`ocpkit.shooting.control_law`), started from the costates at t0;
     the method for bang-bang and saturated laws, and for free parameters (as states);
3. a :class:`~ocpkit.certificate.Certificate` of the result (:func:`~ocpkit.certificate.certify`), with its second-order verdict
   (:func:`ocpkit.second_order.second_order`: a global minimum where the problem is convex, the conjugate-point
   test where every arc is regular, else not applicable with the reason).

A solution of several phases cut from one problem at fixed times (:meth:`~ocpkit.MultiPhaseProblem.split`) is shot
as that problem; any other multi-phase solution (each phase its own dynamics, costs and constraints; links with
jumps, at free times; linkage constraints) as a multi-phase boundary value problem over each phase's arcs
(:mod:`ocpkit.phased_extremal`), its extremal's :attr:`Extremal.phases` certified one by one and as a whole.

What the chain does not treat yet stops it with a named error: a solution without costate estimates (Radau and
HLGL give them), an arc or junction whose flow is not derived (named with what to do), a free t0, free parameters in
the arc method. An extremal of a wrong structure (the shooting can converge to one) fails its certificate, by name: no
extremal is returned uncertified unless ``raise_on_failure=False``. :func:`follow_extremal` continues an extremal in a
problem parameter through the birth and death of arcs.

An :class:`Extremal` has the fields of every indirect result (:class:`~ocpkit.shooting.result.IndirectResult`: ``z``,
``norm``, ``tol``, ``converged``, ``status``, ``detail``, ``iterations``, ``evaluations``, ``cpu_s``, ``objective``,
``trajectory``), read from its shooting run and its certificate.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any, cast

import casadi as ca
import numpy as np

from ._deprecation import renamed_argument
from .certificate import Certificate, Check, certify  # noqa: F401 (Check: ocpkit.indirect's name before)
from .errors import SolverError
from .hamiltonian_form import has_quadratic_term
from .monotone import as_terminal
from .outcome import Outcome
from .shooting.continuation import ContinuationPath
from .shooting.phases import phase_name
from .statement.symbols import readers
from .structure import Structure, control_structure
from .trajectory import Trajectory

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from .program import Program
    from .shooting import MultipleShooting, MultipleShootingResult, Shooting, ShootingResult
    from .shooting.arcs import ArcResult, ArcShooting, ArcTrajectory, ArcType
    from .shooting.phases import PhasedArcResult
    from .solution import PhaseSolution, Solution
    from .statement import OptimalControlProblem


@dataclass
class Extremal:
    """The result of :func:`to_extremal`: the extremal as a :class:`~ocpkit.Trajectory` (``trajectory``), the
    shooting run (``shooting``: an :class:`~ocpkit.shooting.arcs.ArcResult`, a
    :class:`~ocpkit.shooting.ShootingResult` or a :class:`~ocpkit.shooting.MultipleShootingResult`; ``route`` says
    which), the structure read from the direct solution it is compared with
    (``structure``), its ``certificate``, the wall times of the structure detection, the shooting and any re-solve
    (``timings``: ``structure_s``, ``shooting_s``, ``confirm_s``), the ``direct`` solution the certificate compares
    with and, where that is a re-solve from the extremal, the ``first_direct`` one."""

    trajectory: Trajectory
    shooting: ArcResult | ShootingResult | MultipleShootingResult | PhasedArcResult
    structure: Structure
    certificate: Certificate
    timings: dict[str, float] = field(default_factory=dict)
    #: the direct solution the certificate compares with (the one the chain started from, or, where the extremal
    #: differs from it, the same transcription re-solved from the extremal; ``first_direct`` is then the first)
    direct: Solution | PhaseSolution | None = None
    first_direct: Solution | None = None
    #: how the shooting was solved, as ``"arc shooting (K arcs)"``, ``"single shooting"`` or, where single shooting
    #: from the direct costates failed, ``"multiple shooting (K segments), then single shooting"`` or ``"multiple
    #: shooting (K segments)"`` (``shooting`` is then a :class:`~ocpkit.shooting.MultipleShootingResult`; ``_shoot``)
    route: str = ""
    #: the terminal equalities :func:`ocpkit.monotone.as_terminal` added for budgets (their multipliers' signs are
    #: certified)
    budgets: list[str] = field(default_factory=list)
    #: of a multi-phase boundary value problem (:mod:`ocpkit.phased_extremal`), each phase's extremal by name (its
    #: trajectory, run, structure and certificate; empty for one phase): :meth:`phase`
    phases: dict[str, Extremal] = field(default_factory=dict)

    def phase(self, key: str | int) -> Extremal:
        """A phase's extremal by name or index (of a multi-phase extremal)."""
        if not self.phases:
            raise KeyError("this extremal has one phase: it is its own (no phase(name))")
        return self.phases[phase_name(list(self.phases), key)]

    # -- the indirect result contract (ocpkit.shooting.result.IndirectResult), read from the run and the certificate
    @property
    def z(self) -> np.ndarray:
        """The shooting's unknowns at the extremal."""
        return self.shooting.z

    @property
    def residual(self) -> np.ndarray:
        """The shooting function at the extremal."""
        return self.shooting.residual

    @property
    def norm(self) -> float:
        """``|S|`` at the extremal (``|R|`` where multiple shooting gave it)."""
        return self.shooting.norm

    @property
    def tol(self) -> float:
        """The tolerance on ``|S|`` it was solved and certified to."""
        return self.shooting.tol

    @property
    def converged(self) -> bool:
        """Whether the shooting converged (``norm <= tol``) and the certificate passed."""
        return bool(self.shooting.converged and self.certificate.passed)

    @property
    def status(self) -> Outcome:
        """:attr:`~ocpkit.Outcome.CERTIFICATE_FAILED` where the certificate fails, else the shooting's status."""
        return self.shooting.status if self.certificate.passed else Outcome.CERTIFICATE_FAILED

    @property
    def detail(self) -> str:
        """The shooting solver's words, and the failed checks where the certificate fails."""
        if self.certificate.passed:
            return self.shooting.detail
        return f"{self.shooting.detail}; failed checks {self.certificate.failed}"

    @property
    def noise(self) -> float | None:
        """The noise floor of S measured where the shooting stalled above ``tol`` (None where it did not)."""
        return self.shooting.noise

    @property
    def remedy(self) -> str:
        """What to try next, the failed certificate's remedy, else the shooting's (with its measured noise)."""
        return self.shooting.remedy if self.certificate.passed else Outcome.CERTIFICATE_FAILED.remedy

    @property
    def iterations(self) -> int:
        """The shooting's Newton iterations (Jacobian evaluations)."""
        return self.shooting.iterations

    @property
    def evaluations(self) -> int:
        """The shooting's evaluations of its shooting function."""
        return self.shooting.evaluations

    @property
    def cpu_s(self) -> float:
        """The process time of the shooting's solve."""
        return self.shooting.cpu_s

    @property
    def objective(self) -> float:
        """The extremal's cost."""
        return self.shooting.objective

    @property
    def free_parameters(self) -> dict[str, float]:
        """The solved free parameters by name."""
        return self.shooting.free_parameters

    @property
    def jumps(self) -> list[tuple[float, str, float]]:
        """The costate's jumps ``(time, constraint, nu)``, ``p(t+) = p(t-) - nu c_x``, at the junctions and touch
        points of state constraints of order two (:attr:`ArcResult.jumps <ocpkit.shooting.arcs.ArcResult.jumps>`;
        none for the other routes)."""
        return list(getattr(self.shooting, "jumps", []))

    def plot(
        self,
        which: str | Sequence[str] | None = None,
        *,
        names: str | Sequence[str] | None = None,
        n: int = 401,
        figsize: tuple[float, float] | None = None,
        fig: Figure | None = None,
    ) -> Figure:
        """A matplotlib figure of the extremal: its ``trajectory``'s (:meth:`Trajectory.plot
        <ocpkit.trajectory.Trajectory.plot>`, the same arguments; states, controls, costates, the switching times
        and junctions dotted), each bounded control's arcs shaded in the colour of their kind with a legend, at the
        extremal's own junction times; the title names the problem, the route, the objective and ``|S|``."""
        from .plotting import trajectory_figure

        if self.phases:
            raise ValueError(
                f"plot each phase of a multi-phase extremal: phase(name).plot(); the phases are {list(self.phases)}"
            )
        tr = self.trajectory
        title = f"extremal of {tr.problem.name}, {self.route or 'shooting'}: objective {self.objective:.8g}, "
        title += f"|S| = {self.norm:.1e}"
        return trajectory_figure(tr, which, names=names, n=n, figsize=figsize, fig=fig, title=title, arcs=self._arcs())

    def _arcs(self) -> dict[str, list[tuple[str, float, float]]]:
        """Each bounded control's arcs on the extremal, ``(kind, start, end)`` in time order (a boundary arc's kind
        names its inequality, ``"boundary (v.upper)"``): the arc shooting's own arcs and junction times, or the
        :attr:`structure`'s arcs with each junction moved to the extremal's switching time nearest it (within 5%
        of the horizon)."""
        from .shooting.arcs import ArcResult, arc_sequence

        tr = self.trajectory
        if isinstance(self.shooting, ArcResult):
            times = self.shooting.times
            sequence = list(zip(self.shooting.arcs, times[:-1], times[1:]))
        else:
            exact = np.asarray(tr.breakpoints, dtype=float)
            reach = 0.05 * (tr.tf - tr.t0)

            def snap(t: float) -> float:
                nearest = float(exact[np.argmin(np.abs(exact - t))])
                return nearest if abs(nearest - t) <= reach else float(t)

            sequence = [(k, snap(a), snap(b)) for k, a, b in arc_sequence(self.structure, tr.problem, tr.t0, tr.tf)]
        bounded = {a.control for a in self.structure.arcs}
        out: dict[str, list[tuple[str, float, float]]] = {}
        for kind, a, b in sequence:
            for name, which in zip(tr.control_names, kind.kinds):
                if name not in bounded:
                    continue
                label = which if which != "boundary" else f"boundary ({kind.constraint})"
                arcs = out.setdefault(name, [])
                if arcs and arcs[-1][0] == label:
                    arcs[-1] = (label, arcs[-1][1], float(b))
                else:
                    arcs.append((label, float(a), float(b)))
        return out


METHODS = ("auto", "arcs", "switching")
#: the certificate's comparisons with the direct solution that a re-solve from the extremal may settle (the others
#: are conditions of the maximum principle, and ``structure``: an extremal of another structure fails by name)
COMPARISONS = ("objective_gap", "state_gap")


def to_extremal(
    solution: Solution,
    *,
    problem: OptimalControlProblem | None = None,
    control_set: str = "box",
    tol: float = 1e-10,
    method: str = "auto",
    switching: str = "correction",
    jacobian: str | Callable[..., tuple[np.ndarray, np.ndarray]] = "variational",
    solver: str | Callable[..., tuple[Any, ...]] = "hybr",
    raise_on_failure: bool | None = None,
    strict: bool | None = None,
    integrator_tol: float | None = None,
    min_share: float = 0.01,
) -> Extremal:
    """The extremal of the maximum principle that ``solution`` (a direct solution with costate estimates)
    approximates, solved by shooting to ``|S| <= tol`` and certified (module docstring).

    ``problem``: the statement to shoot where the direct one restates the controls so that the NLP is smooth (a
    thrust bounded in norm, ``|u| <= 1`` with the cost ``|u|``, as a magnitude and two angles): it must have the
    direct problem's states (names, order, boundary values), t0, final time (free, or the same fixed value) and
    parameter values, and no free parameters; the states' costates carry over, the controls do not.
    ``control_set``: ``"box"`` (each control within its bounds) or ``"ball"`` (``|u| <= r``, the Euclidean norm of
    all the controls, each bounded by ``[-r, r]`` with the same r; the switching method's law over the ball; the
    certificate samples the ball). With a restated problem the direct structure is reported, not compared arc by
    arc (its controls are not the extremal's).

    Where only the certificate's gaps to the direct solution fail (:data:`COMPARISONS`: a direct solve stopped in
    a worse local minimum, from which the shooting found a better extremal), the same transcription is re-solved
    from the extremal (its states, t_f and controls; a restatement's controls fitted to the extremal's dynamics and
    running cost) and the certificate compares with that solution (``Extremal.direct``; the first is
    ``Extremal.first_direct``), adding ``first_direct_objective``: the extremal may be no worse than the first
    direct answer. This is done only where the transcription, warm-started from the first solution, gives it back
    (the same NLP: not a phase cut from its links). The guarantee is then that the direct method, started from the
    extremal, stays with it, not that the first direct solution approximated it.

    A state that no dynamics reads (an output integral such as ``J' = |u|^2`` with the cost ``J(t_f)``:
    :func:`output_states`, with a nonzero weight in the cost) is named, with the fix (its integrand as the running
    cost), in any error of the law's derivation or of the shooting: its costate is a known constant that the shooting
    carries as an unknown.

    ``method``: ``"arcs"``, ``"switching"`` or ``"auto"`` (module docstring). ``raise_on_failure`` (default True): a
    certificate that fails raises a :class:`~ocpkit.SolverError` naming the failed checks (outcome
    :attr:`~ocpkit.Outcome.CERTIFICATE_FAILED`; the extremal is its ``.result``); False: the extremal is returned
    with its certificate (``converged`` False, ``status`` ``CERTIFICATE_FAILED``). A shooting that fails raises in
    either case, the run as the error's ``.result`` (there is no extremal to certify). ``strict`` is the deprecated
    name of ``raise_on_failure``. ``switching``, ``jacobian`` and ``solver`` are the ``"switching"`` method's.
    ``integrator_tol``: the flows' relative and absolute tolerance (default: 1e-12 for the arc method, ``tol``
    within [1e-13, 1e-8] for the switching method); the objective and the junction times are as accurate as the
    flows (1e-14 gives Bryson-Denham's cost within 4e-13, 1e-12 within 1.4e-11). ``min_share``: the shortest arc
    read from the direct solution, as a fraction of the horizon (:func:`ocpkit.structure.control_structure`).
    With ``problem`` and ``method="arcs"``, the arcs are read in the restatement's controls: those that give the
    direct solution's dynamics and running cost at its states (a thrust pair ``u1 - u2`` as one net thrust with the
    cost ``|F|``), and the certificate compares the extremal's arcs with that reading.

    A direct solution of several phases that are not one problem cut at fixed times is shot as a multi-phase
    boundary value problem (:func:`ocpkit.phased_extremal.shoot_phases`: the arc method, box controls, no
    ``problem=``).
    """
    raise_on_failure = renamed_argument("strict", "raise_on_failure", strict, raise_on_failure, True, "to_extremal")
    from .shooting.hamiltonian import CONTROL_SETS

    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if control_set not in CONTROL_SETS:
        raise ValueError(f"control_set must be one of {CONTROL_SETS}, got {control_set!r}")
    if control_set == "ball" and method == "arcs":
        raise ValueError("control_set='ball' has the switching method's law only; use method='switching' or 'auto'")
    if integrator_tol is not None and not 1e-15 <= integrator_tol <= 1e-3:
        raise ValueError(f"integrator_tol must lie in [1e-15, 1e-3], got {integrator_tol!r}")

    if not _one_problem(solution):
        if problem is not None or control_set != "box" or method == "switching":
            raise ValueError(
                "a multi-phase boundary value problem is shot by the arc method over each phase's own controls: "
                "problem=, control_set='ball' and method='switching' are for one phase (shoot a phase alone, "
                "phase(name))"
            )
        return _phased_extremal(solution, tol, raise_on_failure, integrator_tol, min_share)
    if not getattr(solution, "has_costates", False):
        raise ValueError(
            f"to_extremal needs the direct solution's costate estimates, which {type(solution).__name__} of "
            f"{getattr(solution, 'transcription', 'this scheme')!r} does not give: solve with Radau or HLGL"
        )
    if not 0 < min_share < 0.5:
        raise ValueError(f"min_share must lie in (0, 0.5), got {min_share!r}")
    restated = problem is not None
    statement = _restatement(solution, problem) if problem is not None else _statement(solution)
    if statement.nu == 0:
        raise ValueError(
            f"{statement.name!r} has no control: to_extremal solves the maximum principle for a control law and "
            "there is none (the direct solution, the optimum of its parameters and initial values, stands)"
        )
    start = time.perf_counter()
    # a restatement's arcs are read in its own controls, fitted to the direct solution's dynamics and running cost
    # (a thrust bounded in norm is shot by the switching method's law over the ball, its arcs only reported)
    read_in = restated and control_set == "box"
    structure = control_structure(_ReadIn(solution, statement) if read_in else solution, min_share=min_share)
    detect_s = time.perf_counter() - start
    base = statement
    budgets: list[str] = []
    if not restated:  # a state constraint only the final state can reach: its terminal condition (ocpkit.monotone)
        statement, structure, budgets = as_terminal(statement, structure, solution)
    # an output with a zero weight (the entry landing's downrange) has a zero costate, which the shooting finds
    outputs = {name: c for name, c in output_states(statement).items() if c != 0}
    try:
        return _extremal(
            solution,
            statement,
            base,
            structure,
            budgets,
            restated,
            control_set,
            tol,
            method,
            switching,
            jacobian,
            solver,
            raise_on_failure,
            detect_s,
            integrator_tol,
            min_share,
            read_in,
        )
    except ValueError as exc:
        if not outputs:
            raise
        raise ValueError(f"{exc}; and {_named_outputs(statement, outputs)}") from exc
    except SolverError as exc:
        if not outputs or exc.outcome is Outcome.CERTIFICATE_FAILED:
            raise
        raise exc.with_detail(f"{exc.detail}; {_named_outputs(statement, outputs)}") from exc


def _extremal(
    solution: Solution,
    statement: OptimalControlProblem,
    base: OptimalControlProblem,
    structure: Structure,
    budgets: list[str],
    restated: bool,
    control_set: str,
    tol: float,
    method: str,
    switching: str,
    jacobian: str | Callable[..., tuple[np.ndarray, np.ndarray]],
    solver: str | Callable[..., tuple[Any, ...]],
    raise_on_failure: bool,
    detect_s: float,
    integrator_tol: float | None = None,
    min_share: float = 0.01,
    read_in: bool = False,
) -> Extremal:
    """The chain of :func:`to_extremal` from its statement and structure on: the shooting, its certificate, the
    re-solve from the extremal where only the comparisons with the direct solution fail."""
    from .shooting import Shooting, control_law
    from .shooting.arcs import ArcShooting, arc_sequence

    problem = statement
    radius = _ball_radius(statement) if control_set == "ball" else 1.0
    if method == "auto":
        method = "switching" if control_set == "ball" else "arcs" if _needs_arcs(statement, structure) else "switching"
    start = time.perf_counter()
    shooting: ArcShooting | Shooting
    result: ArcResult | ShootingResult | MultipleShootingResult
    if method == "arcs":
        if statement.free_parameters:
            raise ValueError(
                f"{problem.name!r} has free parameters: the arc method does not take them yet; "
                "use method='switching' (free parameters as states) where the structure allows"
            )
        flows: dict[str, Any] = {} if integrator_tol is None else {"rtol": integrator_tol, "atol": integrator_tol}
        shooting = ArcShooting(statement, arc_sequence(structure, statement, solution.t0, solution.tf), **flows)
        result = shooting.solve(shooting.guess(solution), tol=tol)
        route = f"arc shooting ({len(shooting.kinds)} arcs)"
    else:
        singular = [] if restated else [a for a in structure.arcs if a.kind in ("singular", "boundary")]
        if singular:
            a = singular[0]
            what = "use method='arcs'" if control_set == "box" else "the law over the ball has none; keep the direct"
            raise ValueError(
                f"control {a.control!r} has a {a.kind} arc on [{a.start:.6g}, {a.end:.6g}]: the switching method's "
                f"laws have no such arc; {what}"
            )
        if control_set == "ball" and statement.free_parameters:
            raise ValueError(
                f"{statement.name!r} has free parameters: the law over the ball is not derived for them as states; "
                "fix them, or state the problem with a box"
            )
        try:
            law = control_law(statement, control_set, regularized=has_quadratic_term(statement), radius=radius)
        except ValueError as exc:
            raise ValueError(
                f"{statement.name!r}: no {control_set} law derives from its Hamiltonian ({exc}); to_extremal derives "
                "the laws of H = H0 + psi u + w |u| + b |u|^2 only"
            ) from exc
        # the flow as accurate as the residual asked for
        accuracy = min(1e-8, max(tol, 1e-13)) if integrator_tol is None else integrator_tol
        shooting = Shooting(statement, law, switching=switching, jacobian=jacobian, rtol=accuracy, atol=accuracy)
        result, route = _shoot(shooting, solution, solver=solver, tol=tol)
    shoot_s = time.perf_counter() - start
    trajectory = cast("Trajectory", result.trajectory)  # (a converged run has one)
    terminal = _terminal_multipliers(result, budgets)
    compared = structure if not restated or read_in else None
    certificate = certify(trajectory, result, solution, compared, tol=tol, terminal=terminal, min_share=min_share)
    timings = {"structure_s": detect_s, "shooting_s": shoot_s}
    first = None
    if certificate.failed and set(certificate.failed) <= set(COMPARISONS):
        start = time.perf_counter()
        again = _resolved_from(solution, statement, trajectory, result, restated)
        timings["confirm_s"] = time.perf_counter() - start
        if again is not None:
            first, solution = solution, again
            structure = control_structure(_ReadIn(again, statement) if read_in else again, min_share=min_share)
            if budgets:  # read as the first one was
                structure = as_terminal(base, structure, again)[1]
            compared = structure if not restated or read_in else None
            certificate = certify(
                trajectory, result, again, compared, tol=tol, first=first, terminal=terminal, min_share=min_share
            )
    extremal = Extremal(
        trajectory=trajectory,
        shooting=result,
        structure=structure,
        certificate=certificate,
        timings=timings,
        direct=solution,
        first_direct=first,
        route=route,
        budgets=budgets,
    )
    if raise_on_failure:
        _raise_unless_certified(extremal, repr(problem.name))
    return extremal


def _raise_unless_certified(extremal: Extremal, what: str) -> None:
    """The :class:`~ocpkit.SolverError` of an extremal whose certificate fails (outcome
    :attr:`~ocpkit.Outcome.CERTIFICATE_FAILED`, the extremal its ``.result``), ``what`` naming the problem."""
    certificate = extremal.certificate
    if not certificate.passed:
        raise SolverError(
            "certificate",
            f"failed checks {certificate.failed}",
            extremal.shooting.evaluations,
            f"{what}:\n{certificate.describe()}",
            unit="shooting-function evaluations",
            result=extremal,
            outcome=Outcome.CERTIFICATE_FAILED,
        )


def _phased_extremal(
    solution: Solution, tol: float, raise_on_failure: bool, integrator_tol: float | None, min_share: float
) -> Extremal:
    """The :class:`Extremal` of a multi-phase boundary value problem (:func:`ocpkit.phased_extremal.shoot_phases`):
    each phase's extremal in :attr:`Extremal.phases`, the whole trajectory's certificate; a failed certificate
    raises as :func:`to_extremal` says."""
    from .phased_extremal import shoot_phases

    chain = shoot_phases(solution, tol=tol, integrator_tol=integrator_tol, min_share=min_share)
    result = chain.result
    phases = {
        name: Extremal(
            trajectory=run.trajectory,
            shooting=run,
            structure=chain.structures[name],
            certificate=chain.certificates[name],
            direct=chain.directs[name],
            route=f"arc shooting ({len(run.arcs)} arcs) of phase {name!r}",
        )
        for name, run in result.phases.items()
    }
    structures = list(chain.structures.values())
    extremal = Extremal(
        trajectory=result.trajectory,
        shooting=result,
        structure=Structure(
            tuple(a for s in structures for a in s.arcs), tuple(p for s in structures for p in s.touches)
        ),
        certificate=chain.certificate,
        timings=chain.timings,
        direct=solution,
        route=chain.route,
        phases=phases,
    )
    if raise_on_failure:
        _raise_unless_certified(extremal, f"phases {list(phases)}")
    return extremal


@dataclass
class ExtremalPath(ContinuationPath):
    """The result of :func:`follow_extremal`, a :class:`~ocpkit.shooting.continuation.ContinuationPath` (its
    ``converged``, ``status``, ``detail``, ``iterations``; the list of ``(value, extremal)``): the parameter
    ``values`` solved, the :attr:`extremals` there (each certified; the path's ``results``), and the structure
    ``changes`` met on the way, ``(value, before, after, how)`` with ``how`` the arc that died (``"arc ... shrank
    to zero"``) or ``"re-detected from a direct solve"``."""

    changes: list[tuple[float, str, str, str]] = field(default_factory=list)

    @property
    def extremals(self) -> list[Extremal]:
        """The certified extremal at each value (the path's ``results``)."""
        return self.results


def follow_extremal(
    extremal: Extremal,
    parameter: str,
    values: Sequence[float],
    *,
    tol: float = 1e-10,
    shortest: float = 1e-5,
    raise_on_failure: bool = True,
) -> ExtremalPath:
    """Continue an extremal of the arc method (:func:`to_extremal`) in a problem parameter over ``values``, through
    changes of its structure.

    Each value is shot from the last solution (``ocpkit.shooting.follow``; a failed step is halved). An arc whose
    duration falls below ``shortest`` of the horizon has died: it is removed and the shooting problem re-formed
    from the last extremal. A step that fails, or whose extremal fails its certificate (an arc is born: H is no
    longer minimal, or an inequality is violated off its boundary arcs), is solved directly at that value (the
    direct solution's transcription, warm-started) and its structure detected again. Every extremal returned is
    certified (residual, H minimum, feasibility, H constant, Legendre-Clebsch, multiplier signs). Where a step
    cannot be solved even so, the continuation's :class:`~ocpkit.SolverError` is raised (outcome
    :attr:`~ocpkit.Outcome.STEP_TOO_SMALL`); ``raise_on_failure=False`` returns the path so far with that status."""
    from .shooting.arcs import ArcShooting, arc_sequence
    from .shooting.continuation import Schedule, follow

    if extremal.phases:
        raise ValueError(
            f"follow_extremal continues an extremal of one phase; this one has the phases {list(extremal.phases)} "
            "(a multi-phase continuation is not built: solve the direct problem at each value and call to_extremal)"
        )
    if not isinstance(getattr(extremal.shooting, "arcs", None), list):
        raise ValueError("follow_extremal continues an extremal of the arc method (to_extremal(..., method='arcs'))")
    first = cast("ArcTrajectory", extremal.shooting.trajectory)  # (the arc method's)
    if first.shooting.phase:
        raise ValueError(
            "follow_extremal continues a whole extremal: this is one phase of a multi-phase extremal, which the "
            "other phases' conditions hold; a multi-phase continuation is not built"
        )
    statement = first.shooting.problem
    if parameter not in statement.parameters:
        raise KeyError(f"unknown parameter {parameter!r}; {statement.name!r} has {sorted(statement.parameters)}")
    program = _program(extremal.direct)
    # the statement before its budgets were read as terminal conditions (ocpkit.monotone): read again at each
    # re-detection, where a budget may have stopped binding
    base = statement.replace(
        boundary_constraints=[c for c in statement.boundary_constraints if c.name not in extremal.budgets]
    )
    state: dict[str, Any] = {
        "shooting": first.shooting,
        "last": extremal,
        "direct": extremal.direct,
        "budgets": list(extremal.budgets),
    }
    changes: list[tuple[float, str, str, str]] = []

    def words(arcs: Sequence[ArcType]) -> str:
        return " | ".join(ArcShooting.arc_name(a) for a in arcs)

    def shoot(shooting: ArcShooting, z: np.ndarray, value: float) -> tuple[ArcResult, Trajectory, np.ndarray]:
        result = shooting.solve(z, {parameter: value}, tol=tol)
        tr = cast("Trajectory", result.trajectory)  # (a converged run has one)
        spans = np.diff(tr.breakpoints)
        return result, tr, spans

    def redetect(value: float, why: str) -> tuple[ArcShooting, ArcResult]:
        if program is None:
            raise SolverError("continuation", f"structure change at {value:.6g}", 0, f"{why}; no direct program")
        direct = program.solve(state["direct"], parameters={parameter: value}, error_threshold=None)
        here = base.replace(parameters={parameter: value})
        restated, structure, budgets = as_terminal(here, control_structure(direct), direct)
        shooting = ArcShooting(restated, arc_sequence(structure, restated, direct.t0, direct.tf))
        result = shooting.solve(shooting.guess(direct, {parameter: value}), {parameter: value}, tol=tol)
        changes.append((value, words(state["shooting"].kinds), words(shooting.kinds), f"re-detected ({why})"))
        state["direct"], state["budgets"] = direct, budgets
        return shooting, result

    def solve_at(value: float, z: np.ndarray) -> Extremal:
        shooting = state["shooting"]
        previous = state["last"].trajectory
        if z.size != shooting.nz:
            z = shooting.guess(previous, {parameter: value})
        try:
            result, tr, spans = shoot(shooting, z, value)
            dead = int(np.argmin(spans))
            if spans[dead] < shortest * (tr.tf - tr.t0) and len(spans) > 1:
                arcs = [(k, a, b) for k, (a, b) in zip(shooting.kinds, zip(tr.breakpoints[:-1], tr.breakpoints[1:]))]
                del arcs[dead]
                merged: list[tuple[ArcType, float, float]] = []
                for kind, a, b in arcs:
                    if merged and merged[-1][0] == kind:
                        merged[-1] = (kind, merged[-1][1], b)
                    else:
                        merged.append((kind, a, b))
                merged[0] = (merged[0][0], tr.t0, merged[0][2])
                merged[-1] = (merged[-1][0], merged[-1][1], tr.tf)
                new = ArcShooting(shooting.problem, merged)
                result, tr, spans = shoot(new, new.guess(tr, {parameter: value}), value)
                changes.append((value, words(shooting.kinds), words(new.kinds), f"arc {dead + 1} shrank to zero"))
                shooting = new
            terminal = _terminal_multipliers(result, state["budgets"])
            certificate = certify(tr, result, None, None, tol=tol, terminal=terminal)
            if not certificate.passed:
                raise SolverError(
                    "certificate",
                    f"failed checks {certificate.failed}",
                    0,
                    "",
                    result=result,
                    outcome=Outcome.CERTIFICATE_FAILED,
                )
        except (SolverError, ValueError) as exc:
            shooting, result = redetect(value, exc.status if isinstance(exc, SolverError) else str(exc))
            tr = cast("Trajectory", result.trajectory)  # (a converged run has one)
            certificate = certify(
                tr, result, None, None, tol=tol, terminal=_terminal_multipliers(result, state["budgets"])
            )
            if not certificate.passed:
                raise SolverError(
                    "certificate",
                    f"failed checks {certificate.failed}",
                    0,
                    f"at {parameter} = {value:.6g}",
                    result=result,
                    outcome=Outcome.CERTIFICATE_FAILED,
                ) from exc
        state["shooting"] = shooting
        state["last"] = Extremal(
            trajectory=tr,
            shooting=result,
            structure=control_structure(tr),
            certificate=certificate,
            direct=state["direct"],
            budgets=list(state["budgets"]),
        )
        return state["last"]

    start = float(statement.parameters[parameter])
    path = follow(solve_at, extremal.z, start, Schedule(values), raise_on_failure=raise_on_failure, parameter=parameter)
    return ExtremalPath(**{f.name: getattr(path, f.name) for f in fields(path)}, changes=changes)


def _terminal_multipliers(result: Any, budgets: Sequence[str]) -> dict[str, float]:
    """The multipliers of the budgets' terminal equalities, by name: the last of the arc shooting's."""
    if not budgets:
        return {}
    return dict(zip(budgets, np.ravel(getattr(result, "multipliers", []))[-len(budgets) :]))


def output_states(problem: OptimalControlProblem) -> dict[str, float]:
    """The states no dynamics reads (output integrals, ``J' = |u|^2`` with the cost ``J(t_f)``), by name, each with
    its Mayer weight ``c = dphi/dJ(t_f)``: states that no right-hand side, running cost, path constraint or boundary
    constraint depends on, with a fixed initial and a free final value, and that the Mayer term reads linearly (a
    constant ``c``, 0 where it does not read them). Their costate is the constant ``c`` (``p' = -dH/dJ = 0``,
    ``p(t_f) = c``), which the shooting does not know: it is an unknown whose estimate enters the control law (as
    the quadratic coefficient of ``H`` for an energy integral). Stated as the running cost ``c J'`` instead, the
    state is gone and the law's coefficient is the number ``c``."""
    read = readers(problem.functions)
    X0, XF, T0, TF = ca.SX.sym("x0", problem.nx), ca.SX.sym("xf", problem.nx), ca.SX.sym("t0"), ca.SX.sym("tf")
    P = ca.SX.sym("P", problem.functions.f.size1_in(3))
    phi = problem.phi(X0, XF, T0, TF, P) if problem.phi is not None else ca.SX(0)
    out = {}
    for i, state in enumerate(problem.states):
        if state.fixed_initial is None or state.final is not None:
            continue
        if math.isfinite(state.lower) or math.isfinite(state.upper):
            continue  # a bounded state constrains the solution (a budget): not an output
        if i in read.states_along or i in read.states_own or i in read.states_boundary:
            continue
        weight = ca.gradient(phi, XF[i])
        if not weight.is_constant() or ca.depends_on(phi, X0[i]):
            continue  # not linear in J(tf): its costate is not known before the shooting
        out[state.name] = float(ca.evalf(weight))
    return out


def _named_outputs(problem: OptimalControlProblem, outputs: Mapping[str, float]) -> str:
    """The sentence that names the output states of ``problem`` (:func:`output_states`) and the fix."""
    ham = problem.functions.hamiltonian
    rates = "; ".join(f"{n}' = {ham.f[problem.state_names.index(n)]}, Mayer weight {c:g}" for n, c in outputs.items())
    names = ", ".join(repr(n) for n in outputs)
    costs = " + ".join(f"{c:g} * ({n}'s right-hand side)" for n, c in outputs.items())
    return (
        f"no dynamics, running cost or constraint of {problem.name!r} reads the state {names} (an output integral: "
        f"{rates}): its costate is that constant weight, which the shooting carries as an unknown and its control "
        f"law cannot use; state the cost as the running cost, lagrange = {costs}, drop {names}, and solve the "
        "direct problem again"
    )


def _needs_arcs(problem: OptimalControlProblem, structure: Structure) -> bool:
    """Whether only the arc method fits: a singular or boundary arc, constraints, or explicit time."""
    if any(a.kind in ("singular", "boundary") for a in structure.arcs):
        return True
    if problem.path_constraints or problem.boundary_constraints:
        return True
    ham = problem.functions.hamiltonian
    return bool(ca.depends_on(ca.vertcat(ham.f, ham.L), ham.t))


def _program(solution: Any) -> Program | None:
    """The program a direct solution came from (None for another trajectory, or for a phase of a solution: its
    links are gone)."""
    from .solution import Solution

    return solution.program if isinstance(solution, Solution) else None


def _statement(solution: Solution) -> OptimalControlProblem:
    """The problem as stated by the user (with its free parameters free again), with the parameter values the
    solution was solved with (``solve(parameters=...)``), from a direct solution: a program's one phase, or the
    problem its phases were cut from (:meth:`~ocpkit.program.Program.split`)."""
    program = _program(solution)
    if program is None:
        return solution.problem
    statement = program.problem if program.plain else cast("OptimalControlProblem", program.phased.source)
    solved = solution.problem.parameters
    values = {n: solved[n] for n in statement.parameters if n in solved}
    return statement.replace(parameters=values) if values != dict(statement.parameters) else statement


def _one_problem(solution: Any) -> bool:
    """Whether ``solution`` is shot as one problem: a single phase's, or phases cut from one problem at fixed times
    (:meth:`~ocpkit.MultiPhaseProblem.split`, every state continuous across the cuts). Any other solution of
    several phases is a multi-phase boundary value problem (:mod:`ocpkit.phased_extremal`)."""
    from .solution import Solution

    if not isinstance(solution, Solution) or solution.single:
        return True  # a single-phase problem's (or another trajectory)
    phased = solution.program.phased
    if phased.source is None:
        return False
    return all(
        len(linked.states) == phased.problems[linked.before].nx
        and linked.time == "consistent"
        and all(jump == 0.0 for *_, jump in linked.states)
        for linked in phased.links
    )


def _ball_radius(problem: OptimalControlProblem) -> float:
    """The radius r of a ball control set: every control bounded by ``[-r, r]``, the same r."""
    radii = {float(c.upper) for c in problem.controls}
    for c in problem.controls:
        if not (np.isfinite(c.upper) and c.upper > 0 and c.lower == -c.upper):
            raise ValueError(
                f"control_set='ball' needs every control bounded by [-r, r] with one r (the ball |u| <= r inside its "
                f"box); {c.name!r} of {problem.name!r} has [{c.lower}, {c.upper}]"
            )
    if len(radii) != 1:
        raise ValueError(
            f"control_set='ball' needs one radius: the controls of {problem.name!r} are bounded by {sorted(radii)}"
        )
    return radii.pop()


def _resolved_from(
    solution: Solution,
    statement: OptimalControlProblem,
    trajectory: Trajectory,
    result: Any,
    restated: bool,
    samples: int = 2001,
) -> Solution | None:
    """The direct solution's transcription re-solved from the extremal: its states and t_f, its controls (for a
    restated problem, the direct problem's controls fitted to them: :func:`_fitted_controls`) and its free
    parameters, at the parameter values of ``statement``, with the first solve's IPOPT options. None where the
    solution has no transcription, where that transcription warm-started from the solution does not give it back
    (not the NLP it solved: a phase cut from its links), or where a solve fails."""
    from .statement import Guess

    program = _program(solution)
    if program is None:
        return None
    values = {n: statement.parameters[n] for n in program.parameter_slots if n in statement.parameters}
    J = float(solution.objective)
    options = solution.solve_options.as_kwargs() if solution.solve_options is not None else {}  # the first solve's
    try:
        # the same NLP gives its solution back, to IPOPT's drift from a loosely converged point (seen: 7e-5 of J on
        # the 5 N transfer); other parameters do not (seen: J = 3 against 0)
        same = program.solve(solution, parameters=values, error_threshold=None, **options)
        if abs(float(same.objective) - J) > 1e-3 * (1.0 + abs(J)):
            return None
        t = trajectory.t0 + np.linspace(0.0, 1.0, samples) * (trajectory.tf - trajectory.t0)
        problem = _statement(solution)
        X = trajectory.state(t)[:, : problem.nx]  # the shooting's may have more (free parameters as states)
        V = _fitted_controls(solution, trajectory, t, X) if restated else trajectory.control(t)

        def along(values: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
            return lambda time: np.interp(time, t, values)

        guess = Guess(
            tf=trajectory.tf,
            states={n: along(X[:, j]) for j, n in enumerate(problem.state_names)},
            controls={n: along(V[:, i]) for i, n in enumerate(problem.control_names)},
            parameters=dict(getattr(result, "free_parameters", None) or {}),
        )
        return program.solve(guess, parameters=values, error_threshold=None, **options)
    except (SolverError, ValueError, KeyError, TypeError, RuntimeError):
        return None


def _fitted_controls(solution: Solution, trajectory: Trajectory, t: np.ndarray, X: np.ndarray) -> np.ndarray:
    """The direct problem's controls (rows: the times ``t``) that give the extremal's dynamics and running cost at
    its states ``X`` (:func:`_fit`), from the first direct solution's controls at the same fraction of the
    horizon."""
    from .statement import wrap_periodic

    s = (t - trajectory.t0) / (trajectory.tf - trajectory.t0)
    # a periodic control's continuous angle moved into its bounds by whole turns, where clipping would change it
    start = wrap_periodic(solution.control(solution.t0 + s * (solution.tf - solution.t0)), solution.problem.controls)
    return _fit(solution.problem, trajectory.problem, t, X, trajectory.control(t), start)


def _fit(
    target: OptimalControlProblem,
    source: OptimalControlProblem,
    t: np.ndarray,
    X: np.ndarray,
    U: np.ndarray,
    start: np.ndarray,
) -> np.ndarray:
    """``target``'s controls (rows: the times ``t``) that give ``source``'s dynamics and running cost with its
    controls ``U`` at the states ``X`` (the two problems have the same states):
    ``min sum |(f_t(x, v) - f_s(x, u)) / scale|^2 + (L_t(x, v) - L_s(x, u))^2`` within ``target``'s control bounds,
    one small least-squares problem per time (block-separable), from ``start``."""
    ht, hs = target.functions.hamiltonian, source.functions.hamiltonian
    n = t.size
    fs = ca.Function("fs", [hs.x, hs.u, hs.t, hs.P], [ca.vertcat(hs.f, hs.L)]).map(n)
    P = np.repeat(np.asarray(source.full_parameters, dtype=float).reshape(-1, 1), n, axis=1)
    goal = np.asarray(fs(X.T, U.T, t[None, :], P))
    scale = ca.DM([abs(v.scale) for v in target.states] + [1.0])
    y = ca.SX.sym("y", target.nx + 1)
    misfit = ca.sumsqr((ca.vertcat(ht.f, ht.L) - y) / scale)
    term = ca.Function(
        "misfit", [ht.u, ht.x, ht.t, y], [ca.substitute(misfit, ht.P, ca.DM(target.full_parameters))]
    ).map(n)
    V = ca.MX.sym("V", target.nu, n)
    fit = ca.nlpsol(
        "fit",
        "ipopt",
        {"x": ca.vec(V), "f": ca.sum2(term(V, X.T, t[None, :], goal))},
        {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "ipopt.tol": 1e-12},
    )
    lo = np.repeat([[c.lower] for c in target.controls], n, axis=1)
    hi = np.repeat([[c.upper] for c in target.controls], n, axis=1)
    out = fit(
        x0=np.clip(np.asarray(start).T, lo, hi).ravel(order="F"), lbx=lo.ravel(order="F"), ubx=hi.ravel(order="F")
    )
    return np.asarray(out["x"]).reshape(target.nu, n, order="F").T


class _ReadIn(Trajectory):
    """The direct solution's states and costates with its controls read in a restated problem's (:func:`_fit`, on
    ``samples`` times, linear between them): the direct solution as the restatement's arc method reads its
    structure. Its controls are a transcription's, one polynomial per mesh interval (``polynomial``: a switch that
    the polynomial smears is not an arc, :func:`ocpkit.structure.control_structure`)."""

    polynomial = True

    def __init__(self, solution: Solution, problem: OptimalControlProblem, samples: int = 4001) -> None:
        self.problem = problem
        self.solution = solution
        self.t0, self.tf = float(solution.t0), float(solution.tf)
        self.objective = float(solution.objective)
        self.breakpoints = np.asarray(solution.breakpoints, dtype=float)
        self._t = np.linspace(self.t0, self.tf, samples)
        U, X = solution.control(self._t), solution.state(self._t)
        self._V = _fit(problem, solution.problem, self._t, X, U, np.zeros((samples, problem.nu)))
        # the restatement's controls must give the direct dynamics (but on 5% of the samples at most): else it is not
        # the same problem
        ours, theirs = (problem.functions.hamiltonian, solution.problem.functions.hamiltonian)
        f = [
            ca.Function("f", [h.x, h.u, h.t, h.P], [h.f]).map(samples)(
                X.T,
                V.T,
                self._t[None, :],
                np.repeat(np.asarray(q.full_parameters, dtype=float).reshape(-1, 1), samples, 1),
            )
            for h, V, q in ((ours, self._V, problem), (theirs, U, solution.problem))
        ]
        gap = np.abs(np.asarray(f[0]) - np.asarray(f[1])) / (1.0 + np.abs(np.asarray(f[1])).max(axis=1, keepdims=True))
        # where a switch is smeared (both thrusters of a pair on), the fit trades dynamics for cost: a few samples
        missed = np.any(gap > 1e-3, axis=0)
        if missed.mean() > 0.05:
            i, k = np.unravel_index(int(np.argmax(gap)), gap.shape)
            raise ValueError(
                f"{problem.name!r} does not give the direct solution's dynamics: no controls of it reproduce "
                f"{problem.state_names[i]!r}' at t = {self._t[k]:.6g} (relative misfit {gap[i, k]:.2e}); a "
                "restatement changes the controls, not the dynamics"
            )

    def _state(self, t: np.ndarray) -> np.ndarray:
        return self.solution.state(t)

    def _costate(self, t: np.ndarray) -> np.ndarray:
        return self.solution.costate(t)

    @property
    def has_costates(self) -> bool:
        return True

    def _control(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return np.stack([np.interp(t, self._t, self._V[:, i]) for i in range(self.problem.nu)], axis=-1)


def _restatement(solution: Solution, problem: OptimalControlProblem) -> OptimalControlProblem:
    """``problem`` checked against the direct solution's, each difference named: the same states (names, order,
    initial and final values), a fixed t0 and the same one, the same free or fixed final time (fixed: the same
    value), the same values of the parameters both name, and no free parameters; so that the direct costates are
    the restatement's."""
    direct = _statement(solution)
    if list(problem.state_names) != list(direct.state_names):
        raise ValueError(
            f"problem {problem.name!r} has the states {list(problem.state_names)}, the direct solution's "
            f"{direct.name!r} has {list(direct.state_names)}: a restatement keeps the states (only the controls change)"
        )
    for ours, theirs in zip(problem.states, direct.states):
        for end in ("initial", "final"):
            a, b = getattr(ours, end), getattr(theirs, end)
            same = a is b if a is None or b is None else np.shape(a) == np.shape(b) and np.allclose(a, b, 1e-12, 0.0)
            if not same:
                raise ValueError(
                    f"state {ours.name!r}: the {end} value is {a} in {problem.name!r} and {b} in the direct "
                    f"solution's {direct.name!r}: a restatement keeps the boundary conditions"
                )
    if problem.free_final_time != direct.free_final_time:
        raise ValueError(
            f"the final time is {'free' if problem.free_final_time else 'fixed'} in {problem.name!r} and "
            f"{'free' if direct.free_final_time else 'fixed'} in the direct solution's {direct.name!r}"
        )
    if problem.free_initial_time or direct.free_initial_time or not np.isclose(problem.t0, direct.t0, 1e-12, 0.0):
        raise ValueError(f"a restatement keeps a fixed t0: {problem.name!r} and {direct.name!r} differ")
    tf, direct_tf = cast(float, problem.tf), cast(float, direct.tf)  # (compared where fixed)
    if not problem.free_final_time and not np.isclose(float(tf), float(direct_tf), 1e-12, 0.0):
        raise ValueError(f"the final time is {problem.tf} in {problem.name!r} and {direct.tf} in {direct.name!r}")
    if problem.free_parameters or direct.free_parameters:
        raise ValueError(
            f"a restatement with free parameters ({problem.name!r}, {direct.name!r}) is not taken: the direct "
            "controls could not be fitted to the extremal's; fix the parameters"
        )
    solved = solution.problem.parameters
    for name, value in problem.parameters.items():
        if name in solved and not np.isclose(float(value), float(solved[name]), 1e-12, 0.0):
            raise ValueError(
                f"parameter {name!r} is {value} in {problem.name!r} and {solved[name]} in the direct solution"
            )
    return problem


#: the segment counts :func:`_shoot` tries, in turn, when single shooting from the direct costates fails
SEGMENTS = (10, 20, 40, 80)


def _shoot(
    shooting: Shooting, solution: Solution, *, solver: str | Callable[..., tuple[Any, ...]], tol: float
) -> tuple[ShootingResult | MultipleShootingResult, str]:
    """``(result, route)``: the switching method's shooting solved from the direct solution.

    Single shooting from the direct costates at t0 first. Where it fails (the flow from the estimated costates
    blows up before tf, or Newton stalls: an unstable Hamiltonian flow amplifies the estimates' error over the
    horizon), multiple shooting (:class:`~ocpkit.shooting.multiple.MultipleShooting`, Bulirsch's remedy, with its
    damped Newton) started from the direct solution's states and costates at every node, with :data:`SEGMENTS`
    segments in turn until one converges: each segment's flow lives only as long as its share of the horizon. Its
    solution's ``z`` then starts single shooting once more, which gives the extremal as one integration where the
    whole horizon can still be integrated from it; where it cannot (the flow is too unstable for one integration
    to hold its residual), the multiple-shooting result is the extremal (its trajectory joins the segments'
    flows). Where every route fails, the single shooting's error is raised, with what the multiple shooting met."""
    from .shooting.multiple import MAX_UNKNOWNS, MultipleShooting

    z0 = _unknowns(shooting, solution)
    try:
        return shooting.solve(z0, solver=solver, tol=tol), "single shooting"
    except SolverError as exc:
        failure, tried = exc, []
    per_node = 2 * shooting.problem.nx + 1
    for segments in SEGMENTS:
        if shooting.nz + (segments - 1) * per_node > MAX_UNKNOWNS:
            tried.append(f"{segments} segments: more than {MAX_UNKNOWNS} unknowns")
            break
        multiple = MultipleShooting(shooting, segments)
        try:
            found = multiple.solve(_nodes(multiple, solution, z0), solver="newton", tol=tol)
        except SolverError as exc:
            tried.append(f"{segments} segments: {exc.status}")
            continue
        try:
            return shooting.solve(
                found.z, solver=solver, tol=tol
            ), f"multiple shooting ({segments} segments), then single shooting"
        except SolverError:
            return found, f"multiple shooting ({segments} segments)"
    raise failure.with_detail(
        f"{failure.detail}; multiple shooting from the direct solution's nodes failed too ({'; '.join(tried)})"
    ) from failure


def _nodes(multiple: MultipleShooting, solution: Solution, z0: np.ndarray) -> np.ndarray:
    """Multiple shooting's unknowns from the direct solution: the single shooting's ``z0``, then at each interior
    node ``y = (x, p, J)``, the direct solution's states and costates there (a free parameter, a state of the
    shooting's problem: its solved value, and costate 0 as a start: it enters no flow, so its continuity is linear
    and Newton settles it) and J = 0 (likewise)."""
    shooting = multiple.shooting
    times = multiple.node_times(shooting.split_unknowns(z0)[1])
    s = (times[1:-1] - times[0]) / (times[-1] - times[0])  # the interior nodes' fractions of the horizon
    t = solution.t0 + s * (solution.tf - solution.t0)
    nx, n = solution.problem.nx, shooting.problem.nx
    X, L = np.zeros((t.size, n)), np.zeros((t.size, n))
    X[:, :nx], L[:, :nx] = solution.state(t), solution.costate(t)
    for j, name in enumerate(shooting.problem.state_names[nx:], start=nx):
        X[:, j] = solution.parameters[name]
    return np.concatenate([z0, np.hstack([X, L, np.zeros((t.size, 1))]).ravel()])


def _unknowns(shooting: Shooting, solution: Solution) -> np.ndarray:
    """The shooting's unknowns from the direct solution: per state of the shooting's problem its initial costate,
    or its initial value where free (a free parameter's, its solved value); then tf where free."""
    t0 = solution.t0
    lam = np.asarray(solution.costate(np.array([t0])), dtype=float).ravel()
    x0 = np.asarray(solution.state(np.array([t0])), dtype=float).ravel()
    nx = solution.problem.nx
    values = []
    for j, name in enumerate(shooting.problem.state_names):
        if j < nx:
            values.append(x0[j] if shooting.free_initial[j] else lam[j])
        else:  # a free parameter, a state of the shooting's problem
            values.append(solution.parameters[name])
    if shooting.free_tf:
        values.append(solution.tf)
    return np.array(values, dtype=float)


__all__ = [
    "METHODS",
    "Extremal",
    "ExtremalPath",
    "follow_extremal",
    "output_states",
    "to_extremal",
]
