"""Many solves of one program at the cost of the solver call: :class:`SolveLoop` (``Program.loop()``).

``solve()`` is the policy of one solve: it checks its input, chooses the start, runs IPOPT and packages a
:class:`~ocpkit.Solution` (the trajectory's polynomials, the constraint values and multipliers, the problem with
its parameters fixed), about 0.7 ms of Python around a warm 2-iteration IPOPT call of 2 ms on a 20-segment mesh.
A loop over many parameter values (a continuation, a sweep, the explorer's slider) needs less per solve: the NLP's
bounds are computed once and each call writes only the parameters' entries; IPOPT is called with the arrays as
they are; the result is the NLP's arrays, and the :class:`~ocpkit.Solution` is built only when it is asked for
(:attr:`LoopResult.solution`, then kept). Results are those of ``solve()`` from the same start, to the last bit:
the same NLP, the same bounds, IPOPT with the same options (the program's own instances, one per set of options).

Modelled on CasADi's ``nlpsol`` as a function and rockit's ``to_function``: parameters and a start in, arrays
out; unlike them, the result can become the full solution of the transcription it came from.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from .._deprecation import renamed
from ..nlp import WARM_START, NLPResult, succeeded
from ..solution import Solution
from .solve import exact_start, record_solve, settle

if TYPE_CHECKING:
    import casadi as ca

    from .program import Program


class LoopResult:
    """One solve of a :class:`SolveLoop`: the NLP's arrays, and the :class:`~ocpkit.Solution` when asked for.

    Attributes
    ----------
    w : ndarray
        The scaled NLP vector (the program's layout, :class:`~ocpkit.program.layout.Layout`).
    lam_g : ndarray
        IPOPT's multipliers of the constraints (with ``lam_w`` an exact warm start, as ``guess=``).
    lam_w : ndarray
        IPOPT's multipliers of the variable bounds (with ``lam_g`` an exact warm start, as ``guess=``).
    objective : float
        The objective, in the problem's units (the NLP's times ``objective_scale``).
    status : str
        IPOPT's return status.
    iterations : int
        IPOPT's iterations.
    solve_s : float
        Wall time of the IPOPT call (as :attr:`Solution.solve_s`).
    converged : bool
        ``Solve_Succeeded`` (or ``Solved_To_Acceptable_Level`` where the loop allows it) with a finite iterate.
    parameters : dict
        The problem's parameters as solved with, by name (linked phases that hold one name at different values, and
        were not given one: None; the :attr:`solution`'s phases have each one's).
    """

    def __init__(
        self,
        loop: SolveLoop,
        w: np.ndarray,
        lam_g: np.ndarray,
        lam_w: np.ndarray,
        objective: float,
        status: str,
        iterations: int,
        solve_s: float,
        converged: bool,
        parameters: dict[str, float | None],
        stats: dict[str, Any],
    ) -> None:
        self._loop = loop
        self.w, self.lam_g, self.lam_w = w, lam_g, lam_w
        self.objective, self.status, self.iterations = objective, status, iterations
        self.solve_s, self.converged, self.parameters = solve_s, converged, parameters
        self._stats = stats

    @property
    def t0(self) -> float:
        """The initial time (of the first phase, for linked phases)."""
        return self._loop.program.time_span(self.w)[0]

    @property
    def tf(self) -> float:
        """The final time (of the last phase, for linked phases)."""
        return self._loop.program.time_span(self.w)[1]

    @cached_property
    def solution(self) -> Solution:
        """The full :class:`~ocpkit.Solution` of this result, as ``solve()`` would have returned it (built on first
        access, then kept)."""
        return self._loop._package(self)

    def nlp_result(self) -> NLPResult:
        """The result as the NLP layer's :class:`~ocpkit.nlp.NLPResult` (scaled objective)."""
        return NLPResult(
            w=self.w,
            objective=self.objective / self._loop._objective_scale,
            lam_g=self.lam_g,
            lam_w=self.lam_w,
            status=self.status,
            iterations=self.iterations,
            solve_s=self.solve_s,
            success=self.converged,
            stats={k: v for k, v in self._stats.items() if isinstance(v, (bool, int, float, str))},
        )

    def __repr__(self) -> str:
        return (
            f"LoopResult(status={self.status!r}, iterations={self.iterations}, objective={self.objective:.10g}, "
            f"parameters={self.parameters})"
        )


class SolveLoop:
    """Solve one program (:class:`~ocpkit.program.Program`) for many parameter values and starts.

    ``loop = program.loop()`` (or ``HLGL(problem, 20).loop()``) builds the NLP and its two IPOPT instances (a cold start and :data:`~ocpkit.nlp.WARM_START`)
    once; ``loop(parameters, guess=None)`` solves (``guess`` by keyword, as ``solve``'s options):

    - ``parameters``: new values of some of the problem's parameters by name (the others keep the problem's);
    - ``guess``: None (the program's default start), a :class:`LoopResult` of this loop or a Solution of
      the same program (an exact warm start: its NLP vector and multipliers), or anything ``solve()``
      takes as a guess (interpolated onto the mesh, a cold start).

    A failed solve raises :class:`~ocpkit.SolverError` naming IPOPT's status, with the last iterate's Solution
    as ``error.result``; with ``raise_on_failure=False`` the :class:`LoopResult` says ``converged=False``.
    No error estimate is computed (``solve(error_threshold=None)``); ask the result's :attr:`~LoopResult.solution`.

    A loop solves with its program's IPOPT instances (one per set of options, shared with its ``solve``), and an
    IPOPT instance must not run in two threads at once: give each thread its own program, and its loop.
    """

    def __init__(
        self,
        program: Program,
        *,
        ipopt_options: Mapping[str, Any] | None = None,
        allow_acceptable: bool = False,
        raise_on_failure: bool = True,
    ) -> None:
        #: the program solved
        self.program = program.build()
        self.ipopt_options = dict(ipopt_options or {})
        self.allow_acceptable = bool(allow_acceptable)
        self.raise_on_failure = bool(raise_on_failure)
        self._cold = program.solver(self.ipopt_options)
        self._warm = program.solver({**WARM_START, **self.ipopt_options})
        self._lbw, self._ubw = (np.array(b, dtype=float) for b in program.bounds())
        self._lbg, self._ubg = (np.array(b, dtype=float) for b in program.constraint_bounds())
        self._slots = program.parameter_slots
        self._defaults = dict(program.parameter_defaults())
        self._objective_scale = program.objective_scale
        self._zero_w, self._zero_g = np.zeros(self._lbw.size), np.zeros(self._lbg.size)
        self._start: np.ndarray | None = None  # the default start, computed when first needed

    def __call__(self, parameters: Mapping[str, float] | None = None, *, guess: Any = None) -> LoopResult:
        given = self._parameters(parameters)
        lbw, ubw = self._lbw, self._ubw
        if given:  # only the names given: the others keep their values (each phase's own, for linked phases)
            lbw, ubw = lbw.copy(), ubw.copy()
            for name, value in given.items():
                lbw[self._slots[name]] = ubw[self._slots[name]] = value
        solver, w0, lam_w0, lam_g0 = self._start_of(guess, lbw, ubw)
        t = time.perf_counter()
        out = solver.call([w0, self._no_p, lbw, ubw, self._lbg, self._ubg, lam_w0, lam_g0])
        solve_s = time.perf_counter() - t
        stats = solver.stats()
        status = stats.get("return_status", "unknown")
        w = out[0].full().ravel()
        converged = succeeded(status, w, self.allow_acceptable)
        result = LoopResult(
            self,
            w,
            out[4].full().ravel(),
            out[3].full().ravel(),
            float(out[1]) * self._objective_scale,
            status,
            int(stats.get("iter_count", -1)),
            solve_s,
            converged,
            {**self._defaults, **given},
            stats,
        )
        if not converged and (self.raise_on_failure or not np.isfinite(w).all()):
            settle(result.nlp_result(), lambda _: result.solution, raise_on_failure=True)  # raises, as solve() does
        return result

    _no_p = np.zeros(0)

    def _parameters(self, parameters: Mapping[str, float] | None) -> dict[str, float]:
        """The values given, by name, checked (empty where none is given)."""
        return {} if parameters is None else self.program.check_parameters(parameters)

    def _start_of(
        self, guess: Any, lbw: np.ndarray, ubw: np.ndarray
    ) -> tuple[ca.Function, np.ndarray, np.ndarray, np.ndarray]:
        """The IPOPT instance, start vector and multipliers for ``guess`` (the module docstring)."""
        if isinstance(guess, LoopResult) and guess._loop.program is self.program:
            return self._warm, np.clip(guess.w, lbw, ubw), guess.lam_w, guess.lam_g
        previous = exact_start(self.program, guess)
        if previous is not None:
            return self._warm, np.clip(previous.w, lbw, ubw), previous.lam_w, previous.lam_g
        if guess is None:
            if self._start is None:
                self._start = np.asarray(self.program.initial_point(), dtype=float)
            w0 = self._start
        else:
            if isinstance(guess, LoopResult):  # another loop's: its solution, interpolated
                guess = guess.solution
            w0 = np.asarray(self.program.initial_point(guess), dtype=float)
            if not np.isfinite(w0).all():
                raise ValueError("the initial guess contains NaN or infinite values")
        return self._cold, np.clip(w0, lbw, ubw), self._zero_w, self._zero_g

    def _package(self, result: LoopResult) -> Solution:
        solution = self.program.solution(result.nlp_result())
        record_solve(solution, self.ipopt_options, self.allow_acceptable)
        return solution

    @property
    def meshed(self) -> Program:
        """Deprecated name of :attr:`program`."""
        renamed("SolveLoop.meshed", "SolveLoop.program")
        return self.program
