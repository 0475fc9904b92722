"""Progress bars for long work (continuations, restarts, sweeps), in the terminal, never in a notebook.

A bar is drawn on the terminal of the process that runs the work: for a notebook, its kernel's
original standard error, which is the terminal of ``make reproduce`` or of ``make lab`` (ipykernel
sends what the kernel writes to its own ``sys.stderr`` into the notebook; the bars bypass it). A bar
under a cell would be stored with the notebook, and JupyterLab keeps what a cleared bar leaves (a line
of spaces, the cursor moves of nested bars), so a notebook run and saved in Lab would differ from the
stored one. ``OCPKIT_PROGRESS=off`` (nbval, tests) draws no bars; ``terminal`` (set by
:mod:`compendium.notebooks` for headless runs) or unset draws them.
"""

from __future__ import annotations

import io
import os
import sys
from contextlib import contextmanager

from tqdm import tqdm

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
