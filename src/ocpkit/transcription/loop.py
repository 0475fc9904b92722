"""Many solves at the cost of the solver call, by its module's name before the program owned it: it is
:mod:`ocpkit.program.loop` (:class:`SolveLoop` and :class:`LoopResult` are re-exported here)."""

from ..program.loop import LoopResult as LoopResult
from ..program.loop import SolveLoop as SolveLoop
