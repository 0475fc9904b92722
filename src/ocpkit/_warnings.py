"""Where a warning of the library points: at the user's line, however deep inside ocpkit it is raised."""

from __future__ import annotations

import sys
from pathlib import Path

_ROOT = str(Path(__file__).resolve().parent)


def user_stacklevel() -> int:
    """The ``stacklevel`` that makes a warning issued by the caller of this function point at the first frame
    outside the ocpkit package (the user's call of ``solve()``, whichever entry point led there)."""
    frame = sys._getframe(1)  # the function that issues the warning
    level = 1
    while frame is not None and frame.f_code.co_filename.startswith(_ROOT):
        frame = frame.f_back  # type: ignore[assignment]  # None past the outermost frame
        level += 1
    return level
