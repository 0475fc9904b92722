"""Direct transcription schemes: one module per scheme, the contract a scheme provides, and the table of them.

:mod:`~ocpkit.transcription.scheme` (the contract, rule by rule), :mod:`~ocpkit.transcription.base` (what schemes
share, and a scheme bound to a problem as the shorthand of its program), :mod:`~ocpkit.transcription.hlgl`,
:mod:`~ocpkit.transcription.radau`, :mod:`~ocpkit.transcription.multirate` (the schemes),
:mod:`~ocpkit.transcription.mesh` (a mesh's segments and their refinement) and :mod:`~ocpkit.transcription.registry`
(the schemes by name).
"""

from typing import Any

from ..program.scheme import Scheme
from .base import Transcription
from .hlgl import HLGL
from .loop import LoopResult, SolveLoop
from .mesh import Mesh
from .multirate import MultiRateHLGL, state_partition
from .phases import Link, MultiPhase
from .radau import Radau
from .registry import SCHEMES, scheme

__all__ = [
    "HLGL",
    "SCHEMES",
    "Link",
    "LoopResult",
    "Mesh",
    "MultiPhase",
    "MultiRateHLGL",
    "Radau",
    "Scheme",
    "SolveLoop",
    "Transcription",
    "scheme",
    "state_partition",
]


def __getattr__(name: str) -> Any:
    if name == "MultiPhaseSolution":
        from .._deprecation import renamed
        from ..solution import Solution

        renamed("ocpkit.transcription.MultiPhaseSolution", "ocpkit.Solution (one result for any number of phases)")
        return Solution
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
