"""Direct transcriptions: one module per scheme."""

from .base import Transcription, mesh_fractions
from .hlgl import HLGL

__all__ = ["Transcription", "HLGL", "mesh_fractions"]
