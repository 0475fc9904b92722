"""The mesh of a transcription: segments of [t0, tf], their points, and the map to physical time.

Every scheme lays its points on segments given as fractions of ``tf - t0``; with a free
initial or final time the map from normalised time ``s`` in [0, 1] to physical time
``t0 + (tf - t0) s`` involves NLP variables. This module is the one place that map is
written, numerically (:meth:`Mesh.times`) and symbolically (:func:`segment_clock`,
:meth:`GlobalVariables.t0`, :meth:`GlobalVariables.tf`).

The problem-wide NLP variables that close a phase's variables and every block that needs them
(:class:`~ocpkit.program.layout.GlobalVariables`, and the symbolic clock of a segment,
:func:`~ocpkit.program.layout.segment_clock`) are the program's: this module re-exports them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._deprecation import renamed
from ..program.layout import GlobalVariables as GlobalVariables
from ..program.layout import segment_clock as segment_clock

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..statement import OptimalControlProblem


@dataclass(frozen=True)
class Mesh:
    """Segments of ``[t0, tf]`` as fractions of its length (positive, summing to one)."""

    fractions: np.ndarray

    @classmethod
    def from_spec(cls, count: int | None, fractions: ArrayLike | None = None, *, what: str = "intervals") -> Mesh:
        """``count`` equal segments, or the given ``fractions`` (normalised to sum to one).

        ``what`` names the count in errors (``segments``, ``intervals``).
        """
        if fractions is not None:
            frac = np.asarray(fractions, dtype=float).ravel()
            if frac.size < 1 or np.any(~np.isfinite(frac)) or np.any(frac <= 0):
                raise ValueError("mesh fractions must be positive and finite")
            if count is not None and count != frac.size:
                raise ValueError(f"{what}={count} disagrees with a mesh of {frac.size} fractions")
            return cls(frac / frac.sum())
        if count is None:
            raise ValueError(f"give the number of {what} or the mesh fractions")
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)):
            raise TypeError(f"{what} must be an integer, got {count!r}")
        if count < 1:
            raise ValueError(f"{what} must be at least 1, got {count}")
        return cls(np.full(int(count), 1.0 / count))

    @property
    def n(self) -> int:
        return self.fractions.size

    def split(self, pieces: ArrayLike) -> np.ndarray:
        """Fractions of this mesh with segment ``k`` split into ``pieces[k]`` equal parts (1: unchanged)."""
        pieces = np.asarray(pieces, dtype=np.int64)
        if pieces.shape != self.fractions.shape or np.any(pieces < 1):
            raise ValueError(f"give a positive number of pieces for each of the {self.n} intervals")
        return np.repeat(self.fractions / pieces, pieces)

    def split_at(self, cuts: Sequence[ArrayLike]) -> tuple[np.ndarray, np.ndarray]:
        """Fractions of this mesh with segment ``k`` cut at the positions ``cuts[k]`` (in (0, 1) of the segment;
        empty: unchanged), and the index of the original segment of each new one."""
        fractions: list[np.ndarray] = []
        origin: list[np.ndarray] = []
        for k, (f, c) in enumerate(zip(self.fractions, cuts)):
            edges = np.concatenate([[0.0], np.sort(np.asarray(c, dtype=float)), [1.0]])
            parts = np.diff(edges) * f
            fractions.append(parts)
            origin.append(np.full(parts.size, k))
        return np.concatenate(fractions), np.concatenate(origin)

    @property
    def starts(self) -> np.ndarray:
        """Normalised start times (0..1) of the segments."""
        return np.concatenate([[0.0], np.cumsum(self.fractions)[:-1]])

    @property
    def breaks(self) -> np.ndarray:
        """Normalised segment boundaries, 0 ... 1 (n + 1 values)."""
        return np.concatenate([self.starts, [1.0]])

    def points(self, local: ArrayLike) -> np.ndarray:
        """Normalised times (0..1) of points at ``local`` positions in [0, 1) of every segment, then the end (1).

        Points are ordered segment by segment; consecutive segments share their
        boundary point, so ``local`` excludes 1.
        """
        local = np.asarray(local, dtype=float)
        s = (self.starts[:, None] + self.fractions[:, None] * local[None, :]).ravel()
        return np.concatenate([s, [1.0]])

    @staticmethod
    def times(problem: OptimalControlProblem, tf: float, s: ArrayLike, t0: float | None = None) -> np.ndarray:
        """Physical times of normalised times ``s`` for a final time ``tf`` (and ``t0``, default the problem's)."""
        t0 = problem.t0 if t0 is None else t0
        return t0 + (tf - t0) * np.asarray(s)

    def parameters(
        self, problem: OptimalControlProblem, s: ArrayLike | None = None, fractions: ArrayLike | None = None
    ) -> np.ndarray:
        """Deprecated name of :meth:`block_constants`."""
        renamed("Mesh.parameters", "Mesh.block_constants")
        return self.block_constants(problem, s, fractions)

    def block_constants(
        self,
        times: GlobalVariables | OptimalControlProblem,
        s: ArrayLike | None = None,
        fractions: ArrayLike | None = None,
    ) -> np.ndarray:
        """The constant rows of segment (or point) blocks (:attr:`ocpkit.nlp.Block.constants`):
        ``[s, fraction, (tf if fixed)]``, ``times`` the phase's problem-wide variables (:class:`GlobalVariables`,
        or the problem, whose are then laid out again).

        Default: each segment's start and length; give ``s`` and ``fractions`` for
        other points (a point's normalised time and its segment's fraction).
        """
        s = self.starts if s is None else np.asarray(s, dtype=float)
        fractions = self.fractions if fractions is None else np.asarray(fractions, dtype=float)
        layout = times if isinstance(times, GlobalVariables) else GlobalVariables(times)
        rows = [s, fractions, *(np.full(s.size, v) for v in layout.constants)]
        return np.vstack(rows)


def h_refined(
    mesh: Mesh,
    errors: ArrayLike,
    tolerance: float,
    switches: Sequence[np.ndarray | Sequence[float]] | None = None,
) -> np.ndarray:
    """The fractions of HLGL's h-refinement of ``mesh``: a segment over ``tolerance`` is cut at its control
    ``switches`` when it has any, else split into ``ceil((error / tolerance)^(1/6))`` equal parts (2 to 6;
    HLGL's states converge at about h^6)."""
    errors = np.asarray(errors, dtype=float)
    over = ~(errors <= tolerance)  # NaN counts as over
    errors = np.where(np.isfinite(errors), errors, 1e3)
    pieces = np.where(over, np.clip(np.ceil((errors / tolerance) ** (1 / 6)), 2, 6), 1).astype(np.int64)
    cuts: list[np.ndarray] = []
    for k in range(mesh.n):
        if over[k] and switches is not None and len(switches[k]):
            cuts.append(np.asarray(switches[k], dtype=float))
        else:
            cuts.append(np.arange(1, pieces[k]) / pieces[k])
    return mesh.split_at(cuts)[0]
