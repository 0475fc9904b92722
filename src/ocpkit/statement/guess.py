"""An initial guess of a statement's trajectory."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .bounds import GuessSpec, guess_function

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from .problem import OptimalControlProblem
    from .variables import Variable


@dataclass
class Guess:
    """An initial guess for a transcription.

    ``states`` and ``controls`` map names to a :data:`~ocpkit.statement.bounds.GuessSpec` (a function of time,
    a constant, or a ``(start, end)`` tuple linear in time); names left out use each
    variable's own guess. ``tf`` defaults to the problem's guess (a free initial time
    starts at its guess), and ``parameters`` (free parameter name -> value) to each free
    parameter's guess.
    """

    tf: float | None = None
    states: Mapping[str, GuessSpec] = field(default_factory=dict)
    controls: Mapping[str, GuessSpec] = field(default_factory=dict)
    parameters: Mapping[str, float] = field(default_factory=dict)

    def parameter_values(self, problem: OptimalControlProblem) -> dict[str, float]:
        """The guess of every free parameter, by name."""
        names = [v.name for v in problem.free_parameters]
        unknown = sorted(set(self.parameters) - set(names))
        if unknown:
            raise KeyError(f"guess names unknown free parameters {unknown}; free parameters are {names}")
        return {v.name: float(self.parameters.get(v.name, v.guess_value)) for v in problem.free_parameters}

    def functions(
        self, problem: OptimalControlProblem
    ) -> tuple[float, Callable[[ArrayLike], np.ndarray], Callable[[ArrayLike], np.ndarray]]:
        """``(tf, states(t), controls(t))``: the guessed final time and the guess as functions of time."""
        tf = problem.tf_guess if self.tf is None else float(self.tf)
        t0 = problem.t0
        if not (math.isfinite(tf) and tf > t0):
            raise ValueError(f"guess tf = {tf} must be finite and exceed t0 = {t0}")
        for key, names in (("states", problem.state_names), ("controls", problem.control_names)):
            unknown = sorted(set(getattr(self, key)) - set(names))
            if unknown:
                raise KeyError(f"guess names unknown {key} {unknown}; {key} are {names}")

        def build(
            spec_map: Mapping[str, GuessSpec], variables: Sequence[Variable]
        ) -> Callable[[ArrayLike], np.ndarray]:
            parts = [
                guess_function(spec_map[v.name], f"guess for {v.name!r}") or v.guess_function()
                if v.name in spec_map
                else v.guess_function()
                for v in variables
            ]

            def fun(t: ArrayLike) -> np.ndarray:
                t = np.asarray(t, dtype=float)
                s = (t - t0) / (tf - t0)
                if not parts:
                    return np.zeros(t.shape + (0,))
                return np.stack([np.broadcast_to(g(s, t), t.shape) for g in parts], axis=-1)

            return fun

        return tf, build(self.states, problem.states), build(self.controls, problem.controls)
