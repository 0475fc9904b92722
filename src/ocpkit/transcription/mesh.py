"""The mesh of a transcription: segments of [t0, tf], their points, and the map to physical time.

Every scheme lays its points on segments given as fractions of ``tf - t0``; with a free
initial or final time the map from normalised time ``s`` in [0, 1] to physical time
``t0 + (tf - t0) s`` involves NLP variables. This module is the one place that map is
written, numerically (:meth:`Mesh.times`) and symbolically (:func:`segment_clock`,
:meth:`GlobalVariables.t0`, :meth:`GlobalVariables.tf`).

The problem-wide NLP variables (:class:`GlobalVariables`) close the NLP vector and every block
that needs them: the problem's (fixed) parameters, pinned by their bounds to the values of
the solve (unscaled; IPOPT treats a variable whose bounds are equal as a constant, so they
add nothing to the KKT system, and a new value is a new bound, not a new NLP), then the free
parameters (scaled by their own scaling), then ``t0`` (scaled) when free, then ``tf``
(scaled) when free; :meth:`GlobalVariables.P` and the two time functions read them from the
end of a block's variables ``z``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import casadi as ca
import numpy as np

from .._deprecation import renamed
from ..statement import Duration

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..statement import FreeFinalTime, FreeInitialTime, OptimalControlProblem


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
        self, problem: OptimalControlProblem, s: ArrayLike | None = None, fractions: ArrayLike | None = None
    ) -> np.ndarray:
        """The constant rows of segment (or point) blocks (:attr:`ocpkit.nlp.Block.constants`):
        ``[s, fraction, (tf if fixed)]``.

        Default: each segment's start and length; give ``s`` and ``fractions`` for
        other points (a point's normalised time and its segment's fraction).
        """
        s = self.starts if s is None else np.asarray(s, dtype=float)
        fractions = self.fractions if fractions is None else np.asarray(fractions, dtype=float)
        rows = [s, fractions, *(np.full(s.size, v) for v in GlobalVariables(problem).constants)]
        return np.vstack(rows)


class GlobalVariables:
    """The problem-wide NLP variables of a problem, last in every NLP vector and in every block's ``z``: the pinned
    parameters (NLP variables held by their bounds, so that new values need no rebuild), the free parameters (scaled),
    then t0 and tf where free (divided by their ``scale``; a :class:`~ocpkit.problem.Duration` holds ``tf - t0``
    instead). The only code that maps them, numerically (:meth:`pack`, :meth:`unpack`, :meth:`bounds`) and
    symbolically (:meth:`t0`, :meth:`tf`, :meth:`P`).
    """

    def __init__(self, problem: OptimalControlProblem) -> None:
        self.problem = problem
        self.n_pinned = len(problem.parameters)
        self.n_free = len(problem.free_parameters)
        self.size = self.n_pinned + self.n_free + int(problem.free_initial_time) + int(problem.free_final_time)
        self.duration = isinstance(problem.tf, Duration)

    @property
    def free_positions(self) -> np.ndarray:
        """The positions of the free parameters among them."""
        return np.arange(self.n_pinned, self.n_pinned + self.n_free, dtype=np.int64)

    def free_to_nlp(self, values: Mapping[str, float]) -> np.ndarray:
        """The scaled values of the free parameters from physical ones by name (default their guesses)."""
        pr = self.problem
        values = {v.name: v.guess_value for v in pr.free_parameters} | dict(values)
        return pr.free_parameter_scaling.to_nlp([values[v.name] for v in pr.free_parameters])

    def free_value(self, j: int, scaled: Any) -> Any:
        """Free parameter ``j``'s physical value from its scaled NLP value (a number or a symbol)."""
        sc = self.problem.free_parameter_scaling
        return float(sc.scale[j]) * scaled + float(sc.shift[j])

    @property
    def t0_position(self) -> int | None:
        """The position of t0 among them (None when fixed)."""
        return self.n_pinned + self.n_free if self.problem.free_initial_time else None

    @property
    def tf_position(self) -> int | None:
        """The position of tf among them (None when fixed)."""
        return self.size - 1 if self.problem.free_final_time else None

    @property
    def constants(self) -> list[float]:
        """The block constants the times need, ``[tf]`` when it is fixed (a block's ``q`` holds it, so that one
        compiled block serves any fixed final time), else none."""
        return [] if self.problem.free_final_time else [float(cast(float, self.problem.tf))]

    # -- numbers ---------------------------------------------------------------------------------------------------
    def pack(
        self, pinned: ArrayLike, parameters: Mapping[str, float], t0: float | None, tf: float | None
    ) -> np.ndarray:
        """The scaled values from physical ones: the pinned vector, the free parameters by name (default their
        guesses), t0 (default the problem's guess) and tf (required when free)."""
        pr = self.problem
        parts: list[Any] = [np.asarray(pinned, dtype=float).ravel()]
        if self.n_free:
            parts.append(self.free_to_nlp(parameters))
        t0 = pr.t0 if t0 is None else t0
        if pr.free_initial_time:
            parts.append([t0 / cast("FreeInitialTime", pr.initial_time).scale])
        if pr.free_final_time:
            if tf is None:
                raise ValueError("this problem has a free final time: give tf")
            parts.append([((tf - t0) if self.duration else tf) / cast("FreeFinalTime", pr.tf).scale])
        return np.concatenate(parts)

    def unpack(self, z: ArrayLike) -> dict[str, Any]:
        """``{"pinned": {name: value}, "parameters": {name: value}, "t0": ..., "tf": ...}`` of their scaled values."""
        pr = self.problem
        z = np.asarray(z, dtype=float).ravel()
        n_pinned, nf = self.n_pinned, self.n_free
        values = pr.free_parameter_scaling.from_nlp(z[n_pinned : n_pinned + nf]) if nf else np.zeros(0)
        i0, i_f = self.t0_position, self.tf_position
        t0 = float(z[i0] * cast("FreeInitialTime", pr.initial_time).scale) if i0 is not None else pr.t0
        return {
            "pinned": dict(zip(pr.parameters, z[:n_pinned].tolist())),
            "parameters": dict(zip([v.name for v in pr.free_parameters], values.tolist())),
            "t0": t0,
            "tf": float(self._final(t0, z[i_f])) if i_f is not None else pr.tf,
        }

    def _final(self, t0: Any, value: Any) -> Any:
        """The final time from t0 and the scaled NLP value of tf (or of the duration)."""
        return (t0 if self.duration else 0.0) + value * cast("FreeFinalTime", self.problem.tf).scale

    def bounds(self, pinned: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Their scaled bounds, the pinned parameters held at ``pinned``."""
        pr = self.problem
        pinned = np.asarray(pinned, dtype=float).ravel()
        lb: list[Any] = [pinned]
        ub: list[Any] = [pinned]
        if self.n_free:
            sc = pr.free_parameter_scaling
            lb.append(sc.to_nlp([v.lower for v in pr.free_parameters]))
            ub.append(sc.to_nlp([v.upper for v in pr.free_parameters]))
        for spec, free in ((pr.initial_time, pr.free_initial_time), (pr.tf, pr.free_final_time)):
            if free:
                spec = cast("FreeFinalTime", spec)  # (a FreeInitialTime is one)
                lb.append([spec.lower / spec.scale])
                ub.append([spec.upper / spec.scale])
        return np.concatenate(lb), np.concatenate(ub)

    # -- symbols (a block's ``z`` ends with these variables; ``q`` holds its constants) -------------------------
    def t0(self, z: Any) -> Any:
        """The symbolic initial time: its NLP variable in ``z``'s tail when free, else the constant."""
        if self.t0_position is None:
            return self.problem.t0
        return z[z.numel() - self.size + self.t0_position] * cast("FreeInitialTime", self.problem.initial_time).scale

    def tf(self, z: Any, q: Any, index: int) -> Any:
        """The symbolic final time: its NLP variable in ``z``'s tail when free, else the block constant ``q[index]``."""
        return self._final(self.t0(z), z[z.numel() - 1]) if self.tf_position is not None else q[index]

    def P(self, z: Any) -> Any:
        """The parameter vector ``P`` from ``z``'s tail: the pinned values, then the free parameters."""
        pr = self.problem
        if not self.n_pinned + self.n_free:
            return pr._P
        start = z.numel() - self.size
        parts = [z[start : start + self.n_pinned]] if self.n_pinned else []
        if self.n_free:
            free = z[start + self.n_pinned : start + self.n_pinned + self.n_free]
            parts.append(pr.free_parameter_scaling.from_nlp(free))
        return ca.vertcat(*parts)


def segment_clock(problem: OptimalControlProblem, z: Any, p: Any) -> tuple[Any, Any, Any]:
    """``(t_begin, T, h)`` of a block whose constants are ``[s, fraction, (tf)]`` (:meth:`Mesh.block_constants`).

    ``T = tf - t0``, ``t_begin = t0 + T s`` and ``h = T fraction``.
    """
    layout = GlobalVariables(problem)
    t0 = layout.t0(z)
    T = layout.tf(z, p, 2) - t0
    return t0 + T * p[0], T, T * p[1]


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
