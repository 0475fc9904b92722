"""ocpkit: transcriptions, solvers and test problems of the optimal-control compendium."""

from typing import Any

from .errors import SolverError
from .outcome import Outcome
from .program import LoopResult, Program, SolveLoop
from .scaling import autoscale
from .solution import PhaseSolution, Reintegration, Solution
from .statement import (
    Constraint,
    Control,
    Duration,
    FreeFinalTime,
    FreeInitialTime,
    FreeParameter,
    Guess,
    OptimalControlProblem,
    State,
)
from .statement.phases import Link, MultiPhaseProblem
from .trajectory import Trajectory
from .transcription import HLGL, MultiPhase, MultiRateHLGL, Radau, Scheme, Transcription, scheme

__version__ = "0.3.0.dev0"

__all__ = [
    "Constraint",
    "Control",
    "Duration",
    "FreeFinalTime",
    "FreeInitialTime",
    "FreeParameter",
    "Guess",
    "HLGL",
    "Link",
    "LoopResult",
    "MultiPhase",
    "MultiPhaseProblem",
    "MultiRateHLGL",
    "OptimalControlProblem",
    "Outcome",
    "PhaseSolution",
    "Program",
    "Radau",
    "Reintegration",
    "Scheme",
    "Solution",
    "SolveLoop",
    "SolverError",
    "State",
    "Trajectory",
    "Transcription",
    "autoscale",
    "scheme",
]


def __getattr__(name: str) -> Any:
    if name == "MultiPhaseSolution":
        from ._deprecation import renamed

        renamed("ocpkit.MultiPhaseSolution", "ocpkit.Solution (one result for any number of phases)")
        return Solution
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
