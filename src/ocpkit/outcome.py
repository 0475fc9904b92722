"""How an indirect solve ended: :class:`Outcome`, one enumeration for every shooting engine and continuation.

A shooting run (:class:`~ocpkit.shooting.ShootingResult`, :class:`~ocpkit.shooting.MultipleShootingResult`,
:class:`~ocpkit.shooting.arcs.ArcResult`), an :class:`~ocpkit.indirect.Extremal` and a continuation path
(:class:`~ocpkit.shooting.continuation.ContinuationPath`) carry their ``status`` as an :class:`Outcome`; a
:class:`~ocpkit.SolverError` raised by them carries it as ``outcome``. Each member carries its ``remedy``: what to
try next (empty for success), as diffrax's ``RESULTS`` members carry their message. An :class:`Outcome` is a
``str`` (``enum.StrEnum``): it equals its value, ``result.status == "converged"``, and prints as it in tables.

The rule every engine applies at its end: ``CONVERGED`` if and only if the residual's norm is finite and at most the
tolerance asked for (``tol``); otherwise the reason the solver stopped decides, and a solver's own claim of
convergence above ``tol`` becomes ``STALLED``.
"""

from __future__ import annotations

import enum


class Outcome(enum.StrEnum):
    """How an indirect solve ended; ``remedy`` says what to try next (module docstring)."""

    remedy: str

    def __new__(cls, value: str, remedy: str = "") -> Outcome:
        member = str.__new__(cls, value)
        member._value_ = value
        member.remedy = remedy
        return member

    #: ``|S| <= tol`` at the returned point
    CONVERGED = "converged", ""
    #: the solver's budget of evaluations or iterations ran out
    MAX_ITERATIONS = (
        "max_iterations",
        "raise maxfev (max_iterations for arc shooting), or start nearer a solution: continue from a solved "
        "problem (ocpkit.shooting.follow) or from a direct solution's costates (ocpkit.indirect.to_extremal)",
    )
    #: the residual stopped decreasing above ``tol``
    STALLED = (
        "stalled",
        "|S| stopped decreasing above tol: the result's noise is S's measured noise floor and its detail the tol "
        "that would pass where |S| is at that noise; lower the noise by stating the problem in units of order one or "
        "tightening the integrator's rtol/atol, use switching='correction' and jacobian='variational', or multiple "
        "shooting; far from a solution (|S| well above the noise), start nearer one",
    )
    #: the Jacobian of the shooting function is singular or not finite
    SINGULAR_JACOBIAN = (
        "singular_jacobian",
        "dS/dz is singular or not finite (a switching grazed, or a wrong switching structure): perturb the start, "
        "or detect the structure again from a direct solution (ocpkit.structure.control_structure)",
    )
    #: the flow could not be integrated from the unknowns
    INTEGRATION_FAILED = (
        "integration_failed",
        "the flow from these unknowns blows up or leaves the domain (e.g. tf <= t0): start from a direct solution's "
        "costates (ocpkit.indirect.to_extremal) or use multiple shooting (ocpkit.shooting.MultipleShooting)",
    )
    #: the extremal fails a check of its certificate
    CERTIFICATE_FAILED = (
        "certificate_failed",
        "the extremal fails its certificate (certificate.describe() names the checks): refine the direct solution "
        "(mesh_tolerance), or choose method=; raise_on_failure=False returns the extremal with its certificate",
    )
    #: a continuation shortened its step to its limit
    STEP_TOO_SMALL = (
        "step_too_small",
        "the continuation shortened its step to its limit: allow more halvings, give a better predictor, or follow "
        "the path by pseudo-arclength (ocpkit.shooting.arclength) where it folds",
    )
    #: a continuation's path folded back in its parameter
    FOLD = (
        "fold",
        "the path folds back in the parameter: the values beyond the fold lie on another branch (follow it on with "
        "ocpkit.shooting.arclength without stop_at_turn)",
    )
    #: stopped by its caller
    CANCELLED = "cancelled", "a newer request replaced this one: nothing to do"
    #: the root solver stopped for a reason of its own
    SOLVER_FAILED = (
        "solver_failed",
        "the root solver stopped for a reason of its own (its words are the result's detail): try the other "
        "solver (solver='newton' or 'hybr')",
    )


__all__ = ["Outcome"]
