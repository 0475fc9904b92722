"""The contract of a transcription scheme, where the schemes meet it: it is the program's,
:mod:`ocpkit.program.scheme` (what a :class:`~ocpkit.program.Program` asks of a scheme), re-exported here."""

from ..program.scheme import PathPoints as PathPoints
from ..program.scheme import PhaseFields as PhaseFields
from ..program.scheme import Scheme as Scheme
from ..program.scheme import VariableGroup as VariableGroup
