"""What a transcription scheme provides to the program that owns the NLP: the contract, rule by rule.

A scheme is configuration on a grid: ``Radau(nodes=4, intervals=20)`` says where the points lie and how the
dynamics hold between them, for any problem. A :class:`~ocpkit.program.Program` owns the NLP: it lays out every
phase's variables, asks the phase's scheme for what only the scheme knows, and builds everything else itself (the
bounds, the boundary conditions, the Mayer term, the path and boundary constraints at the scheme's points, the
links between phases, the solve and the solution). A new scheme (Legendre-Gauss, say) is one module that provides
the members of :class:`Scheme`, one entry in :data:`~ocpkit.transcription.registry.SCHEMES`, and its test; the contract, rule by rule:

1. ``label``: a short description for messages and tables, ``"Radau(nodes=4, intervals=20)"``.
2. ``ipopt_defaults``: IPOPT options its NLP's structure asks for (a fill-reducing ordering), applied after
   :data:`ocpkit.nlp.DEFAULT_IPOPT_OPTIONS` and before the user's; the program drops its ordering where the NLP is
   large and has a shared column (:data:`~ocpkit.program.program.SHARED_COLUMN_POINTS`).
3. ``groups(problem)``: its NLP variables for one phase, in layout order, as :class:`VariableGroup` s, each a run of
   some of the problem's states or controls at points with their normalised times in [0, 1] (Dymos calls them node
   subsets). Every state is in one group whose first point lies at 0 and last at 1: the program holds the boundary
   conditions there. Every control is in one group (its end values: rule 6).
4. ``defect_count(problem)``: how many defect equations it writes, the phase's first constraint rows.
5. ``blocks(phase)``: its :class:`~ocpkit.nlp.Block` s on the phase's layout (:class:`~ocpkit.program.PhaseLayout`:
   its groups' index tables, its problem-wide variables, the program's objective scale), in the phase's own
   numbering: the defect rows ``0 .. defect_count - 1`` (each scaled by the state scale, every row written), then
   the running cost as objective blocks (divided by ``phase.objective_scale``). Each block is one small function
   mapped over its instances: the NLP stays block-separable with exact derivatives.
6. ``path_points(phase)`` and ``control_weights(fraction)``: where path constraints hold (:class:`PathPoints`: the
   states, controls and times at the points, as expressions of the block's variables; an empty list if the scheme
   enforces none), and the points of the control group with the weights that give the control at a normalised time
   (``u(s) = sum_k w_k U_k``): the program holds a control's end value by its point's bounds where one lies there,
   else as a row on this combination.
7. ``interpolants(phase, values, problem, t0, tf)``: the solution's fields from the values of its groups (physical, one
   ``(points, variables)`` array per group) and the solved problem and times: the times and values at the points,
   the mesh's breakpoints, the state and control interpolants (functions of time), and where the error estimate is
   not on the mesh, its intervals (:class:`PhaseFields`).
8. ``costates(phase, multipliers, t0, tf)``: costate estimates ``(times, values)`` from the defect rows'
   multipliers (IPOPT's, of the scaled NLP: the scheme converts them by ``phase.objective_scale``, its weights and
   the state scale), or None where the scheme gives none.
9. ``refine(errors, tolerance, cuts)``: the scheme on a grid refined where the per-interval ``errors`` (its estimate
   intervals, a :class:`PhaseFields`' ``estimate_breakpoints``) exceed ``tolerance``, cut at ``cuts`` (per interval,
   fractions in (0, 1) where the control switches or a path constraint's arc begins); this very object where
   nothing needs refining (the refinement then stops: the next mesh would be this one).
10. ``uniform(points)``: the scheme on equal intervals at the lowest degree its refinement uses, with at least
    ``points`` collocation points: the mesh a refinement restarts on when the meshes it refined from lead nowhere
    (:func:`ocpkit.program.solve.solve_refined`). Optional: a scheme that raises ``NotImplementedError`` (the
    default of :class:`~ocpkit.transcription.base.Transcription`) is refined without that recovery.

The program never asks a scheme anything else (but for a ``problem`` it may carry, the problem it is bound to, which
must be its phase's), so everything a scheme does not provide works the same on every scheme and on any number of
phases. :data:`~ocpkit.transcription.registry.SCHEMES` names them;
:func:`ocpkit.transcription.registry.scheme` builds one from its name, so that a study or a table chooses a scheme
by name without a dispatch of its own.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import casadi as ca
import numpy as np

from ..statement import AffineScaling, Control, OptimalControlProblem, State, Variable

if TYPE_CHECKING:
    from ..nlp import Block
    from ..program.layout import PhaseLayout


#: The value of an IPOPT option (a scheme's preferences, rule 2)
IpoptOption = str | int | float


@dataclass(frozen=True, eq=False)
class VariableGroup:
    """A run of NLP variables: the values of ``variables`` at points whose normalised times (0..1) are
    ``fractions``, point by point (``points`` of them)."""

    name: str
    variables: tuple[Variable, ...]
    fractions: np.ndarray

    @property
    def points(self) -> int:
        return int(np.size(self.fractions))

    @property
    def size(self) -> int:
        return self.points * len(self.variables)

    @property
    def is_state(self) -> bool:
        return bool(self.variables) and isinstance(self.variables[0], State)

    @property
    def is_control(self) -> bool:
        return bool(self.variables) and isinstance(self.variables[0], Control)

    @property
    def scaling(self) -> AffineScaling:
        return AffineScaling.of(self.variables)


@dataclass(eq=False)
class PathPoints:
    """Where a scheme holds states and controls, for its path constraints: ``count`` instances of ``k`` points.

    ``z`` and ``p`` are the symbols of one instance (its NLP variables and constants, the
    layout of ``variables`` (nz, count), the phase's own numbering, and ``constants`` (np, count)); ``x``, ``u`` and
    ``t`` are lists of ``k`` expressions in them (state, control, time at each point);
    ``fractions`` (count, k) the normalised times (0..1) of the points.
    """

    z: ca.SX
    p: ca.SX
    x: list[ca.SX]
    u: list[ca.SX]
    t: list[ca.SX]
    variables: np.ndarray
    constants: np.ndarray
    fractions: np.ndarray

    @property
    def count(self) -> int:
        return int(self.variables.shape[1])

    @property
    def k(self) -> int:
        return len(self.x)


@dataclass
class PhaseFields:
    """What a scheme makes of a phase's solved values (rule 7 of :class:`Scheme`): the times and values of the states
    and controls at their points, the mesh's ``breakpoints`` (physical times, t0 to tf), the ``state_interpolant`` and
    ``control_interpolant`` (functions of time, shape ``t.shape + (n,)``) and, where the error estimate is not on
    the mesh's intervals, ``estimate_breakpoints`` and the points of each ``estimate_points`` (default: the
    breakpoints; the estimate's own default count)."""

    state_times: np.ndarray
    state_values: np.ndarray
    control_times: np.ndarray
    control_values: np.ndarray
    breakpoints: np.ndarray
    state_interpolant: Callable[[np.ndarray], np.ndarray]
    control_interpolant: Callable[[np.ndarray], np.ndarray]
    estimate_breakpoints: np.ndarray | None = None
    estimate_points: np.ndarray | int | None = None


@runtime_checkable
class Scheme(Protocol):
    """The contract of a transcription scheme (the module docstring says it rule by rule)."""

    @property
    def label(self) -> str: ...

    @property
    def ipopt_defaults(self) -> Mapping[str, IpoptOption]: ...

    def groups(self, problem: OptimalControlProblem) -> tuple[VariableGroup, ...]: ...

    def defect_count(self, problem: OptimalControlProblem) -> int: ...

    def blocks(self, phase: PhaseLayout) -> list[Block]: ...

    def path_points(self, phase: PhaseLayout) -> list[PathPoints]: ...

    def control_weights(self, fraction: float) -> tuple[np.ndarray, np.ndarray]: ...

    def interpolants(
        self, phase: PhaseLayout, values: Sequence[np.ndarray], problem: OptimalControlProblem, t0: float, tf: float
    ) -> PhaseFields: ...

    def costates(
        self, phase: PhaseLayout, multipliers: np.ndarray, t0: float, tf: float
    ) -> tuple[np.ndarray, np.ndarray] | None: ...

    def refine(self, errors: np.ndarray, tolerance: float, cuts: Sequence[np.ndarray] | None = None) -> Scheme: ...

    def uniform(self, points: int) -> Scheme: ...


__all__ = ["IpoptOption", "PathPoints", "PhaseFields", "Scheme", "VariableGroup"]
