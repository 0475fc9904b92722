"""Progress bars for long work (continuations, restarts, sweeps), in the terminal, never in a notebook.

A bar is drawn on the terminal of the process that runs the work: for a notebook, its kernel's
original standard error, which is the terminal of ``make reproduce`` or of ``make lab`` (ipykernel
sends what the kernel writes to its own ``sys.stderr`` into the notebook; the bars bypass it). A bar
under a cell would be stored with the notebook, and JupyterLab keeps what a cleared bar leaves (a line
of spaces, the cursor moves of nested bars), so a notebook run and saved in Lab would differ from the
stored one. ``OCPKIT_PROGRESS=off`` (nbval, tests) draws no bars; ``terminal`` (set by
:mod:`compendium.notebooks` for headless runs) or unset draws them.

For ``make reproduce``, how long each notebook and all those left are expected to take (:class:`NotebookETA`):
each notebook's time measured by the previous run on this machine, else the one ``notebooks/durations.toml``
gives (:data:`PRIOR_DURATIONS`).
"""

from __future__ import annotations

import io
import os
import sys
from collections.abc import Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from tqdm import tqdm

from . import paths

_TERMINAL = None


def terminal():
    """The process's terminal: the original standard error of an IPython kernel (``sys.stderr.fileno()`` is the
    copy ipykernel keeps of it), else ``sys.__stderr__``."""
    global _TERMINAL
    if _TERMINAL is None:
        try:
            fd = sys.stderr.fileno()
        except (AttributeError, OSError, ValueError, io.UnsupportedOperation):
            _TERMINAL = sys.__stderr__
        else:
            _TERMINAL = sys.__stderr__ if fd == 2 else open(os.dup(fd), "w", buffering=1)  # noqa: SIM115
    return _TERMINAL


def progress(iterable=None, *, total: int | None = None, desc: str | None = None, unit: str = "it") -> tqdm:
    """A tqdm bar over ``iterable`` (or a manual one with ``total``), routed as the module docstring says."""
    mode = os.environ.get("OCPKIT_PROGRESS", "")
    if mode not in ("", "terminal", "off"):
        raise ValueError(f"OCPKIT_PROGRESS must be 'terminal' or 'off' (or unset), got {mode!r}")
    return tqdm(
        iterable,
        total=total,
        desc=desc,
        unit=unit,
        leave=False,
        file=terminal() if mode != "off" else sys.__stderr__,
        disable=mode == "off",
        dynamic_ncols=True,
        mininterval=0.5,
    )


@contextmanager
def continuation_progress(desc: str, parameter: str, log=None):
    """A ``log`` for :func:`ocpkit.shooting.follow`: one bar tick per solved value, showing the value.

    ``log``: a further ``log(value, result, elapsed)`` to call (a study's printed lines).
    """
    bar = progress(desc=desc, unit="step")

    def callback(value, result, elapsed):
        bar.update()
        bar.set_postfix_str(f"{parameter} = {value:.6g}", refresh=False)
        if log is not None:
            log(value, result, elapsed)

    try:
        yield callback
    finally:
        bar.close()


# -- how long each notebook of make reproduce takes ------------------------------------------------------------------

#: seconds each notebook's published run took, the estimate before a run on this machine measured it (notebooks/)
PRIOR_DURATIONS = "durations.toml"


@dataclass(frozen=True)
class Estimate:
    """How long a notebook's run is expected to take, and what says so (``"last run here"``,
    ``"reference machine"``)."""

    seconds: float
    source: str


def prior_durations(folder: Path | None = None) -> dict[str, float]:
    """The seconds :data:`PRIOR_DURATIONS` in ``folder`` (default the notebooks' own) gives each notebook."""
    import tomllib

    path = (folder or paths.notebooks_dir()) / PRIOR_DURATIONS
    if not path.is_file():
        return {}
    return {name: float(seconds) for name, seconds in tomllib.loads(path.read_text()).items()}


def measured_durations(executed: Path, parameters: dict[str, dict]) -> dict[str, float]:
    """papermill's duration of each notebook executed into ``executed`` whose run completed with the parameters
    ``parameters`` gives for its name (the parameters passed to papermill, those of ``notebooks/published.toml`` for
    ``make reproduce``): the previous run's measured time, on this machine."""
    import json

    out = {}
    for name, given in parameters.items():
        try:
            meta = json.loads((executed / f"{name}.ipynb").read_text(encoding="utf-8"))["metadata"]["papermill"]
        except (OSError, ValueError, KeyError, TypeError):
            continue
        complete = meta.get("exception") is None and isinstance(meta.get("duration"), (int, float))
        if complete and meta.get("parameters") == json.loads(json.dumps(given)):
            out[name] = float(meta["duration"])
    return out


def notebook_estimates(names: list[str], measured: dict[str, float], prior: dict[str, float]) -> dict:
    """Each notebook's :class:`Estimate`: its time measured on this machine where known, else the prior; ``None``
    where neither is known."""
    out: dict[str, Estimate | None] = {}
    for name in names:
        if name in measured:
            out[name] = Estimate(measured[name], "last run here")
        elif name in prior:
            out[name] = Estimate(prior[name], "reference machine")
        else:
            out[name] = None
    return out


class NotebookETA:
    """The expected end of the running notebook and of all of them, from per-notebook :class:`Estimate`\\ s (not an
    average over notebooks: one notebook may take most of the time). ``estimates``: in the order they run."""

    def __init__(self, estimates: dict[str, Estimate | None], clock=None):
        import time

        self.estimates, self.clock = dict(estimates), clock or time.time

    def line(self, name: str) -> str:
        """What to show when ``name`` starts: its own estimate and end, and the sum of the estimates of it and every
        notebook after it (their end), in clock times that stay right while the line is not redrawn."""
        import time

        names = list(self.estimates)
        left = names[names.index(name) :]
        now = self.clock()
        own = self.estimates[name]
        known = [self.estimates[n].seconds for n in left if self.estimates[n] is not None]  # type: ignore[union-attr]
        unknown = len(left) - len(known)

        def at(seconds: float) -> str:
            return time.strftime("%H:%M", time.localtime(now + seconds))

        this = (
            f"~{duration(own.seconds)} ({own.source}), until ~{at(own.seconds)}"
            if own is not None
            else "no estimate (no earlier run)"
        )
        if not known:
            return f"{name}: {this}; all {len(left)} left: no estimate"
        total = f"~{duration(sum(known))}" + (f" + {unknown} without an estimate" if unknown else "")
        return f"{name}: {this}; all {len(left)} left: {total}, until ~{at(sum(known))}"


def duration(seconds: float) -> str:
    """Seconds as the runner says them: ``"42 s"``, ``"18 min"``, ``"1 h 07 min"``."""
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{seconds / 60:.0f} min"
    return f"{int(seconds // 3600)} h {seconds % 3600 / 60:02.0f} min"


def longest_first(
    names: list[str],
    estimates: dict[str, Estimate | None],
    jobs: int,
    after: Mapping[str, Sequence[str]] | None = None,
) -> tuple[list[str], float]:
    """The order in which ``jobs`` notebooks run at once (``make reproduce``): the longest expected first (one
    without an estimate counts as the longest), and the wall time that schedule is expected to take: each starts on
    the first process free, once the notebooks ``after`` names for it have ended (those without an estimate count as
    zero in it)."""
    after = after or {}
    known = {n: e.seconds for n, e in estimates.items() if e is not None}
    order = sorted(names, key=lambda n: -known.get(n, float("inf")))
    ends: dict[str, float] = {}
    free = [0.0] * max(jobs, 1)
    waiting = list(order)
    while waiting:
        k = free.index(min(free))
        ready = [
            n for n in waiting if all(d not in names or ends.get(d, float("inf")) <= free[k] for d in after.get(n, ()))
        ]
        if not ready:  # this process waits for the first of those it waits on to end
            pending = [ends[d] for n in waiting for d in after.get(n, ()) if d in ends and ends[d] > free[k]]
            if not pending:
                raise ValueError(f"{', '.join(waiting)} wait on each other")
            free[k] = min(pending)
            continue
        waiting.remove(ready[0])
        ends[ready[0]] = free[k] = free[k] + known.get(ready[0], 0.0)
    return order, max(ends.values(), default=0.0)
