"""The one program that owns a direct transcription's NLP (:class:`Program`), and what it is made of.

:mod:`~ocpkit.program.program` (the program: statement, schemes, NLP, bounds, starts, results),
:mod:`~ocpkit.program.scheme` (the contract it asks of a scheme), :mod:`~ocpkit.program.layout` (where everything
lies, built once per mesh), :mod:`~ocpkit.program.assembly` (the blocks that are the same on every scheme),
:mod:`~ocpkit.program.solve` (the solve policy: one solve, warm starts, mesh refinement) and
:mod:`~ocpkit.program.loop` (many solves at the cost of the solver call).
"""

from .layout import GlobalVariables, Layout, Phase, PhaseLayout
from .loop import LoopResult, SolveLoop
from .program import Program
from .solve import MeshIteration

__all__ = ["GlobalVariables", "Layout", "LoopResult", "MeshIteration", "Phase", "PhaseLayout", "Program", "SolveLoop"]
