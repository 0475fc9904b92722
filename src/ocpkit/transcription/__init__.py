"""Direct transcriptions: one module per scheme."""

from .base import Transcription, mesh_fractions
from .hlgl import HLGL
from .multirate import MultiRateHLGL, state_partition

__all__ = ["HLGL", "MultiRateHLGL", "Transcription", "mesh_fractions", "state_partition"]
