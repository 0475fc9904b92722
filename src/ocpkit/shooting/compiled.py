"""Compiling a Hamiltonian system with the Dormand-Prince integrator into a shared library.

CasADi generates C for the mode-wise flows, switching functions and Hamiltonian of a
:class:`~ocpkit.shooting.hamiltonian.HamiltonianSystem`; ``dopri5.c`` (next to this
module, shipped with the package) integrates them. Both are compiled with the system's
C compiler (``CC``, default ``gcc``) into one library, cached by the hash of its sources
in ``OCPKIT_CACHE_DIR`` or the user's cache folder (``$XDG_CACHE_HOME/ocpkit/shooting``,
by default ``~/.cache/ocpkit/shooting``), and called through ctypes: the whole
integration, switching handling included, runs in C.
"""

from __future__ import annotations

import ctypes
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import _ccompile
from .._ccompile import CFLAGS, cache_dir  # noqa: F401 (their home before)
from .._deprecation import renamed_argument
from .hamiltonian import HamiltonianSystem
from .strategies import SWITCHING_MODES

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

_STATUS = {
    0: "ok",
    1: "maximum number of steps reached",
    2: "step size too small",
    3: "non-finite values",
    4: "out of memory",
    5: "switching root not found",
}
_SOURCE = Path(__file__).with_name("dopri5.c")


def generate_c(system: HamiltonianSystem) -> str:
    """C source of the system's functions (CasADi code generation)."""
    return _ccompile.generate_c(system.compiled_functions())


def build_library(system: HamiltonianSystem) -> Path:
    """Compile (or reuse from the cache, ``cache_dir()``: ``OCPKIT_CACHE_DIR``, else ``<user cache>/ocpkit/shooting``)
    the integrator for ``system``; returns the library path."""
    return _ccompile.shared_library("ocp", generate_c(system), [_SOURCE], purpose="the shooting integrator")


@dataclass
class Integration:
    """Result of one integration from t0 to tf."""

    y: np.ndarray
    Psi: np.ndarray | None
    status: str
    accepted: int
    rejected: int
    rhs_evaluations: int
    switchings: int
    """Mode changes (a simultaneous crossing of several switching functions counts each)."""
    interior_switchings: int
    """Switchings found inside a step by the interior check (arcs a sign test at step ends misses)."""
    step_times: np.ndarray = field(repr=False)
    step_sizes: np.ndarray = field(repr=False)
    hamiltonian: np.ndarray = field(repr=False)
    rejected_times: np.ndarray = field(repr=False)
    rejected_sizes: np.ndarray = field(repr=False)
    switching_times: np.ndarray = field(repr=False)
    switching_index: np.ndarray = field(repr=False)
    states: np.ndarray = field(repr=False)
    """y = (x, p, J) at ``step_times`` (rows), when recorded."""
    truncated: bool = False
    """The recorded histories hit their capacity and stop before tf (the integration itself did not)."""
    parameters: np.ndarray | None = field(default=None, repr=False)
    """The problem parameters the flow was integrated with."""

    @property
    def steps(self) -> int:
        return self.accepted + self.rejected

    @property
    def rejected_ratio(self) -> float:
        return self.rejected / self.steps if self.steps else 0.0

    def controls(
        self, system: HamiltonianSystem, parameters: Mapping[str, float] | ArrayLike | None = None
    ) -> np.ndarray:
        """The control at the recorded points (rows), in the mode their switching functions select.

        ``parameters``: default, those this trajectory was integrated with.
        """
        P = system.problem.parameter_vector(self.parameters if parameters is None else parameters)
        return np.array([np.asarray(system.control(y, system.mode_at(y, P), P)).ravel() for y in self.states])

    @property
    def hamiltonian_drift(self) -> float:
        """Largest deviation of H from its initial value along the accepted steps."""
        return float(np.abs(self.hamiltonian - self.hamiltonian[0]).max()) if self.hamiltonian.size else float("nan")


class CompiledSystem:
    """A :class:`HamiltonianSystem` compiled with the Dormand-Prince integrator."""

    def __init__(self, system: HamiltonianSystem) -> None:
        self.system = system
        self.library_path = build_library(system)
        try:
            lib = ctypes.CDLL(str(self.library_path))
        except OSError:  # a broken file in the cache: compiled again, once
            _ccompile.discard(self.library_path)
            self.library_path = build_library(system)
            lib = ctypes.CDLL(str(self.library_path))
        dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
        i32 = np.ctypeslib.ndpointer(dtype=np.int32, flags="C_CONTIGUOUS")
        i64 = np.ctypeslib.ndpointer(dtype=np.int64, flags="C_CONTIGUOUS")
        fn = lib.ocp_integrate
        fn.restype = ctypes.c_int
        fn.argtypes = [
            dbl,
            ctypes.c_double,
            ctypes.c_double,
            dbl,
            i32,
            dbl,
            i32,
            dbl,
            i64,
            dbl,
            dbl,
            dbl,
            dbl,
            dbl,
            dbl,
            i32,
            ctypes.c_void_p,
        ]
        self._fn = fn
        self._lib = lib
        self._groups = np.asarray(system.law.group_sizes, dtype=np.int32)

    def integrate(
        self,
        y0: ArrayLike,
        t0: float,
        tf: float,
        parameters: Mapping[str, float] | ArrayLike | None = None,
        *,
        switching: str | None = None,
        rtol: float = 1e-8,
        atol: float = 1e-8,
        Psi0: ArrayLike | None = None,
        record: bool = True,
        max_steps: int = 1_000_000,
        capacity: int | None = None,
        h0: float = 0.0,
        hmax: float = 0.0,
        interior_check: bool = True,
        detection: str | None = None,
    ) -> Integration:
        """Integrate y = (x, p) from t0 to tf (tf > t0), optionally with variational columns Psi0 (n x nvar).

        ``switching``: how a switching is met (:data:`~ocpkit.shooting.SWITCHING_MODES`; ``detection`` is its
        deprecated name). ``interior_check``
        (detection and correction): also look for a pair of crossings
        inside one step (a short arc), from the cubic Hermite interpolant of each switching
        function and the dense output (see ``dopri5.c``); off, only the signs at the step's
        ends are compared, as in Martinon & Gergaud's slides.
        """
        switching = renamed_argument(
            "detection", "switching", detection, switching, "correction", "CompiledSystem.integrate"
        )
        sysm = self.system
        n = sysm.n
        if switching not in SWITCHING_MODES:
            raise ValueError(f"switching must be one of {SWITCHING_MODES}, got {switching!r}")
        if not (rtol > 0 and atol > 0):
            raise ValueError(f"tolerances must be positive, got rtol={rtol}, atol={atol}")
        if not tf > t0:
            raise ValueError(f"integration must run forward: tf = {tf} <= t0 = {t0}")
        y0 = np.asarray(y0, dtype=float).ravel()
        if y0.size != n:
            raise ValueError(f"y0 must have {n} entries (states and costates), got {y0.size}")
        P = sysm.problem.parameter_vector(parameters)
        nvar = 0
        Y0 = y0
        if Psi0 is not None:
            Psi0 = np.asarray(Psi0, dtype=float)
            if Psi0.shape != (n, sysm.n_variational):
                raise ValueError(f"Psi0 must have shape ({n}, {sysm.n_variational}), got {Psi0.shape}")
            nvar = sysm.n_variational
            Y0 = np.concatenate([y0, Psi0.ravel(order="F")])
        cap = int(capacity if capacity is not None else min(max_steps, 200_000)) if record else 1
        ng = sysm.law.n_switching
        opt_int = np.array(
            [
                n,
                nvar,
                ng,
                len(self._groups),
                SWITCHING_MODES.index(switching),
                max_steps,
                int(record),
                cap,
                int(bool(interior_check)),
            ],
            dtype=np.int32,
        )
        opt_dbl = np.array([rtol, atol, h0, hmax], dtype=float)
        Y = np.empty(Y0.size)
        out = np.zeros(9, dtype=np.int64)
        arrays = [np.empty(cap) for _ in range(6)]
        sw_k = np.empty(cap, dtype=np.int32)
        states = np.empty((cap, n)) if record else None
        self._fn(
            np.ascontiguousarray(Y0),
            float(t0),
            float(tf),
            np.ascontiguousarray(P),
            opt_int,
            opt_dbl,
            self._groups,
            Y,
            out,
            *arrays,
            sw_k,
            None if states is None else states.ctypes.data,
        )
        status, acc, rej, nfev, nsw, nhist, nrej, nswr, ninside = (int(v) for v in out)
        ht, hh, hH, rt, rh, st = arrays
        return Integration(
            y=Y[:n].copy(),
            Psi=Y[n:].reshape(n, nvar, order="F").copy() if nvar else None,
            status=_STATUS.get(status, f"error {status}"),
            accepted=acc,
            rejected=rej,
            rhs_evaluations=nfev,
            switchings=nsw,
            interior_switchings=ninside,
            step_times=ht[:nhist].copy(),
            step_sizes=hh[:nhist].copy(),
            hamiltonian=hH[:nhist].copy(),
            rejected_times=rt[:nrej].copy(),
            rejected_sizes=rh[:nrej].copy(),
            switching_times=st[:nswr].copy(),
            switching_index=sw_k[:nswr].copy(),
            states=states[:nhist].copy() if states is not None else np.zeros((0, n)),
            truncated=bool(record and max(nhist, nrej, nswr) >= cap),
            parameters=P.copy(),
        )
