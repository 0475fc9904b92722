"""The result of a direct transcription: a :class:`~ocpkit.trajectory.Trajectory` with the NLP's statistics."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ._deprecation import renamed
from .statement import OptimalControlProblem
from .trajectory import Reintegration, Trajectory

if TYPE_CHECKING:
    import pandas as pd
    from numpy.typing import ArrayLike

    from .accuracy import Accuracy

__all__ = ["Reintegration", "Solution"]


@dataclass
class Solution(Trajectory):
    """A solution of a transcribed optimal control problem.

    Every field is documented by name: ``status`` (IPOPT's), ``converged`` (whether the
    solve succeeded: transcriptions raise on failure unless asked to return the last
    iterate, see :meth:`~ocpkit.transcription.Transcription.solve`), ``iterations``,
    ``objective`` (in the problem's units), ``decision_variables`` (the NLP's free variables, Desai & Conway's
    "NLP parameters"; ``nlp_parameters`` is its deprecated name), ``defect_equations``,
    ``constraints``, ``build_s`` and ``solve_s`` (wall times), the NLP values at their
    times (``state_*``, ``control_*``), the transcription's interpolants, segment
    ``breakpoints``, ``raw`` (the NLP vector, multipliers and IPOPT statistics) and,
    for schemes that estimate them, ``costate_times`` and ``costate_values``.

    With path constraints: ``path_times`` (the points where the scheme enforces them,
    increasing), ``path_values`` (points, expressions) and ``path_multipliers`` (their
    KKT multipliers in the problem's units: positive where the upper bound is active,
    negative where the lower one is, zero where inactive; a discrete measure, whose sum
    over an interval estimates the integral of the continuous multiplier). With boundary
    constraints: ``boundary_values`` and ``boundary_multipliers``. Columns and entries
    follow ``problem.functions.path.labels`` and ``.boundary.labels``; :meth:`constraint`
    and :meth:`path_dataframe` select by name.
    """

    problem: OptimalControlProblem
    transcription: str
    status: str
    iterations: int
    objective: float
    t0: float
    tf: float
    #: the NLP's free variables (Desai & Conway's "NLP parameters"; ``nlp_parameters`` is its deprecated name)
    decision_variables: int
    defect_equations: int
    constraints: int
    build_s: float
    #: the wall time of the IPOPT solve, in seconds
    solve_s: float
    state_times: np.ndarray
    state_values: np.ndarray
    control_times: np.ndarray
    control_values: np.ndarray
    breakpoints: np.ndarray
    state_interpolant: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    control_interpolant: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    raw: dict[str, Any] = field(default_factory=dict, repr=False)
    costate_times: np.ndarray | None = field(default=None, repr=False)
    costate_values: np.ndarray | None = field(default=None, repr=False)
    converged: bool = True
    path_times: np.ndarray | None = field(default=None, repr=False)
    path_values: np.ndarray | None = field(default=None, repr=False)
    #: the KKT multipliers of the path constraints at ``path_times`` (points, expressions), in the problem's units
    #: (positive where the upper bound is active, negative where the lower one is, zero where inactive; a discrete
    #: measure, whose sum over an interval estimates the integral of the continuous multiplier)
    path_multipliers: np.ndarray | None = field(default=None, repr=False)
    boundary_values: np.ndarray | None = field(default=None, repr=False)
    boundary_multipliers: np.ndarray | None = field(default=None, repr=False)
    estimate_breakpoints: np.ndarray | None = field(default=None, repr=False)
    estimate_points: np.ndarray | int | None = field(default=None, repr=False)
    mesh_history: list[Any] | None = field(default=None, repr=False)
    #: the solved free parameters (:class:`~ocpkit.FreeParameter`) by name; the problem's constants, and these
    #: fixed at their solved values, are ``problem.parameters``
    parameters: dict[str, float] = field(default_factory=dict)
    #: how a refinement (``solve(mesh_tolerance=...)``) ended, ``"met"`` (every part of the estimate within the
    #: tolerance), ``"stalled"``, ``"stopped"`` (the next mesh would have been this one), ``"not met"`` (out of
    #: meshes) or ``"failed"`` (the last mesh's solve did not succeed, with ``raise_on_failure=False``); None for a
    #: single solve. ``refinement_reason``: the warning's text that said so ("" where met).
    refinement_outcome: str | None = field(default=None, repr=False)
    refinement_reason: str = field(default="", repr=False)

    @property
    def nlp_parameters(self) -> int:
        """Deprecated name of :attr:`decision_variables`."""
        renamed("Solution.nlp_parameters", "Solution.decision_variables")
        return self.decision_variables

    # -- accuracy ---------------------------------------------------------------------
    @cached_property
    def interval_errors(self) -> np.ndarray:
        """Relative state error estimate on each mesh interval (:mod:`ocpkit.accuracy`, Patterson-Hager-Rao)."""
        from .accuracy import interval_errors

        return interval_errors(self, self.estimate_points, self.estimate_intervals)

    @property
    def estimate_intervals(self) -> np.ndarray:
        """The intervals of :attr:`interval_errors` (the scheme's segments, or its fine segments)."""
        return self.breakpoints if self.estimate_breakpoints is None else self.estimate_breakpoints

    @property
    def error_estimate(self) -> float:
        """The largest of :attr:`interval_errors`, the solution's estimated relative state error (the other parts
        of its error, the objective's and the path constraints', are in :attr:`accuracy`)."""
        return float(self.interval_errors.max())

    @cached_property
    def accuracy(self) -> Accuracy:
        """Every part of the solution's estimated error (:class:`ocpkit.accuracy.Accuracy`), the state's, the
        objective's (the cost its admissible control achieves against the NLP's) and each path constraint's
        largest violation between the scheme's points."""
        from .accuracy import Accuracy

        return Accuracy(self)

    # -- the trajectory -------------------------------------------------------------
    def _state(self, t: np.ndarray) -> np.ndarray:
        return self.state_interpolant(t)

    def _control(self, t: np.ndarray) -> np.ndarray:
        """The transcription's control interpolant, projected onto the control bounds.

        Between its parameters a polynomial control can overshoot a bound it
        touches (and an LGR control, extrapolated past the last collocation point,
        can leave it); the projection gives the only values the dynamics admit.
        """
        return self.admissible(self.control_interpolant(t))

    def admissible(self, values: ArrayLike) -> np.ndarray:
        """Control values (last axis: the controls) as the dynamics admit them: a periodic control
        (:attr:`~ocpkit.Control.period`) wrapped into ``[lower, lower + period)`` when its bounds are finite and
        at least a period apart, then every control clipped to its bounds."""
        lo, hi = self._control_bounds
        values = np.array(values, dtype=float, copy=True)
        for j, c in enumerate(self.problem.controls):
            if c.period is not None and np.isfinite(lo[j]) and hi[j] - lo[j] >= c.period:
                values[..., j] = lo[j] + np.mod(values[..., j] - lo[j], c.period)
        return np.clip(values, lo, hi)

    @property
    def control_breakpoints(self) -> np.ndarray:
        """Where the control interpolant's pieces meet (the mesh's breakpoints, or a finer control mesh's)."""
        raw = self.control_interpolant
        for breaks in (getattr(raw, "breaks", None), getattr(getattr(raw, "poly", None), "x", None)):
            if breaks is not None:
                return np.asarray(breaks, dtype=float)
        return np.asarray(self.breakpoints, dtype=float)

    def _raw_control(self, t: ArrayLike) -> np.ndarray:
        return self.control_interpolant(self._check_times(t))

    def initial_state(self) -> np.ndarray:
        return self.state_values[0].astype(float)

    @property
    def has_costates(self) -> bool:
        return self.costate_values is not None

    def _costate(self, t: ArrayLike) -> np.ndarray:
        """Costate estimates, linear between their points (transcriptions that provide them, e.g. Radau)."""
        if self.costate_values is None:
            raise ValueError(f"{self.transcription} provides no costate estimates")
        t = np.asarray(t, dtype=float)
        times = cast(np.ndarray, self.costate_times)  # given with the values
        cols = [np.interp(t.ravel(), times, self.costate_values[:, j]) for j in range(self.costate_values.shape[1])]
        return np.stack(cols, axis=-1).reshape(t.shape + (len(cols),))

    @cached_property
    def _control_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        controls = self.problem.controls
        return np.array([c.lower for c in controls]), np.array([c.upper for c in controls])

    # -- tables ---------------------------------------------------------------------
    def costates_dataframe(self) -> pd.DataFrame:
        """Costate estimates at their points (transcriptions that provide them, e.g. Radau)."""
        import pandas as pd

        if self.costate_values is None:
            raise ValueError(f"{self.transcription} provides no costate estimates")
        df = pd.DataFrame(self.costate_values, columns=[f"lambda_{n}" for n in self.problem.state_names])
        df.insert(0, "t", self.costate_times)
        return df

    def constraint(self, name: str) -> dict[str, Any]:
        """One constraint by name: ``{"values", "multipliers", "lower", "upper"}`` (and the times ``"t"`` of a
        path constraint), one column per expression of the constraint."""
        functions = self.problem.functions
        for kind in ("path", "boundary"):
            cs = getattr(functions, kind)
            if cs is None or name not in cs.names:
                continue
            i = cs.names.index(name)
            start = int(sum(cs.sizes[:i]))
            cols = slice(start, start + cs.sizes[i])
            out = {"lower": cs.lower[cols], "upper": cs.upper[cols]}
            # a solution of a problem with constraints of this kind has their values and multipliers
            if kind == "path":
                values, multipliers = cast(np.ndarray, self.path_values), cast(np.ndarray, self.path_multipliers)
                out.update(t=self.path_times, values=values[:, cols], multipliers=multipliers[:, cols])
            else:
                values, multipliers = (
                    cast(np.ndarray, self.boundary_values),
                    cast(np.ndarray, self.boundary_multipliers),
                )
                out.update(values=values[cols], multipliers=multipliers[cols])
            return out
        known = [n for kind in ("path", "boundary") if getattr(functions, kind) for n in getattr(functions, kind).names]
        raise KeyError(f"no constraint {name!r}; the problem's constraints are {known}")

    def path_dataframe(self) -> pd.DataFrame:
        """Path constraints at their points: ``t``, each expression's value and its multiplier (``mu_<label>``)."""
        import pandas as pd

        cs = self.problem.functions.path
        if cs is None:
            raise ValueError(f"{self.problem.name!r} has no path constraints")
        df = pd.DataFrame(self.path_values, columns=cs.labels)
        for j, label in enumerate(cs.labels):
            df[f"mu_{label}"] = cast(np.ndarray, self.path_multipliers)[:, j]
        df.insert(0, "t", self.path_times)
        return df

    def nodes_dataframe(self) -> pd.DataFrame:
        """NLP state parameters at their nodes."""
        import pandas as pd

        df = pd.DataFrame(self.state_values, columns=self.problem.state_names)
        df.insert(0, "t", self.state_times)
        return df

    @property
    def linear_solver(self) -> str:
        """IPOPT's linear solver and its ordering in this solve (e.g. ``"mumps (QAMD ordering)"``; chosen by the
        transcription's structure, :attr:`~ocpkit.Radau.ipopt_defaults`); ``""`` where not recorded."""
        return str(self.raw.get("linear_solver", ""))

    def summary(self) -> dict[str, Any]:
        """Key numbers, JSON-serialisable."""
        return {
            "problem": self.problem.name,
            "transcription": self.transcription,
            "status": self.status,
            "objective": self.objective,
            "tf": self.tf,
            "nlp_parameters": self.decision_variables,
            "defect_equations": self.defect_equations,
            "constraints": self.constraints,
            "iterations": self.iterations,
            "build_s": self.build_s,
            "solve_s": self.solve_s,
        }
