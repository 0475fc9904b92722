"""One house style for every figure, deterministic PNG/PDF output, and the note a figure of a run with other
parameters than the published run's carries (:func:`run_note`, :func:`note_figures`)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib as mpl
import matplotlib.pyplot as plt
import numpy as np

STYLE = {
    "figure.figsize": (6.4, 4.0),
    "figure.dpi": 110,
    "savefig.dpi": 150,
    "savefig.bbox": "tight",
    "font.size": 10,
    "axes.titlesize": 11,
    "axes.labelsize": 10,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "legend.frameon": False,
    "lines.linewidth": 1.6,
    "axes.prop_cycle": mpl.cycler(color=["#1f5fa8", "#d1495b", "#2a9d8f", "#e9a23b", "#6d597a", "#3d405b"]),
    "pdf.fonttype": 42,
    "svg.hashsalt": "ocpkit",
}

# Metadata that would otherwise carry versions or timestamps into the files
_PNG_METADATA = {"Software": None}
_PDF_METADATA = {"Creator": None, "Producer": None, "CreationDate": None, "ModDate": None}


def use_style() -> None:
    """Apply the compendium's matplotlib style."""
    mpl.rcParams.update(STYLE)


#: the ``gid`` of the note :func:`add_note` writes on a figure (one note per figure)
NOTE_GID = "compendium-run-note"
_NOTE_HOOK = "compendium.plotting:_note_new_figure"
#: the note :func:`note_figures` puts on every figure pyplot creates from now on (``None``: none)
_run_note: str | None = None


def run_note(changed: dict, published: dict, meanings: dict | None = None, width: int = 110) -> str:
    """The note of a run whose parameters ``changed`` (name -> value) differ from the published run's
    (``published``, name -> value): ``Not the published run: thrust_to_weight = 2.5 (published: None, the paper's)``,
    with what a ``None`` stands for where ``meanings`` (name -> text,
    :func:`compendium.notebook_source.none_meanings`) says it, long values cut short, wrapped at ``width``
    characters."""
    import reprlib
    import textwrap

    short = reprlib.Repr()
    short.maxstring = short.maxother = 40
    short.maxlist = short.maxtuple = short.maxdict = 6
    meanings = meanings or {}

    def shown(name: str, value) -> str:
        return f"None, {meanings[name]}" if value is None and name in meanings else short.repr(value)

    parts = [f"{k} = {shown(k, v)} (published: {shown(k, published.get(k))})" for k, v in changed.items()]
    return "\n".join(textwrap.wrap("Not the published run: " + "; ".join(parts), width, break_long_words=False))


def add_note(fig: plt.Figure, note: str) -> None:
    """Write ``note`` above the figure's top left corner, small and in orange (once: a figure that carries it is
    left as it is). A figure-level text: :mod:`compendium.figure_data` does not record it, so the guard compares the
    figure's data as without it; ``savefig.bbox = "tight"`` and the inline backend keep it in the picture."""
    if any(t.get_gid() == NOTE_GID for t in fig.texts):
        return
    fig.text(0.0, 1.0, note, ha="left", va="bottom", fontsize=8, color="#b35c00", gid=NOTE_GID)


def note_figures(note: str | None) -> None:
    """From now on, every figure pyplot creates in this process carries ``note`` (:func:`add_note`), through
    matplotlib's ``figure.hooks``: a notebook's inline figures say what its saved ones say. ``None``: no note."""
    global _run_note
    _run_note = note
    hooks = [h for h in mpl.rcParams["figure.hooks"] if h != _NOTE_HOOK]
    mpl.rcParams["figure.hooks"] = hooks + ([_NOTE_HOOK] if note is not None else [])


def noted(fig: plt.Figure) -> plt.Figure:
    """``fig`` with the note :func:`note_figures` set, if one is (a figure made without pyplot has none else)."""
    if _run_note is not None:
        add_note(fig, _run_note)
    return fig


def _note_new_figure(fig: plt.Figure) -> None:
    noted(fig)


def save_figure(fig: plt.Figure, name: str, folder: Path | str, formats: Sequence[str] = ("png", "pdf")) -> list[Path]:
    """Write ``<folder>/<name>.<fmt>`` with metadata that does not change between runs (byte-deterministic).

    Notebooks do not call this directly: :meth:`compendium.outputs.Outputs.figure` decides the folder. A figure
    that carries a run's note (:func:`add_note`, above the figure) is saved with a tight bounding box, whatever
    ``savefig.bbox`` says, so that the note is in the picture.
    """
    if not name or "/" in name or "\\" in name:
        raise ValueError(f"figure name must be a plain file stem, got {name!r}")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    tight = {"bbox_inches": "tight"} if any(t.get_gid() == NOTE_GID for t in fig.texts) else {}
    out = []
    for fmt in formats:
        path = folder / f"{name}.{fmt}"
        if fmt == "png":
            meta = _PNG_METADATA
        elif fmt == "pdf":
            meta = _PDF_METADATA
        else:
            raise ValueError(f"unsupported figure format {fmt!r}")
        fig.savefig(path, format=fmt, metadata=meta, **tight)
        out.append(path)
    return out


def floored(values, floor: float) -> np.ndarray:
    """``|values|`` drawn against a stated floor: a value below it (rounding noise, whose digits differ between
    machines) is drawn at the floor, so that the picture is the same on every machine. The floor is the one the
    value's class states in ``notebooks/contract.toml``; :func:`draw_floor` shows it."""
    return np.maximum(np.abs(np.asarray(values, dtype=float)), floor)


def draw_floor(ax, floor: float, what: str = "rounding level") -> None:
    """A dotted line at ``floor`` on a logarithmic axis, labelled: values of :func:`floored` below it sit on it."""
    ax.axhline(floor, color="0.55", lw=0.8, ls=":", zorder=0, label=f"{what} ({floor:.0e}): values below drawn on it")


def time_histories(
    t,
    data,
    columns: Sequence[str],
    labels: Sequence[str],
    ylabel: str,
    title: str,
    xlabel: str = "t (non-dimensional)",
    markers=None,
) -> plt.Figure:
    """Time histories of ``data[column]`` against ``t`` (one line each), with optional markers.

    ``markers``: ``(times, values)``, values indexable by column (the NLP's parameters).
    """
    fig, ax = plt.subplots()
    for col, lab in zip(columns, labels):
        (line,) = ax.plot(t, data[col], label=lab)
        if markers is not None:
            ax.plot(markers[0], markers[1][col], ".", color=line.get_color(), ms=4)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    if len(columns) > 1:
        ax.legend()
    return fig


ARC_COLOURS = {"lower": "C0", "upper": "C3", "zero": "C7", "singular": "C2", "regular": "C1", "boundary": "C4"}


def _junction_times(trajectory, reach: float = 0.01, kinds=None, control: int | None = None):
    """A junction read from an extremal's control samples moved to the extremal's own junction nearest it, within
    ``reach`` of the horizon: an arc's end or a switching time, which the shooting converged
    (``trajectory.breakpoints``). Reading the samples locates a junction of a singular arc only to the sampling
    grid, and where exactly on it depends on rounding (catalyst mixing's, 1e-4 off, moved by 2.5e-5 from one machine
    to another). Given the shooting's arc types (``kinds``, one :class:`ocpkit.shooting.arcs.ArcType` per arc
    between the breakpoints) and a control's index, only that control's junctions are candidates: the breakpoints
    where its kind or the active inequality changes, and the ends, never another control's switch nearby."""
    exact = np.asarray(getattr(trajectory, "breakpoints", [trajectory.t0, trajectory.tf]), dtype=float)
    if kinds is not None and control is not None and len(kinds) == len(exact) - 1:
        own = [k for k in range(1, len(exact) - 1) if _changes(kinds[k - 1], kinds[k], control)]
        exact = exact[[0, *own, len(exact) - 1]]
    span = reach * (trajectory.tf - trajectory.t0)

    def at(t: float) -> float:
        nearest = exact[np.argmin(np.abs(exact - t))]
        return float(nearest) if abs(nearest - t) <= span else float(t)

    return at


def _changes(before, after, control: int) -> bool:
    """Whether the control's arc ends where the arc type ``before`` gives way to ``after``: its kind changes, or it
    is on a boundary arc on either side and the active inequality changes (another control's does not count)."""
    kind = before.kinds[control], after.kinds[control]
    return kind[0] != kind[1] or ("boundary" in kind and before.constraint != after.constraint)


def arcs_over_control(ax, direct, extremal, control: str, scale: float = 1.0, n: int = 801) -> None:
    """The control history of a direct solution (thin, grey) and of its extremal (:func:`ocpkit.indirect.to_extremal`)
    drawn arc by arc (the extremal's own structure, each junction at the extremal's converged time) in the colour of
    its kind, with a legend of the kinds and the junctions dotted; ``scale`` divides the control (e.g. its maximum)."""
    from ocpkit.structure import control_structure

    i = direct.problem.control_names.index(control)
    t = np.linspace(direct.t0, direct.tf, n)
    ax.plot(t, direct.control(t)[:, i] / scale, color="0.6", lw=0.8, label="direct (Radau)")
    tr = extremal.trajectory
    found = control_structure(tr)
    exact = _junction_times(tr, kinds=getattr(extremal.shooting, "kinds", None), control=i)
    seen = set()
    for arc in found.of(control):
        s = np.linspace(exact(arc.start), exact(arc.end), 200)
        kind = arc.kind if arc.constraint is None else f"boundary ({arc.constraint})"
        ax.plot(s, tr.control(s)[:, i] / scale, color=ARC_COLOURS[arc.kind], lw=2, label=None if kind in seen else kind)
        seen.add(kind)
    for tj in found.junctions(control):
        ax.axvline(exact(tj), color="k", ls=":", lw=0.7)
    ax.set_xlabel("t")
    ax.set_ylabel(control if scale == 1.0 else f"{control} / {scale:g}")
    ax.legend(fontsize=7, loc="best")


def thrust_against_direct(ax, extremal, magnitude: str, n: int = 4001) -> None:
    """A thrust bounded in norm: the extremal's ``|u|`` (thick) over the direct solutions' ``magnitude`` control,
    the first solve (grey) and, where :func:`ocpkit.indirect.to_extremal` re-solved it from the extremal, that
    solution (thin), with the extremal's switching times dotted."""
    tr = extremal.trajectory
    first = extremal.first_direct if extremal.first_direct is not None else extremal.direct
    for sol, style, label in [
        (first, dict(color="0.6", lw=0.8), "direct (Radau), first solve"),
        (extremal.direct if extremal.first_direct is not None else None, dict(lw=0.9), "direct, from the extremal"),
    ]:
        if sol is None:
            continue
        t = np.linspace(sol.t0, sol.tf, n)
        ax.plot(t, sol.control(t)[:, sol.problem.control_names.index(magnitude)], label=label, **style)
    t = np.linspace(tr.t0, tr.tf, n)
    ax.plot(t, np.linalg.norm(tr.control(t), axis=1), color="k", lw=1.6, label="extremal |u|")
    for ts in extremal.shooting.integration.switching_times:
        ax.axvline(ts, color="k", ls=":", lw=0.5)
    ax.set_xlabel("t")
    ax.set_ylabel(f"|u| and {magnitude}")
    ax.legend(fontsize=7, loc="lower left")
