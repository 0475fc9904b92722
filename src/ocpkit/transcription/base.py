"""What every transcription scheme shares, and the shorthand of a scheme bound to a problem.

A scheme (:class:`Transcription`'s subclasses: :class:`~ocpkit.transcription.hlgl.HLGL`,
:class:`~ocpkit.transcription.radau.Radau`, :class:`~ocpkit.transcription.multirate.MultiRateHLGL`) is
configuration on a grid; what it must provide is :class:`~ocpkit.program.scheme.Scheme`'s contract. Given a
problem first, ``HLGL(problem, intervals=20)``, a scheme is also the shorthand of the one-phase
:class:`~ocpkit.program.Program` of that problem: ``solve``, ``loop``, ``nlp`` and the program's other members are
that program's (:attr:`Transcription.program`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Self

import numpy as np

from ..program import Program
from ..statement import OptimalControlProblem

if TYPE_CHECKING:
    from ..nlp import Block
    from ..program.layout import PhaseLayout
    from ..program.loop import SolveLoop
    from ..program.scheme import IpoptOption, PathPoints, PhaseFields, VariableGroup
    from ..solution import Solution


class _OfProgram:
    """A member of the bound scheme's one-phase program (:attr:`Transcription.program`): its value there."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name
        self.__doc__ = f"The one-phase program's ``{name}`` (:class:`~ocpkit.program.program.Program`; a bound scheme)."

    def __get__(self, obj: Any, owner: Any = None) -> Any:
        if obj is None:
            return self
        return getattr(obj.program, self.name)


class Transcription(ABC):
    """A transcription scheme: configuration on a grid (the contract, :class:`~ocpkit.program.scheme.Scheme`).

    ``problem``: None for a scheme alone (``Radau(nodes=4, intervals=20)``, for a
    :class:`~ocpkit.program.Program` of any number of phases); a problem binds the scheme to it, and the scheme is
    then the shorthand of that problem's one-phase program (:attr:`program`): ``HLGL(problem, 20).solve()``.
    """

    #: IPOPT options this scheme prefers over :data:`ocpkit.nlp.DEFAULT_IPOPT_OPTIONS` (user options win).
    ipopt_defaults: Mapping[str, IpoptOption] = {}

    def __init__(self, problem: OptimalControlProblem | None = None) -> None:
        if problem is not None and not isinstance(problem, OptimalControlProblem):
            raise TypeError(f"expected an OptimalControlProblem, got {type(problem).__name__}")
        #: the problem the scheme is bound to (None for a scheme alone)
        self.problem = problem
        self._program: Program | None = None
        self._compile: str | bool = "auto"

    # -- the contract (ocpkit.program.scheme.Scheme) -------------------------------------------------------------
    @property
    @abstractmethod
    def label(self) -> str:
        """Short description, e.g. ``HLGL(intervals=20)``."""

    @abstractmethod
    def groups(self, problem: OptimalControlProblem) -> tuple[VariableGroup, ...]:
        """The NLP variables of a phase of ``problem``, in layout order (rule 3 of the contract)."""

    @abstractmethod
    def defect_count(self, problem: OptimalControlProblem) -> int:
        """How many defect equations it writes for ``problem`` (rule 4)."""

    @abstractmethod
    def blocks(self, phase: PhaseLayout) -> list[Block]:
        """The defect and running-cost blocks of a phase (rule 5)."""

    def path_points(self, phase: PhaseLayout) -> list[PathPoints]:
        """Where path constraints hold (rule 6); none by default."""
        return []

    @abstractmethod
    def control_weights(self, fraction: float) -> tuple[np.ndarray, np.ndarray]:
        """The control group's points and weights giving the control at a normalised time (rule 6)."""

    @abstractmethod
    def interpolants(
        self, phase: PhaseLayout, values: Sequence[np.ndarray], problem: OptimalControlProblem, t0: float, tf: float
    ) -> PhaseFields:
        """The solution's fields from the phase's solved values (rule 7)."""

    def costates(
        self, phase: PhaseLayout, multipliers: np.ndarray, t0: float, tf: float
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """Costate estimates from the defect multipliers (rule 8); none by default."""
        return None

    @abstractmethod
    def refine(self, errors: np.ndarray, tolerance: float, cuts: Sequence[np.ndarray] | None = None) -> Transcription:
        """The scheme on a refined grid, this very object where nothing needs refining (rule 9); a scheme bound to a
        problem stays bound to it."""

    def uniform(self, points: int) -> Transcription:
        """The scheme on equal intervals at the lowest degree its refinement uses, with at least ``points``
        collocation points (rule 10, optional); a scheme bound to a problem stays bound to it. This default has
        none: a refinement of the scheme skips its uniform-mesh recovery."""
        raise NotImplementedError(f"{self.label} has no uniform mesh (scheme rule 10)")

    # -- a scheme bound to a problem: the shorthand of its one-phase program ----------------------------------------------
    @property
    def program(self) -> Program:
        """The one-phase :class:`~ocpkit.program.Program` of the problem this scheme is bound to (made once)."""
        if self._program is None:
            if self.problem is None:
                raise ValueError(
                    f"{self.label} is a scheme alone: bind it to a problem ({type(self).__name__}(problem, ...)) or "
                    f"give it to a program, Program(problem, {self.label})"
                )
            self._program = Program(self.problem, self, compile=self._compile)
        return self._program

    @property
    def compile(self) -> str | bool:
        """Whether the program's NLP blocks are compiled to C (:class:`~ocpkit.program.Program`'s ``compile``); set
        it before the NLP is built (a refinement's meshes keep it)."""
        return self._program.compile if self._program is not None else self._compile

    @compile.setter
    def compile(self, value: str | bool) -> None:
        self._compile = value
        if self._program is not None:
            self._program.compile = value

    def solve(self, guess: Any = None, **options: Any) -> Solution:
        """Solve the problem this scheme is bound to: its one-phase program's :meth:`~ocpkit.program.Program.solve`
        (``ipopt_options``, ``allow_acceptable``, ``raise_on_failure``, ``error_threshold``, ``verdict``, ``mesh_tolerance``,
        ``max_mesh_iterations``, ``parameters``)."""
        return self.program.solve(guess, **options)

    def loop(self, **options: Any) -> SolveLoop:
        """Many solves of the bound problem at the cost of the solver call: its program's
        :meth:`~ocpkit.program.Program.loop`."""
        return self.program.loop(**options)

    def build(self) -> Self:
        """Build the program's NLP (idempotent); this scheme."""
        self.program.build()
        return self

    nlp = _OfProgram()
    build_s = _OfProgram()
    solver = _OfProgram()
    effective_ipopt_options = _OfProgram()
    nlp_bounds = _OfProgram()
    initial_point = _OfProgram()
    package = _OfProgram()
    pack = _OfProgram()
    unpack = _OfProgram()
    global_values = _OfProgram()
    global_indices = _OfProgram()
    time_indices = _OfProgram()
    n_variables = _OfProgram()
    n_constraints = _OfProgram()
    n_decision_variables = _OfProgram()
    n_path_points = _OfProgram()
    path_point_fractions = _OfProgram()
    n_defects = _OfProgram()
    n_collocation_points = _OfProgram()
    layout = _OfProgram()

    def __repr__(self) -> str:
        bound = f" of {self.problem.name!r}" if self.problem is not None else ""
        return f"<{self.label}{bound}>"


__all__ = ["Transcription"]
