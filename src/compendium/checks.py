"""Key numbers checked in the notebooks themselves: assert with a stated tolerance, and print the verdict.

A wrong number then fails the notebook (and ``make reproduce``), not only nbval's text
comparison. The printed line is rounded so that it is stable across machines.
"""

from __future__ import annotations

import math


def check(
    name: str,
    value,
    expected,
    *,
    rtol: float = 0.0,
    atol: float = 0.0,
    how: str = "close",
    digits: int = 4,
    quiet: bool = False,
) -> None:
    """Assert ``value`` against ``expected`` and print one line saying so.

    ``how``: ``"close"`` (``|value - expected| <= atol + rtol |expected|``), ``"at most"``
    (``value <= expected + atol + rtol |expected|``) or ``"at least"``
    (``value >= expected - atol - rtol |expected|``). ``digits``: significant digits printed;
    ``quiet``: assert only (where the cell prints its own summary).
    """
    if how not in ("close", "at most", "at least"):
        raise ValueError(f"how must be 'close', 'at most' or 'at least', got {how!r}")
    value, expected = float(value), float(expected)
    slack = atol + rtol * abs(expected)
    ok = {
        "close": abs(value - expected) <= slack,
        "at most": value <= expected + slack,
        "at least": value >= expected - slack,
    }[how]
    if math.isnan(value):
        ok = False
    tolerance = " + ".join(t for t in (f"{atol:g}" if atol else "", f"{rtol:g} relative" if rtol else "") if t)
    bound = f"{expected:.{digits}g}"
    if how == "close":
        relation = f"within {tolerance} of {bound}" if tolerance else f"equal to {bound}"
    else:
        relation = f"{how} {bound}" + (f" {'+' if how == 'at most' else '-'} {tolerance}" if tolerance else "")
    line = f"{name}: {value:.{digits}g} ({relation})"
    if not ok:
        raise AssertionError(f"check failed: {line}")
    if not quiet:
        print(f"{line}: ok")


def check_true(name: str, condition) -> None:
    """Assert a condition and print it."""
    if not bool(condition):
        raise AssertionError(f"check failed: {name}")
    print(f"{name}: ok")
