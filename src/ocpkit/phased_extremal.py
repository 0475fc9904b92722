"""The direct-to-indirect chain of :func:`ocpkit.indirect.to_extremal` for a multi-phase boundary value problem: a
direct solution of a :class:`~ocpkit.MultiPhaseProblem` whose phases have their own dynamics, costs and
constraints, joined by links (with jumps, at free times) and linkage constraints.

Each phase's arcs are read from its direct solution (:func:`~ocpkit.structure.control_structure`), the phases are
shot together (:class:`~ocpkit.shooting.phases.PhasedArcShooting`: each phase's flows and junctions, the
trajectory's transversality conditions at the phases' ends), and the extremal is certified phase by phase
(:func:`~ocpkit.certificate.certify`: H minimal, feasible, constant, the arcs' conditions, the direct phase's arcs,
cost and states) and as a whole (``|S|``, the objective against the direct solution's, and the second-order
verdict: by convexity, where every phase has fixed times and is convex, the trajectory's cost convex (a constant
positive semidefinite Hessian) and the equalities at the ends affine; otherwise not applicable, with the reason).

Stopped by name: free parameters (their transversality conditions are not derived), inequalities at the ends, a
free time the direct solution ends on a bound of, and a state constraint the direct solution meets at a phase's
start or end only where a state it reads is free (a mass spent down to a stage's dry mass at a link: its multiplier
would enter the costate there). Unlike the one-phase chain, it does not re-solve the direct problem from the
extremal where only the comparisons with the direct solution fail.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from .certificate import Certificate, Check, certify
from .second_order import SecondOrder, not_convex
from .statement.times import Duration, FreeFinalTime
from .structure import Structure, control_structure, inequalities

if TYPE_CHECKING:
    from .shooting.phases import PhasedArcResult, PhasedArcShooting
    from .solution import PhaseSolution, Solution
    from .statement import OptimalControlProblem
    from .statement.phases import MultiPhaseProblem


@dataclass
class PhasedChain:
    """What the chain found for a multi-phase solution (:func:`shoot_phases`), from which
    :func:`~ocpkit.indirect.to_extremal` makes the :class:`~ocpkit.indirect.Extremal`: the shooting run
    (``result``), each phase's ``structures`` read from its direct solution, ``directs`` (those direct phases) and
    ``certificates``, the whole trajectory's ``certificate``, the wall times of the stages (``timings``) and the
    ``route`` in words."""

    result: PhasedArcResult
    structures: dict[str, Structure]
    directs: dict[str, PhaseSolution]
    certificates: dict[str, Certificate]
    certificate: Certificate
    timings: dict[str, float] = field(default_factory=dict)
    route: str = ""


def shoot_phases(
    solution: Solution, *, tol: float = 1e-10, integrator_tol: float | None = None, min_share: float = 0.01
) -> PhasedChain:
    """The multi-phase chain (module docstring) from ``solution``, a direct solution of several phases with costate
    estimates (the arguments are :func:`~ocpkit.indirect.to_extremal`'s). A failed shooting raises its
    :class:`~ocpkit.SolverError`; what the chain does not take raises a ValueError naming it."""
    from .shooting.arcs import arc_sequence
    from .shooting.phases import PhasedArcShooting

    statement = solution.program.phased
    names = list(statement.names)
    free = [n for n, pr in zip(names, statement.problems) if pr.free_parameters]
    if free:
        raise ValueError(
            f"the phases {free} have free parameters: the multi-phase arc shooting does not take them (their "
            "transversality conditions are not derived); fixed at their solved values (fix_parameters), the "
            "extremal it certifies is that of those values"
        )
    phases = [solution.phase(n) for n in names]
    without = [n for n, ph in zip(names, phases) if not ph.has_costates]
    if without:
        raise ValueError(
            f"to_extremal needs every phase's costate estimates, which {without} do not have: solve with Radau or HLGL"
        )
    problem = statement.with_problems([ph.problem for ph in phases])  # at the parameter values solved with
    _inactive_time_bounds(problem, phases)
    start = time.perf_counter()
    structures = [control_structure(ph, min_share=min_share) for ph in phases]
    for name, pr, ph, st in zip(names, problem.problems, phases, structures):
        _no_bound_at_an_end_only(name, pr, ph, st)
    detect_s = time.perf_counter() - start
    start = time.perf_counter()
    flows: dict[str, Any] = {} if integrator_tol is None else {"rtol": integrator_tol, "atol": integrator_tol}
    arcs = []
    for name, st, pr, ph in zip(names, structures, problem.problems, phases):
        try:
            arcs.append(arc_sequence(st, pr, ph.t0, ph.tf))
        except ValueError as exc:
            raise ValueError(f"phase {name!r}: {exc}") from exc
    shooting = PhasedArcShooting(problem, arcs, **flows)
    result = shooting.solve(shooting.guess(phases), tol=tol)
    shoot_s = time.perf_counter() - start
    certificates: dict[str, Certificate] = {}
    checks = [Check("shooting_residual", float(result.norm), tol, "|S| at the solution")]
    for name, ph, st in zip(names, phases, structures):
        run = result.phases[name]
        certificate = certify(run.trajectory, run, ph, st, tol=tol, min_share=min_share, second=False)
        certificates[name] = certificate
        checks += [
            Check(f"{name}: {c.name}", c.value, c.tolerance, c.meaning)
            for c in certificate.checks
            if c.name != "shooting_residual"
        ]
    gap = abs(result.objective - float(solution.objective)) / (1.0 + abs(result.objective))
    checks.append(Check("objective_gap", gap, 1e-2, "indirect against direct, the whole trajectory"))
    verdict = _second_order(problem, shooting, result)
    if verdict.applicable:
        checks.append(Check("second_order", 0.0 if verdict.passed else 1.0, 0.0, str(verdict)))
    return PhasedChain(
        result=result,
        structures=dict(zip(names, structures)),
        directs=dict(zip(names, phases)),
        certificates=certificates,
        certificate=Certificate(tuple(checks), verdict),
        timings={"structure_s": detect_s, "shooting_s": shoot_s},
        route=f"multi-phase arc shooting ({len(names)} phases, {sum(len(a) for a in arcs)} arcs)",
    )


def _no_bound_at_an_end_only(name: str, problem: OptimalControlProblem, phase: PhaseSolution, found: Structure) -> None:
    """A ValueError naming a state constraint of a phase that its direct solution reaches at the phase's start or
    end only, where a state it reads is free (a bound met at a link): the structure has no arc of it, so the
    shooting would leave it out, and the extremal would violate it."""
    ham = problem.functions.hamiltonian
    P = np.asarray(problem.full_parameters, dtype=float).ravel()
    t = np.linspace(phase.t0, phase.tf, 201)
    X, U = phase.state(t), phase.control(t)
    held = {a.constraint for a in found.arcs if a.constraint is not None} | {p.constraint for p in found.touches}
    for q in inequalities(problem):
        if not q.pure or q.name in held:
            continue
        c = np.asarray(q.function.map(t.size)(X.T, U.T, t[None, :], np.repeat(P[:, None], t.size, axis=1))).ravel()
        expr = q.function(ham.x, ham.u, ham.t, ham.P)
        for k, (when, fixed) in enumerate((("start", "fixed_initial"), ("end", "fixed_final"))):
            free = [
                s.name
                for i, s in enumerate(problem.states)
                if ca.depends_on(expr, ham.x[i]) and getattr(s, fixed) is None
            ]
            value = c[0] if k == 0 else c[-1]
            if free and abs(value) <= 1e-6 * max(1.0, float(np.ptp(c))):
                raise ValueError(
                    f"phase {name!r}: the direct solution reaches {q.name!r} at the phase's {when} only (t = "
                    f"{t[0] if k == 0 else t[-1]:.10g}), where {free} are free: the structure has no arc of it, and "
                    "the shooting would leave it out; state it as the phase's boundary value (a bound met at a link)"
                )


def _inactive_time_bounds(problem: MultiPhaseProblem, phases: list[PhaseSolution]) -> None:
    """A ValueError naming a phase whose free time (or duration) the direct solution ends on a bound of: the
    shooting's condition there is H's transversality, which holds only where the bound is inactive."""
    for name, pr, ph in zip(problem.names, problem.problems, phases):
        ends = [("initial time", pr.t0, ph.t0), ("final time", pr.tf, ph.tf)]
        if isinstance(pr.tf, Duration):
            ends[1] = ("duration", pr.tf, ph.tf - ph.t0)
        for what, declared, value in ends:
            if not isinstance(declared, FreeFinalTime):  # FreeInitialTime and Duration are kinds of it
                continue
            for side, bound in (("lower", declared.lower), ("upper", declared.upper)):
                if abs(value - bound) <= 1e-7 * (1.0 + abs(bound)):
                    raise ValueError(
                        f"phase {name!r}: its {what} {value:.10g} lies on its {side} bound {bound:g}: the shooting "
                        "takes free times whose bounds are inactive (H's transversality condition holds only "
                        "there); widen the bound, or fix the time"
                    )


def _second_order(problem: MultiPhaseProblem, shooting: PhasedArcShooting, result: PhasedArcResult) -> SecondOrder:
    """The whole trajectory's second-order verdict: passed by convexity where every phase has fixed times and is
    convex (:func:`ocpkit.second_order.second_order`'s test, phase by phase), the trajectory's
    cost convex and its equalities at the ends (links, linkage constraints, its phases' boundary equalities) affine; a
    normal extremal is then a global minimum. Otherwise not applicable, with the reason (a Jacobi test across
    phases is not derived)."""
    for name, pr in zip(problem.names, problem.problems):
        if pr.free_initial_time or pr.free_final_time:
            return SecondOrder(
                "not applicable", "", f"phase {name!r} has a free time: its second variation is not derived"
            )
        reason = not_convex(pr, result.phases[name].trajectory)
        if reason is not None:
            return SecondOrder(
                "not applicable",
                "",
                f"phase {name!r} is not convex ({reason}); a Jacobi test across phases is not derived",
            )
    E = shooting.ends
    hessian = ca.hessian(shooting.trajectory_cost, E)[0]
    if ca.depends_on(hessian, E) or np.linalg.eigvalsh(np.asarray(ca.evalf(hessian))).min(initial=0.0) < -1e-12:
        return SecondOrder("not applicable", "", "the trajectory's cost is not convex in the phases' ends")
    for label, row in zip(shooting.psi_labels, ca.vertsplit(shooting.psi)):
        if ca.depends_on(ca.jacobian(row, E), E):
            return SecondOrder("not applicable", "", f"{label} is not affine in the phases' ends")
    return SecondOrder(
        "passed",
        "convexity",
        "every phase's dynamics are affine in (x, u), its costs and constraints convex, the trajectory's cost convex "
        "and the links and linkage constraints affine: a normal extremal is a global minimum",
    )


__all__ = ["PhasedChain", "shoot_phases"]
