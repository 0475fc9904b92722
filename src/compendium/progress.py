"""Progress bars for long work (continuations, restarts, sweeps), wherever the reader is.

``OCPKIT_PROGRESS`` says where the bars go:

* ``terminal`` (set by :mod:`compendium.notebooks` for headless runs): the kernel process's own
  stderr, which is the terminal of ``make reproduce``; nothing enters the stored notebook;
* ``off`` (nbval, tests): no bars;
* unset (JupyterLab): under the running cell, cleared when the work is done.
"""

from __future__ import annotations

import os
import sys
from contextlib import contextmanager

from tqdm import tqdm


def progress(iterable=None, *, total: int | None = None, desc: str | None = None, unit: str = "it") -> tqdm:
    """A tqdm bar over ``iterable`` (or a manual one with ``total``), routed as the module docstring says."""
    mode = os.environ.get("OCPKIT_PROGRESS", "")
    if mode not in ("", "terminal", "off"):
        raise ValueError(f"OCPKIT_PROGRESS must be 'terminal' or 'off' (or unset), got {mode!r}")
    stream = sys.__stderr__ if mode == "terminal" else sys.stderr
    return tqdm(
        iterable,
        total=total,
        desc=desc,
        unit=unit,
        leave=False,
        file=stream,
        disable=mode == "off",
        dynamic_ncols=mode == "terminal",
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
