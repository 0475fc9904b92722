"""Key numbers checked in the notebooks themselves: assert with a stated tolerance, and print the verdict.

A wrong number then fails the notebook (and ``make reproduce``), not only nbval's text comparison.
The printed line follows the reproducibility contract (:mod:`compendium.contract`), so that nbval,
which compares the printed text of the cells marked ``NBVAL_CHECK_OUTPUT``, never compares a digit
that varies between machines:

* ``exact`` values print as they are;
* ``converged`` values print rounded one decade above the check's tolerance (a value that passes
  varies far less than that);
* ``error``, ``order`` and ``path`` values (errors, residuals, fitted orders, iteration counts) print
  with ``≈``: nbval masks the digits after it (``notebooks/nbval_sanitize.cfg``) and compares the rest
  of the line, the verdict included. :func:`approx` writes such a number in a notebook's own lines.
"""

from __future__ import annotations

import math

from .contract import CLASSES

KINDS = tuple(CLASSES)  # the classes of the contract
APPROX = "≈"


def approx(value, digits: int = 2) -> str:
    """``≈ 1.2e-15``: a value whose digits vary between machines (nbval compares the text around it only)."""
    value = float(value)
    return f"{APPROX} {value:.{digits}g}"


def _rounded(value: float, resolution: float) -> str:
    """``value`` to the decade ``resolution`` (a power of ten), in fixed point: ``18.00``, ``7529.7``, ``0.00``."""
    if not math.isfinite(value):
        return f"{value:g}"
    decade = round(math.log10(resolution))
    if decade >= 0:
        return f"{round(value / resolution) * resolution:.0f}"
    return f"{value:.{-decade}f}"


def check(
    name: str,
    value,
    expected,
    *,
    rtol: float = 0.0,
    atol: float = 0.0,
    how: str = "close",
    kind: str | None = None,
    digits: int = 4,
    quiet: bool = False,
) -> None:
    """Assert ``value`` against ``expected`` and print one line saying so.

    ``how``: ``"close"`` (``|value - expected| <= atol + rtol |expected|``), ``"at most"``
    (``value <= expected + atol + rtol |expected|``) or ``"at least"``
    (``value >= expected - atol - rtol |expected|``). ``kind``: the value's class in the
    reproducibility contract (the module docstring); default ``"converged"`` for a ``"close"``
    check with a tolerance, ``"exact"`` for one without, ``"error"`` for a bound. ``digits``:
    significant digits of the expected value (and of an ``≈`` value) printed; ``quiet``: assert
    only (where the cell prints its own summary).
    """
    if how not in ("close", "at most", "at least"):
        raise ValueError(f"how must be 'close', 'at most' or 'at least', got {how!r}")
    value, expected = float(value), float(expected)
    slack = atol + rtol * abs(expected)
    if kind is None:
        kind = ("converged" if slack > 0 else "exact") if how == "close" else "error"
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
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
    if kind == "exact":
        shown = f"{value:.{max(digits, 12)}g}"
    elif kind == "converged":
        shown = _rounded(value, 10.0 ** (math.floor(math.log10(slack)) + 1)) if slack > 0 else f"{value:.{digits}g}"
    else:
        shown = approx(value, min(digits, 2))
    line = f"{name}: {shown} ({relation})"
    if not ok:
        raise AssertionError(f"check failed: {name}: {value!r} ({relation})")
    if not quiet:
        print(f"{line}: ok")


def check_true(name: str, condition) -> None:
    """Assert a condition and print it."""
    if not bool(condition):
        raise AssertionError(f"check failed: {name}")
    print(f"{name}: ok")
