"""The solved trajectory: statistics, interpolants, independent verification, export."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from .problem import OptimalControlProblem


@dataclass
class Reintegration:
    """The optimal control re-integrated with an adaptive integrator (scipy DOP853).

    ``error[k, j]`` is the integrated state minus the transcription's state
    interpolant at ``t[k]``.
    """

    t: np.ndarray
    states: np.ndarray
    error: np.ndarray
    state_names: list[str]
    scale: np.ndarray
    rtol: float
    atol: float
    n_rhs: int

    @property
    def max_error_by_state(self) -> dict[str, float]:
        """Largest absolute error of each state, in its own units."""
        return dict(zip(self.state_names, np.abs(self.error).max(axis=0).tolist()))

    @property
    def max_error(self) -> float:
        """Largest absolute error over all states, in units of each state's scale."""
        return float((np.abs(self.error) / self.scale).max())


@dataclass
class Solution:
    """A converged solution of a transcribed optimal control problem.

    Only ever constructed from a successful solve: transcriptions raise
    :class:`ocpkit.SolverError` otherwise.
    """

    problem: OptimalControlProblem
    transcription: str
    status: str
    iterations: int
    objective: float
    t0: float
    tf: float
    nlp_parameters: int
    defect_equations: int
    constraints: int
    build_s: float
    solve_s: float
    state_times: np.ndarray
    state_values: np.ndarray
    control_times: np.ndarray
    control_values: np.ndarray
    breakpoints: np.ndarray
    state_interpolant: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    control_interpolant: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    raw: dict = field(default_factory=dict, repr=False)
    costate_times: np.ndarray | None = field(default=None, repr=False)
    costate_values: np.ndarray | None = field(default=None, repr=False)

    # -- time histories -------------------------------------------------------------
    def state(self, t) -> np.ndarray:
        """States at times ``t`` (shape ``t.shape + (nx,)``), from the transcription's interpolant."""
        return self.state_interpolant(self._check_times(t))

    def control(self, t) -> np.ndarray:
        """Controls at times ``t`` (shape ``t.shape + (nu,)``): the transcription's interpolant, within the bounds.

        Between its parameters a polynomial control can overshoot a bound it
        touches (and an LGR control, extrapolated past the last collocation
        point, can leave it); the values are projected onto the control bounds,
        the only values the dynamics admit.
        """
        lo, hi = self._control_bounds
        return np.clip(self.control_interpolant(self._check_times(t)), lo, hi)

    @cached_property
    def _control_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        controls = self.problem.controls
        return np.array([c.lower for c in controls]), np.array([c.upper for c in controls])

    def _check_times(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        span = self.tf - self.t0
        if np.any(t < self.t0 - 1e-12 * span) or np.any(t > self.tf + 1e-12 * span):
            raise ValueError(f"times must lie in [t0, tf] = [{self.t0}, {self.tf}]")
        return np.clip(t, self.t0, self.tf)

    def time_grid(self, n: int = 401) -> np.ndarray:
        if n < 2:
            raise ValueError("a time grid needs at least 2 points")
        return np.linspace(self.t0, self.tf, n)

    def to_dataframe(self, t=None, n: int = 401) -> pd.DataFrame:
        """Time histories on ``t`` (default: ``n`` equally spaced points) as a DataFrame."""
        t = self.time_grid(n) if t is None else np.asarray(t, dtype=float)
        data = {"t": t}
        data.update(dict(zip(self.problem.state_names, self.state(t).T)))
        data.update(dict(zip(self.problem.control_names, self.control(t).T)))
        return pd.DataFrame(data)

    def costates_dataframe(self) -> pd.DataFrame:
        """Costate estimates at their points (transcriptions that provide them, e.g. Radau)."""
        if self.costate_values is None:
            raise ValueError(f"{self.transcription} provides no costate estimates")
        df = pd.DataFrame(self.costate_values, columns=[f"lambda_{n}" for n in self.problem.state_names])
        df.insert(0, "t", self.costate_times)
        return df

    def nodes_dataframe(self) -> pd.DataFrame:
        """NLP state parameters at their nodes."""
        df = pd.DataFrame(self.state_values, columns=self.problem.state_names)
        df.insert(0, "t", self.state_times)
        return df

    # -- verification ---------------------------------------------------------------
    def reintegrate(self, rtol: float = 1e-12, atol: float = 1e-12, n: int = 2001,
                    controls: str = "bounded") -> Reintegration:
        """Integrate dx/dt = f(x, u*(t), t) from x*(t0) with DOP853 and compare.

        ``controls="bounded"`` (default) integrates the admissible control
        :meth:`control` (the interpolant projected onto the bounds): how far the
        flown trajectory lands from the transcribed one. ``"interpolant"`` uses the
        raw polynomial, overshoots included: how consistent the discretisation is.
        Integration restarts at every breakpoint (segment boundary) so that no step
        straddles a kink of the piecewise-polynomial control. ``atol`` is scaled by
        each state's scale.
        """
        if rtol <= 0 or atol <= 0:
            raise ValueError("tolerances must be positive")
        if controls not in ("bounded", "interpolant"):
            raise ValueError(f"controls must be 'bounded' or 'interpolant', got {controls!r}")
        control = self.control if controls == "bounded" else self.control_interpolant
        problem = self.problem
        scale = problem.state_scale
        t_eval = np.union1d(self.time_grid(n), self.breakpoints)
        out = np.empty((t_eval.size, problem.nx))
        x = self.state_values[0].astype(float)
        n_rhs = 0

        bp = self.breakpoints
        for a, b in zip(bp[:-1], bp[1:]):
            # the control of this interval up to its end (piecewise controls may jump at b)
            b_left = np.nextafter(b, a)

            def rhs(t, y, b_left=b_left):
                return problem.rhs(t, y, control(np.array(min(t, b_left))))

            mask = (t_eval >= a) & (t_eval <= b)
            sol = solve_ivp(rhs, (a, b), x, method="DOP853", rtol=rtol, atol=atol * scale, dense_output=True)
            if sol.status != 0:
                raise RuntimeError(f"re-integration failed on [{a}, {b}]: {sol.message}")
            n_rhs += sol.nfev
            out[mask] = sol.sol(t_eval[mask]).T
            x = sol.y[:, -1]
        err = out - self.state(t_eval)
        return Reintegration(
            t=t_eval, states=out, error=err, state_names=problem.state_names,
            scale=scale, rtol=rtol, atol=atol, n_rhs=n_rhs,
        )

    # -- reporting ------------------------------------------------------------------
    def summary(self) -> dict:
        """Key numbers, JSON-serialisable."""
        return {
            "problem": self.problem.name,
            "transcription": self.transcription,
            "status": self.status,
            "objective": self.objective,
            "tf": self.tf,
            "nlp_parameters": self.nlp_parameters,
            "defect_equations": self.defect_equations,
            "constraints": self.constraints,
            "iterations": self.iterations,
            "build_s": self.build_s,
            "solve_s": self.solve_s,
        }
