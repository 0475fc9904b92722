"""Figures of results: what :meth:`Trajectory.plot <ocpkit.trajectory.Trajectory.plot>`,
:meth:`Solution.plot_refinement <ocpkit.solution.Solution.plot_refinement>` and the indirect results' ``plot()``
draw.

matplotlib is not a dependency of ocpkit: it is imported when a figure is drawn, and its absence is an ImportError
that says how to install it. Each figure is made with pyplot (so that a notebook's inline backend renders it). Under
the inline backend and the file backends (Agg, the default without a display) it is closed in pyplot at once: a
notebook shows it exactly once, as the value of the cell that returns it (``fig = sol.plot()`` shows nothing until
``fig`` is a cell's value), a script saves it (``fig.savefig("name.png")``), and a loop of plots leaves no figure open
behind it. Under a window backend (QtAgg, TkAgg, ...) it stays open, and ``plt.show()`` shows it.

Every line the figures mark times or limits with carries a ``gid``: ``"bound"`` (a finite bound of a state or a
control, a limit of a path constraint, dashed), ``"phase boundary"`` (where a phase starts, solid grey),
``"switching"`` (an indirect trajectory's switching times and junctions, dotted), ``"mesh"`` (a direct solution's
mesh breakpoints, ticks along the bottom of each axes), ``"nodes"`` (the points of a direct solution: its scheme's
state, control, costate and path-constraint points), ``"tolerance"`` (a refinement's tolerance).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from .trajectory import Trajectory

__all__ = ["CROWDED", "GROUPS", "refinement_figure", "trajectory_figure"]

#: the groups of axes a trajectory's figure may hold, in its order
GROUPS = ("states", "controls", "costates", "constraints")
#: above this many axes, a figure drawn with neither ``which`` nor ``names`` leaves costates and path constraints out
#: (and says so in its title)
CROWDED = 16

_COLOURS = {"states": "#1f5fa8", "controls": "#d1495b", "costates": "#2a9d8f", "constraints": "#e9a23b"}
_ARC_COLOURS = {
    "lower": "#1f5fa8",
    "upper": "#d1495b",
    "zero": "0.6",
    "singular": "#2a9d8f",
    "regular": "#e9a23b",
    "boundary": "#6d597a",
}


def _pyplot() -> Any:
    """``matplotlib.pyplot``, or an ImportError that says how to install matplotlib."""
    try:
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise ImportError(
            "plotting a result needs matplotlib, which ocpkit does not install: pip install matplotlib (or pip "
            'install "ocpkit[plot]")'
        ) from exc
    return plt


#: backends that draw into files or a notebook's cell output, not a window: their figures are closed in pyplot
_NOT_WINDOWS = ("agg", "cairo", "pdf", "pgf", "ps", "svg", "template")


def _new_figure(figsize: tuple[float, float]) -> Figure:
    """A pyplot figure with a constrained layout, closed in pyplot unless a window backend shows it (module
    docstring)."""
    plt = _pyplot()
    fig = plt.figure(figsize=figsize, layout="constrained")
    backend = plt.get_backend().lower()
    if "inline" in backend or backend in _NOT_WINDOWS:
        plt.close(fig)
    return fig


def _empty(fig: Figure) -> Figure:
    if fig.axes:
        raise ValueError(
            "fig already holds axes: give an empty figure (plt.figure()) or a subfigure (fig.add_subfigure(...))"
        )
    return fig


# -- a trajectory -----------------------------------------------------------------------------------------------------
class _Axis:
    """One axes of a trajectory's figure: its group, its name, and where each piece (phase) holds it (its index in
    the piece's variables, or in its path constraints' labels)."""

    def __init__(self, group: str, name: str) -> None:
        self.group, self.name = group, name
        self.where: dict[int, int] = {}


def _pieces(trajectory: Trajectory) -> list[Trajectory]:
    """The phases of a solution of several (each drawn on its own interval), else the trajectory itself."""
    phases = getattr(trajectory, "phases", None)
    return list(phases) if phases is not None and len(phases) > 1 else [trajectory]


def _path_labels(piece: Trajectory) -> list[str]:
    path = piece.problem.functions.path
    return [] if path is None else list(path.labels)


def _axes_of(pieces: list[Trajectory], groups: Sequence[str]) -> list[_Axis]:
    axes: dict[tuple[str, str], _Axis] = {}
    for group in GROUPS:
        if group not in groups:
            continue
        for k, piece in enumerate(pieces):
            if group in ("states", "costates"):
                names = piece.problem.state_names if group == "states" or piece.has_costates else []
            elif group == "controls":
                names = piece.problem.control_names
            else:
                names = _path_labels(piece)
            for j, name in enumerate(names):
                label = f"lambda_{name}" if group == "costates" else name
                axes.setdefault((group, label), _Axis(group, label)).where[k] = j
    return list(axes.values())


def _selected(
    axes: list[_Axis], names: Sequence[str] | None, pieces: list[Trajectory], which: Sequence[str]
) -> list[_Axis]:
    """The axes of ``names`` (states, controls, path constraints; a state's costate comes with it)."""
    if names is None:
        return axes
    if isinstance(names, str):
        names = [names]
    choices: list[str] = []
    for piece in pieces:
        for name in [*piece.problem.state_names, *piece.problem.control_names, *_path_labels(piece)]:
            if name not in choices:
                choices.append(name)
        path = piece.problem.functions.path
        choices += [n for n in (path.names if path is not None else ()) if n not in choices]
    if not names:
        raise ValueError(f"names= lists no name: give some of {choices}, or leave it out to draw them all")
    for name in names:
        if name not in choices:
            raise ValueError(f"unknown name {name!r} in names=: the trajectory's names are {choices}")
    wanted = set(names)

    def keep(axis: _Axis) -> bool:
        if axis.group == "costates":
            return axis.name.removeprefix("lambda_") in wanted
        return axis.name in wanted or axis.name.split("[")[0] in wanted

    out = [a for a in axes if keep(a)]
    if not out:
        raise ValueError(f"names={list(names)} are in none of the groups drawn, which={list(which)}")
    return out


def _groups(trajectory: Trajectory, pieces: list[Trajectory], which: str | Sequence[str] | None) -> list[str]:
    available = ["states"]
    if any(p.problem.nu for p in pieces):
        available.append("controls")
    if any(p.has_costates for p in pieces):
        available.append("costates")
    if any(_path_labels(p) for p in pieces):
        available.append("constraints")
    if which is None:
        return available
    asked = [which] if isinstance(which, str) else list(which)
    if not asked:
        raise ValueError(f"which= names no group: give some of {available}, or leave it out to draw them all")
    for group in asked:
        if group not in GROUPS:
            raise ValueError(f"unknown group {group!r} in which=: the groups are {list(GROUPS)}")
        if group not in available:
            raise ValueError(f"this {type(trajectory).__name__} has no {group} to draw: which= takes {available} here")
    return asked


def _bound(ax: Axes, value: float, t0: float, tf: float, values: np.ndarray) -> None:
    """A dashed line at a finite bound over ``[t0, tf]``, where it lies within the larger of the values' span and
    magnitude of them (a bound farther away would flatten the curve to a line)."""
    if not np.isfinite(value) or values.size == 0 or not np.all(np.isfinite(values)):
        return
    lo, hi = float(values.min()), float(values.max())
    reach = max(hi - lo, abs(lo), abs(hi), 1e-12)
    if lo - reach <= value <= hi + reach:
        ax.plot([t0, tf], [value, value], ls="--", lw=0.9, color="0.35", gid="bound")


def _draw_axis(ax: Axes, axis: _Axis, pieces: list[Trajectory], grids: list[np.ndarray]) -> None:
    colour = _COLOURS[axis.group]
    for k, j in axis.where.items():
        piece, t = pieces[k], grids[k]
        problem = piece.problem
        nodes: tuple[Any, Any] | None = None
        bounds: tuple[float, float] = (np.inf, np.inf)
        if axis.group == "states":
            values = piece.state(t)[:, j]
            nodes = (getattr(piece, "state_times", None), getattr(piece, "state_values", None))
            bounds = (problem.states[j].lower, problem.states[j].upper)
        elif axis.group == "controls":
            values = piece.control(t)[:, j]
            nodes = (getattr(piece, "control_times", None), getattr(piece, "control_values", None))
            bounds = (problem.controls[j].lower, problem.controls[j].upper)
        elif axis.group == "costates":
            values = piece.costate(t)[:, j]
            nodes = (getattr(piece, "costate_times", None), getattr(piece, "costate_values", None))
        else:
            path = problem.functions.path
            assert path is not None  # (an axis of this group is a path constraint's)
            X, U = piece.state(t), piece.control(t)
            P = np.repeat(problem.parameter_vector()[:, None], t.size, axis=1)
            values = np.asarray(path.function.map(t.size)(X.T, U.T, t[None, :], P))[j]
            nodes = (getattr(piece, "path_times", None), getattr(piece, "path_values", None))
            bounds = (float(path.lower[j]), float(path.upper[j]))
        ax.plot(t, values, color=colour, lw=1.4)
        if nodes[0] is not None and nodes[1] is not None:
            ax.plot(nodes[0], np.asarray(nodes[1])[:, j], ".", color=colour, ms=3.5, gid="nodes")
        for b in bounds:
            _bound(ax, float(b), float(t[0]), float(t[-1]), values)
    ax.set_title(axis.name, fontsize=10)
    lo, hi = ax.dataLim.intervaly
    if np.isfinite(lo) and np.isfinite(hi) and hi - lo <= 1e-9 * max(abs(lo), abs(hi)):
        # a constant (a costate of a state no function reads): its rounding noise is not a curve
        pad = 0.05 * max(abs(lo), abs(hi))
        ax.set_ylim(lo - pad, hi + pad)
    unit = ""
    if axis.group in ("states", "controls"):
        k, j = next(iter(axis.where.items()))
        variables = pieces[k].problem.states if axis.group == "states" else pieces[k].problem.controls
        unit = variables[j].unit
    if unit:
        ax.set_ylabel(unit)


def _times(ax: Axes, pieces: list[Trajectory]) -> None:
    """Phase boundaries; a direct solution's mesh breakpoints (ticks), an indirect one's switching times."""
    for piece in pieces[1:]:
        ax.axvline(piece.t0, color="0.45", lw=1.0, gid="phase boundary")
    for piece in pieces:
        inner = np.asarray(piece.breakpoints, dtype=float)[1:-1]
        if getattr(piece, "state_times", None) is not None:
            ax.plot(
                np.asarray(piece.breakpoints, dtype=float),
                np.full(len(piece.breakpoints), 0.0),
                ls="none",
                marker=2,  # a tick up from the bottom edge, inside the axes
                color="0.55",
                ms=5,
                transform=ax.get_xaxis_transform(),
                clip_on=False,
                gid="mesh",
            )
        else:
            for t in inner:
                ax.axvline(t, color="k", ls=":", lw=0.8, gid="switching")


def trajectory_figure(
    trajectory: Trajectory,
    which: str | Sequence[str] | None = None,
    *,
    names: str | Sequence[str] | None = None,
    n: int = 401,
    figsize: tuple[float, float] | None = None,
    fig: Figure | None = None,
    title: str | None = None,
    arcs: Mapping[str, Sequence[tuple[str, float, float]]] | None = None,
) -> Figure:
    """The figure of :meth:`Trajectory.plot <ocpkit.trajectory.Trajectory.plot>` (its arguments); ``title``
    replaces the default one, ``arcs`` shades each named control's arcs, ``(kind, start, end)`` each, in the colour
    of their kind (:data:`ocpkit.structure.ARC_KINDS`), with a legend."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"n must be a whole number of points per phase, at least 2, got {n!r}")
    pieces = _pieces(trajectory)
    groups = _groups(trajectory, pieces, which)
    axes = _selected(_axes_of(pieces, groups), names, pieces, groups)
    left_out = [g for g in groups if g in ("costates", "constraints")] if which is None and names is None else []
    if len(axes) > CROWDED and left_out:  # a large problem: its states and controls, and how to see the rest
        groups = [g for g in groups if g not in left_out]
        axes = _selected(_axes_of(pieces, groups), None, pieces, groups)
    else:
        left_out = []
    ncols = 1 if len(axes) == 1 else 2 if len(axes) in (2, 4) else 3
    nrows = -(-len(axes) // ncols)
    fig = _new_figure(figsize or (3.6 * ncols, 2.4 * nrows + 0.5)) if fig is None else _empty(fig)
    grid = fig.subplots(nrows, ncols, sharex=True, squeeze=False)
    grids = [np.linspace(p.t0, p.tf, n) for p in pieces]
    for k, axis in enumerate(axes):
        ax = grid.flat[k]
        _draw_axis(ax, axis, pieces, grids)
        _times(ax, pieces)
        if arcs and axis.group == "controls" and axis.name in arcs:
            seen: set[str] = set()
            for kind, a, b in arcs[axis.name]:
                base = kind.split(" ")[0]
                ax.axvspan(
                    a, b, color=_ARC_COLOURS.get(base, "0.8"), alpha=0.15, lw=0, label=None if kind in seen else kind
                )
                seen.add(kind)
            ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.3)
    for ax in grid.flat[len(axes) :]:
        ax.remove()
    for k, ax in enumerate(grid.flat[: len(axes)]):
        if k + ncols >= len(axes):  # the last axes of its column
            ax.set_xlabel("t")
            ax.tick_params(labelbottom=True)
    if len(pieces) > 1:
        top = grid.flat[0]
        for piece in pieces:
            top.text(
                0.5 * (piece.t0 + piece.tf),
                0.97,
                str(getattr(piece, "name", "")),
                transform=top.get_xaxis_transform(),
                ha="center",
                va="top",
                fontsize=7,
                color="0.35",
            )
    heading = title if title is not None else _title(trajectory, pieces)
    if left_out:
        heading += f"\n({' and '.join(left_out)} left out, {len(axes)} axes already: plot(which=...) draws them)"
    fig.suptitle(heading, fontsize=11)
    return fig


def _title(trajectory: Trajectory, pieces: list[Trajectory]) -> str:
    if len(pieces) > 1:
        name = "phases " + ", ".join(str(getattr(p, "name", p.problem.name)) for p in pieces)
    else:
        name = trajectory.problem.name
    method = getattr(trajectory, "transcription", None) or type(trajectory).__name__
    if trajectory.objective_label != "objective":  # a phase of a solution: its own share
        return f"{name}: {trajectory.objective_label} {trajectory.objective:.8g}\n{method}"
    if getattr(trajectory, "converged", True) is False:
        return f"{name}: NOT CONVERGED ({getattr(trajectory, 'status', '?')}), objective {trajectory.objective:.8g}\n{method}"
    return f"{name}: objective {trajectory.objective:.8g}\n{method}"


# -- a refinement ----------------------------------------------------------------------------------------------------
def refinement_figure(
    history: Sequence[Any],
    tolerance: float,
    *,
    title: str = "mesh refinement",
    figsize: tuple[float, float] | None = None,
    fig: Figure | None = None,
) -> Figure:
    """The figure of :meth:`Solution.plot_refinement <ocpkit.solution.Solution.plot_refinement>`: from a
    refinement's ``history`` (:class:`~ocpkit.program.solve.MeshIteration` s), each mesh's intervals and collocation
    points, its state error estimate against ``tolerance`` (logarithmic) and, on a mesh whose state part met it, the
    largest other part that did not (named: the objective, a path constraint), and its interval boundaries over
    normalised time (one row of ticks per mesh: each mesh's intervals are fractions of its own horizon)."""
    if not history:
        raise ValueError("a refinement's figure needs at least one mesh iteration")
    fig = _new_figure(figsize or (8.0, 5.5)) if fig is None else _empty(fig)
    from matplotlib.ticker import MaxNLocator  # (matplotlib is there: the figure is)

    spec = fig.add_gridspec(2, 2, height_ratios=[1.0, 1.3])
    size, error, mesh = fig.add_subplot(spec[0, 0]), fig.add_subplot(spec[0, 1]), fig.add_subplot(spec[1, :])
    k = np.array([m.iteration for m in history])
    size.plot(k, [m.fractions.size for m in history], "o-", color=_COLOURS["states"], label="intervals")
    size.plot(k, [m.collocation_points for m in history], "s-", color=_COLOURS["controls"], label="collocation points")
    size.set_xlabel("mesh iteration")
    size.set_title("mesh size", fontsize=10)
    size.legend(fontsize=7)
    estimate = np.array([m.error_estimate for m in history], dtype=float)
    error.semilogy(k, estimate, "o-", color=_COLOURS["states"], label="state error estimate")
    over = [m for m in history if m.failing and np.isfinite(m.worst)]
    if over:  # the state part met the tolerance there, another part did not: it drove the next mesh
        error.semilogy(
            [m.iteration for m in over],
            [m.worst for m in over],
            "^",
            color=_COLOURS["constraints"],
            gid="failing",
            label="largest other part over the tolerance",
        )
        for m in over:
            error.annotate(
                ", ".join(m.failing), (m.iteration, m.worst), xytext=(6, -9), textcoords="offset points", fontsize=7
            )
    error.axhline(tolerance, color="0.35", ls="--", lw=0.9, gid="tolerance", label=f"tolerance {tolerance:.0e}")
    error.set_xlabel("mesh iteration")
    error.set_title("error estimate", fontsize=10)
    error.legend(fontsize=7)
    for ax in (size, error):
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.grid(alpha=0.3)
    bounds = [np.concatenate([[0.0], np.cumsum(m.fractions)]) for m in history]
    mesh.eventplot(bounds, lineoffsets=k.tolist(), linelengths=0.7, colors=_COLOURS["states"], linewidths=0.8)
    mesh.set_xlabel("(t - t0) / (tf - t0)")
    mesh.set_ylabel("mesh iteration")
    mesh.set_title("interval boundaries of each mesh", fontsize=10)
    mesh.set_xlim(-0.02, 1.02)
    mesh.yaxis.set_major_locator(MaxNLocator(integer=True))
    fig.suptitle(title, fontsize=11)
    return fig
