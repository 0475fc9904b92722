"""Direct transcriptions: one module per scheme."""

from .base import Transcription, mesh_fractions
from .hlgl import HLGL
from .multirate import MultiRateHLGL, state_partition
from .radau import Radau

__all__ = ["HLGL", "MultiRateHLGL", "Radau", "Transcription", "mesh_fractions", "state_partition"]
