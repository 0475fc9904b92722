"""One trajectory type for direct and indirect results.

A :class:`Trajectory` is a problem's state, control and (where the method gives
them) costates as functions of time on ``[t0, tf]``, with the times where the
control may jump (``breakpoints``: segment ends of a transcription, switching
times of a shooting). Every trajectory can be sampled into a DataFrame, re-integrated
(the dynamics flown with its control, from its initial state, by an independent
integrator), compared with another trajectory of the same problem and drawn (:meth:`Trajectory.plot`).

:class:`~ocpkit.solution.Solution` (direct transcriptions) and
:class:`~ocpkit.shooting.trajectory.ShootingTrajectory` (indirect shooting) implement it.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Sequence

    import pandas as pd
    from matplotlib.figure import Figure
    from numpy.typing import ArrayLike

    from .statement import OptimalControlProblem


@dataclass
class Reintegration:
    """The control re-integrated with an adaptive integrator (scipy DOP853).

    ``error[k, j]`` is the integrated state minus the trajectory's state at ``t[k]``.
    """

    t: np.ndarray
    states: np.ndarray
    error: np.ndarray
    state_names: list[str]
    #: each state's scale (or one row of them per time, where the scales change along the trajectory's phases)
    scale: np.ndarray
    rtol: float
    atol: float
    n_rhs: int

    @property
    def max_error_by_state(self) -> dict[str, float]:
        """Largest absolute error of each state, in its own units."""
        return dict(zip(self.state_names, np.abs(self.error).max(axis=0).tolist()))

    @property
    def max_error(self) -> float:
        """Largest absolute error over all states, in units of each state's scale."""
        return float((np.abs(self.error) / self.scale).max())


class Trajectory(ABC):
    """State, control and costates of a problem as functions of time (see the module docstring).

    Subclasses provide ``problem``, ``t0``, ``tf``, ``objective`` (the cost as the method
    computed it), ``breakpoints`` (increasing, from t0 to tf inclusive) and the evaluators ``_state``, ``_control`` (and
    ``_costate`` where available).
    """

    problem: OptimalControlProblem
    t0: float
    tf: float
    objective: float
    breakpoints: np.ndarray
    #: what ``objective`` is, as a figure's title names it (:meth:`plot`)
    objective_label: ClassVar[str] = "objective"

    # -- to be provided --------------------------------------------------------------------
    @abstractmethod
    def _state(self, t: np.ndarray) -> np.ndarray: ...

    @abstractmethod
    def _control(self, t: np.ndarray) -> np.ndarray: ...

    def _costate(self, t: np.ndarray) -> np.ndarray:
        raise ValueError(f"{type(self).__name__} provides no costates")

    @property
    def has_costates(self) -> bool:
        return False

    def _raw_control(self, t: np.ndarray) -> np.ndarray:
        """The control as the method represents it (a transcription's polynomial, overshoots included)."""
        return self._control(t)

    @property
    def state_names(self) -> list[str]:
        """The states' names, in the order of :meth:`~ocpkit.trajectory.Trajectory.state`'s last axis."""
        return self.problem.state_names

    @property
    def control_names(self) -> list[str]:
        """The controls' names, in the order of :meth:`~ocpkit.trajectory.Trajectory.control`'s last axis."""
        return self.problem.control_names

    def initial_state(self) -> np.ndarray:
        """x(t0), where re-integration starts."""
        return np.asarray(self.state(np.array(self.t0)), dtype=float).ravel()

    # -- evaluation ---------------------------------------------------------------------------
    def state(self, t: ArrayLike) -> np.ndarray:
        """States at times ``t`` (shape ``t.shape + (nx,)``)."""
        return self._state(self._check_times(t))

    def control(self, t: ArrayLike) -> np.ndarray:
        """Controls at times ``t`` (shape ``t.shape + (nu,)``), within the control bounds."""
        return self._control(self._check_times(t))

    def costate(self, t: ArrayLike) -> np.ndarray:
        """Costates at times ``t`` (shape ``t.shape + (nx,)``), where the method gives them."""
        return self._costate(self._check_times(t))

    def _check_times(self, t: ArrayLike) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        span = self.tf - self.t0
        if np.any(t < self.t0 - 1e-12 * span) or np.any(t > self.tf + 1e-12 * span):
            raise ValueError(f"times must lie in [t0, tf] = [{self.t0}, {self.tf}]")
        return np.clip(t, self.t0, self.tf)

    def time_grid(self, n: int = 401) -> np.ndarray:
        if n < 2:
            raise ValueError("a time grid needs at least 2 points")
        return np.linspace(self.t0, self.tf, n)

    def to_dataframe(self, t: ArrayLike | None = None, n: int = 401, costates: bool = False) -> pd.DataFrame:
        """Time histories on ``t`` (default: ``n`` equally spaced points) as a DataFrame.

        Columns ``t``, the states, the controls and, with ``costates=True``, ``lambda_<state>``.
        """
        import pandas as pd

        t = self.time_grid(n) if t is None else np.asarray(t, dtype=float)
        data = {"t": t}
        data.update(dict(zip(self.state_names, self.state(t).T)))
        data.update(dict(zip(self.control_names, self.control(t).T)))
        if costates:
            data.update({f"lambda_{k}": v for k, v in zip(self.state_names, self.costate(t).T)})
        return pd.DataFrame(data)

    def plot(
        self,
        which: str | Sequence[str] | None = None,
        *,
        names: str | Sequence[str] | None = None,
        n: int = 401,
        figsize: tuple[float, float] | None = None,
        fig: Figure | None = None,
    ) -> Figure:
        """A matplotlib figure of this trajectory (matplotlib is needed: ``pip install matplotlib``).

        One axes per state, per control, per costate (where the trajectory has them, ``has_costates``) and per
        path constraint's expression, each drawn on ``n`` points per phase; a direct solution's points (its scheme's
        nodes) as dots on it and its mesh breakpoints as ticks along the bottom; finite bounds and path-constraint
        limits dashed (where within the span of the values from them); the phases' boundaries as solid lines
        (a solution of several phases, each phase on its own interval, its own bounds), an indirect trajectory's
        breakpoints dotted (the events of its switching functions, where the control may switch, and its junctions); the title names the problem, the method and the objective.

        ``which``: the groups drawn, some of ``"states"``, ``"controls"``, ``"costates"``, ``"constraints"``
        (default every group the trajectory has, but only states and controls where all would make more than
        :data:`~ocpkit.plotting.CROWDED` axes, as the title then says); ``names``: only these states, controls and
        path constraints (a
        state's costate with it); ``figsize``: inches (default from the number of axes); ``fig``: an empty figure
        or subfigure to draw into. Returns the figure. A notebook shows it once, as a cell's value (``sol.plot()``
        last in a cell; after ``fig = sol.plot()``, ``fig``; a trailing ``;`` hides it); a script saves it with
        ``fig.savefig(...)``, or shows it with ``plt.show()`` under a window backend (:mod:`ocpkit.plotting`).
        """
        from .plotting import trajectory_figure

        return trajectory_figure(self, which, names=names, n=n, figsize=figsize, fig=fig)

    # -- expressions of the solution --------------------------------------------------------
    def sample(
        self, expr: Callable[..., Any], grid: ArrayLike | None = None, n: int = 401
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(t, values)``: ``expr(x, u, t[, p])`` evaluated along this trajectory, as rockit's ``sol.sample``.

        ``expr`` is written as the problem's callables are (names: ``x["h"]``, ``u["alpha"]``, ``p["k"]``;
        :mod:`ocpkit.names`), ``p`` holding the solved free parameters. ``grid``: the times (default
        ``n`` equally spaced points). ``values`` has shape ``t.shape`` for a scalar expression,
        ``t.shape + (m,)`` for ``m`` of them. The control is the admissible one (:meth:`control`).
        """
        t = self.time_grid(n) if grid is None else self._check_times(grid)
        return t, self.evaluate(expr, t)

    def evaluate(self, expr: Callable[..., Any], t: np.ndarray, extra: dict[str, float] | None = None) -> np.ndarray:
        """``expr(x, u, t[, p])`` at the times ``t`` (:meth:`sample`'s values); ``extra``: parameters by name that
        ``p`` has besides the problem's (a trajectory's parameters that another phase declares)."""
        extra = {} if extra is None else {k: v for k, v in extra.items() if k not in self.problem.parameter_names}
        fun = self.problem.expression(expr, "running", "sample's expression", list(extra))
        m = fun.size1_out(0)
        flat = t.ravel()
        if flat.size == 0:
            return np.zeros(t.shape if m == 1 else t.shape + (m,))
        values = np.concatenate([self.problem.parameter_vector(), np.array(list(extra.values()), dtype=float)])
        P = np.repeat(values[:, None], flat.size, axis=1)
        out = np.asarray(fun.map(flat.size)(self.state(flat).T, self.control(flat).T, flat[None, :], P)).T
        return out.reshape(t.shape) if m == 1 else out.reshape(t.shape + (m,))

    def value(self, what: str | Callable[..., Any]) -> float | np.ndarray:
        """A number of this trajectory: a parameter's value by name (fixed, or free and solved), ``"t0"``, ``"tf"``,
        ``"objective"``, or ``what(x0, xf, t0, tf[, p])`` written as a Mayer term is (a float, or an array
        for several expressions). A state or control is a function of time: :meth:`sample` it."""
        problem = self.problem
        if isinstance(what, str):
            if what in ("t0", "tf", "objective"):
                return float(getattr(self, what))
            if what in problem.parameters:
                return float(problem.parameters[what])
            if what in problem.state_names or what in problem.control_names:
                raise ValueError(
                    f"{what!r} is a function of time: sample(lambda x, u, t: ...) it, or give "
                    f"value(lambda x0, xf, t0, tf: xf[{what!r}]) for its final value"
                )
            raise KeyError(f"unknown name {what!r}; parameters are {list(problem.parameters)}")
        fun = problem.expression(what, "boundary", "value's expression")
        x0, xf = self.state(np.array(self.t0)), self.state(np.array(self.tf))
        out = np.asarray(fun(x0, xf, self.t0, self.tf, problem.parameter_vector())).ravel()
        return float(out[0]) if out.size == 1 else out

    # -- verification -----------------------------------------------------------------------
    def reintegrate(
        self, rtol: float = 1e-12, atol: float = 1e-12, n: int = 2001, controls: str = "bounded"
    ) -> Reintegration:
        """Integrate dx/dt = f(x, u(t), t) from x(t0) with DOP853 and compare with :meth:`state`.

        ``controls="bounded"`` (default) flies the admissible control :meth:`control`:
        how far the flown trajectory lands from this one. ``"interpolant"`` uses the
        method's own representation, overshoots included: how consistent the
        discretisation is. The integration restarts at every breakpoint, so that no
        step straddles a jump or kink of the control. ``atol`` is scaled by each
        state's scale.
        """
        from scipy.integrate import solve_ivp

        if rtol <= 0 or atol <= 0:
            raise ValueError("tolerances must be positive")
        if controls not in ("bounded", "interpolant"):
            raise ValueError(f"controls must be 'bounded' or 'interpolant', got {controls!r}")
        control = self.control if controls == "bounded" else self._raw_control
        problem = self.problem
        scale = problem.state_scale
        bp = np.asarray(self.breakpoints, dtype=float)
        t_eval = np.union1d(self.time_grid(n), bp)
        out = np.empty((t_eval.size, problem.nx))
        x = self.initial_state()
        n_rhs = 0
        for a, b in zip(bp[:-1], bp[1:]):
            # the control of this interval up to its end (piecewise controls may jump at b)
            b_left = np.nextafter(b, a)

            def rhs(t: float, y: np.ndarray, b_left: float = b_left) -> np.ndarray:
                return np.asarray(problem.dynamics(y, control(np.array(min(t, b_left))), t)).ravel()

            mask = (t_eval >= a) & (t_eval <= b)
            sol = solve_ivp(rhs, (a, b), x, method="DOP853", rtol=rtol, atol=atol * scale, dense_output=True)
            if sol.status != 0:
                raise RuntimeError(f"re-integration failed on [{a}, {b}]: {sol.message}")
            n_rhs += sol.nfev
            out[mask] = sol.sol(t_eval[mask]).T
            x = sol.y[:, -1]
        err = out - self.state(t_eval)
        return Reintegration(
            t=t_eval,
            states=out,
            error=err,
            state_names=problem.state_names,
            scale=scale,
            rtol=rtol,
            atol=atol,
            n_rhs=n_rhs,
        )

    def difference(self, other: Trajectory, n: int = 2001) -> dict[str, float]:
        """Largest difference of each variable from ``other``, in percent of ``other``'s magnitude.

        For each state and control ``v``: ``100 max_k |v(s_k) - v_other(s_k)| / max_k |v_other(s_k)|``
        over ``n`` points ``s_k`` equally spaced in normalised time ``s = (t - t0) / (tf - t0)``
        (each trajectory on its own final time, so that a final-time difference does
        not pose as a state difference). Also ``"states"`` and ``"controls"``: the
        largest over each group, and ``"tf"``: the final-time difference in percent of
        ``other``'s duration.
        """
        if n < 2:
            raise ValueError("n must be at least 2")
        states, controls = self.state_names, self.control_names
        if states != other.state_names or controls != other.control_names:
            raise ValueError("trajectories of problems with different variables cannot be compared")
        s = np.linspace(0.0, 1.0, n)

        def at(tr: Trajectory) -> tuple[np.ndarray, np.ndarray]:
            t = tr.t0 + s * (tr.tf - tr.t0)
            return tr.state(t), tr.control(t)

        xa, ua = at(self)
        xb, ub = at(other)
        out = {}
        for names, a, b in ((states, xa, xb), (controls, ua, ub)):
            for j, name in enumerate(names):
                scale = np.abs(b[:, j]).max()
                out[name] = float(100 * np.abs(a[:, j] - b[:, j]).max() / scale) if scale > 0 else float("nan")
        out["states"] = max(out[k] for k in states)
        out["controls"] = max((out[k] for k in controls), default=float("nan"))
        out["tf"] = float(100 * abs(self.tf - other.tf) / abs(other.tf - other.t0))
        return out
