"""The trajectory of a shooting solution as functions of time (a :class:`~ocpkit.trajectory.Trajectory`).

The compiled integrator records ``y = (x, p, J)`` at the end of every accepted step
and at every switching, so each interval between two records lies in one mode of the
control law. Between records the state and costate are the quintic Hermite
interpolant of ``y`` and of the mode's flow ``dy/dt`` and its derivative
``d2y/dt2 = (d phi / dy) phi`` at both ends (sixth-order accurate in the step: the
integrator's steps are as long as its fifth-order local error allows, and a cubic
interpolant's error, fourth order, exceeded its tolerance by orders of magnitude
between steps on smooth arcs); the control is the law's branch of that mode,
evaluated on the interpolated state and costate.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from .._arrays import unique
from ..nodes import quintic_hermite
from ..trajectory import Trajectory
from .compiled import Integration
from .hamiltonian import HamiltonianSystem

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


class ShootingTrajectory(Trajectory):
    """State, control and costate of a recorded integration (``record=True``) of a Hamiltonian system.

    ``objective``: the cost of the trajectory (the shooting result's, running cost plus Mayer term).
    """

    def __init__(self, integration: Integration, system: HamiltonianSystem, objective: float = float("nan")) -> None:
        if integration.states.shape[0] < 2:
            raise ValueError("a shooting trajectory needs a recorded integration (record=True)")
        if integration.truncated:
            raise ValueError("the recorded integration stops before tf (its history hit its capacity)")
        self.problem = system.problem
        self.system = system
        self.integration = integration
        self.objective = float(objective)
        P = system.problem.parameter_vector(integration.parameters)
        self.full_parameters = P
        t = integration.step_times
        keep = np.concatenate([[True], np.diff(t) > 0])  # a switching at tf repeats the last time
        self._t, Y = t[keep], integration.states[keep]
        self.t0, self.tf = float(self._t[0]), float(self._t[-1])
        n = self.problem.nx
        # the mode of each interval, from the switching functions at its midpoint
        self._maps: dict[tuple[int, int], ca.Function] = {}
        mid = 0.5 * (Y[1:] + Y[:-1])
        self._modes = self._modes_at(mid)
        d0, d1, a0, a1 = (np.empty_like(Y[:-1]) for _ in range(4))
        for m in unique(self._modes):
            sel = np.flatnonzero(self._modes == m)
            at = np.union1d(sel, sel + 1)  # the ends of this mode's intervals, each point once
            D = np.asarray(self._mapped(system.flow, at.size)(Y[at].T, m, P)).T
            A = np.asarray(self._mapped(system.acceleration, at.size)(Y[at].T, m, P)).T
            start, end = np.searchsorted(at, sel), np.searchsorted(at, sel + 1)
            d0[sel], d1[sel], a0[sel], a1[sel] = D[start], D[end], A[start], A[end]
        self._Y, self._D0, self._D1, self._A0, self._A1 = Y, d0, d1, a0, a1
        self._n = n
        self.breakpoints = np.concatenate(
            [
                [self.t0],
                integration.switching_times[
                    (integration.switching_times > self.t0) & (integration.switching_times < self.tf)
                ],
                [self.tf],
            ]
        )

    def _mapped(self, fun: ca.Function, count: int) -> ca.Function:
        """``fun`` mapped over ``count`` instances, built once per size: building a map takes about 14 ms, as long as
        evaluating 10,000 instances, and a closest approach (:func:`~ocpkit.shooting.grazing.closest_approach`) asks
        for single points some tens of times."""
        key = (id(fun), count)  # (the system holds its functions for the trajectory's life)
        mapped = self._maps.get(key)
        if mapped is None:
            mapped = self._maps[key] = fun.map(count)
        return mapped

    def _modes_at(self, Y: np.ndarray) -> np.ndarray:
        law = self.system.law
        g = np.asarray(self._mapped(self.system.switching, Y.shape[0])(Y.T, self.full_parameters)).T
        modes = np.zeros(Y.shape[0], dtype=int)
        stride, k = 1, 0
        for size in law.group_sizes:
            modes += stride * (g[:, k : k + size] > 0).sum(axis=1)
            stride *= size + 1
            k += size
        return modes

    def _locate(self, t: ArrayLike) -> tuple[tuple[int, ...], np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        flat = t.ravel()
        i = np.clip(np.searchsorted(self._t, flat, side="right") - 1, 0, self._t.size - 2)
        h = self._t[i + 1] - self._t[i]
        s = (flat - self._t[i]) / h
        return t.shape, i, s, h

    def _y(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        shape, i, s, h = self._locate(t)
        y = quintic_hermite(
            self._Y[i], self._D0[i], self._A0[i], self._Y[i + 1], self._D1[i], self._A1[i], h[:, None], s[:, None]
        )
        return y.reshape(shape + (y.shape[-1],)), i

    def switching(self, t: ArrayLike) -> np.ndarray:
        """The control law's switching functions ``g_k = q - c_k`` at the times ``t``, shape ``t.shape + (n_g,)``
        (:meth:`~ocpkit.shooting.ControlLaw.switching`; the law switches where one crosses zero)."""
        y, _ = self._y(t)
        Y = y.reshape(-1, y.shape[-1])
        g = np.asarray(self._mapped(self.system.switching, Y.shape[0])(Y.T, self.full_parameters)).T
        return g.reshape(y.shape[:-1] + (g.shape[-1],))

    def _state(self, t: np.ndarray) -> np.ndarray:
        return self._y(t)[0][..., : self._n]

    @property
    def has_costates(self) -> bool:
        return True

    def _costate(self, t: ArrayLike) -> np.ndarray:
        return self._y(t)[0][..., self._n : 2 * self._n]

    def _control(self, t: np.ndarray) -> np.ndarray:
        y, i = self._y(t)
        shape = y.shape[:-1]
        Y = y.reshape(-1, y.shape[-1])
        modes = self._modes[i]
        out = np.empty((Y.shape[0], self.system.law.nu))
        for m in unique(modes):
            sel = np.flatnonzero(modes == m)
            out[sel] = np.asarray(self._mapped(self.system.control, sel.size)(Y[sel].T, m, self.full_parameters)).T
        return out.reshape(shape + (out.shape[-1],))
