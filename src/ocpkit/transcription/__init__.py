"""Direct transcriptions: one module per scheme."""

from .base import Transcription
from .hlgl import HLGL
from .loop import LoopResult, SolveLoop
from .mesh import Mesh
from .multirate import MultiRateHLGL, state_partition
from .phases import Link, MultiPhase, MultiPhaseSolution
from .radau import Radau

__all__ = [
    "HLGL",
    "Link",
    "LoopResult",
    "Mesh",
    "MultiPhase",
    "MultiPhaseSolution",
    "MultiRateHLGL",
    "Radau",
    "SolveLoop",
    "Transcription",
    "state_partition",
]
