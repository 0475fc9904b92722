"""ocpkit: transcriptions, solvers and test problems of the optimal-control compendium."""

from .errors import SolverError
from .outcome import Outcome
from .scaling import autoscale
from .solution import Reintegration, Solution
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
from .trajectory import Trajectory
from .transcription import (
    HLGL,
    Link,
    LoopResult,
    MultiPhase,
    MultiPhaseSolution,
    MultiRateHLGL,
    Radau,
    SolveLoop,
    Transcription,
)

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
    "MultiPhaseSolution",
    "MultiRateHLGL",
    "OptimalControlProblem",
    "Outcome",
    "Radau",
    "Reintegration",
    "Solution",
    "SolveLoop",
    "SolverError",
    "State",
    "Trajectory",
    "Transcription",
    "autoscale",
]
