"""Linked phases, by their names before the program (:class:`~ocpkit.program.Program`) owned every NLP.

The statement of linked phases is :class:`~ocpkit.statement.phases.MultiPhaseProblem` (its :class:`Link`,
:class:`PhaseEnds` and :class:`PhasesEnds` are re-exported here); a program transcribes it, each phase on its scheme,
and its solution is an :class:`ocpkit.Solution` of as many phases. ``MultiPhase`` and ``MultiPhaseSolution`` are the
deprecated names of those (the old name goes in the next release).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from .._deprecation import renamed
from ..program import Program
from ..statement import OptimalControlProblem
from ..statement.phases import Link as Link
from ..statement.phases import PhaseEnds as PhaseEnds
from ..statement.phases import PhasesEnds as PhasesEnds
from .base import Transcription


class MultiPhase:
    """Deprecated: linked phases are a :class:`~ocpkit.program.Program` of a
    :class:`~ocpkit.statement.phases.MultiPhaseProblem` (``Program(MultiPhaseProblem(problems, links, ...),
    schemes)``), or of transcriptions bound to their problems, :meth:`Program.from_phases
    <ocpkit.program.Program.from_phases>`, which ``MultiPhase(transcriptions, links, ...)`` returns."""

    def __new__(  # type: ignore[misc]  # returns the program that replaces it
        cls,
        phases: Sequence[Transcription] | Mapping[str, Transcription],
        links: Sequence[Link] | None = None,
        **options: Any,
    ) -> Program:
        renamed("MultiPhase(transcriptions, links, ...)", "Program.from_phases(transcriptions, links, ...)")
        return Program.from_phases(phases, links, **options)

    @classmethod
    def split(
        cls,
        problem: OptimalControlProblem,
        times: Sequence[float],
        scheme: Callable[[OptimalControlProblem], Transcription],
        **options: Any,
    ) -> Program:
        """Deprecated name of :meth:`Program.split <ocpkit.program.Program.split>`."""
        renamed("MultiPhase.split", "Program.split")
        return Program.split(problem, times, scheme, **options)


def __getattr__(name: str) -> Any:
    if name == "MultiPhaseSolution":
        from ..solution import Solution

        renamed(
            "ocpkit.transcription.phases.MultiPhaseSolution", "ocpkit.Solution (one result for any number of phases)"
        )
        return Solution
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
