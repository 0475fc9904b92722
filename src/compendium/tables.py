"""Plain-text renderings of result tables (Markdown), without extra dependencies."""

from __future__ import annotations

import math
from collections.abc import Mapping

import pandas as pd


def _cell(value, fmt: str | None) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    if fmt is not None and isinstance(value, (int, float)) and not isinstance(value, bool):
        return format(value, fmt)
    return str(value)


def markdown_table(df: pd.DataFrame, formats: Mapping[str, str] | None = None) -> str:
    """A GitHub-flavoured Markdown table of ``df``; ``formats`` maps columns to format specs.

    Numbers are right-aligned, everything else left-aligned; NaN renders empty.
    """
    formats = dict(formats or {})
    unknown = sorted(set(formats) - set(df.columns))
    if unknown:
        raise KeyError(f"formats for unknown columns {unknown}")
    cols = [str(c) for c in df.columns]
    rows = [[_cell(v, formats.get(c)) for c, v in zip(df.columns, rec)] for rec in df.itertuples(index=False)]
    numeric = [pd.api.types.is_numeric_dtype(df[c]) for c in df.columns]
    widths = [max([len(h)] + [len(r[j]) for r in rows]) for j, h in enumerate(cols)]

    def line(cells):
        out = [c.rjust(w) if num else c.ljust(w) for c, w, num in zip(cells, widths, numeric)]
        return "| " + " | ".join(out) + " |"

    rule = "|" + "|".join(("-" * (w + 1) + ":") if num else ("-" * (w + 2)) for w, num in zip(widths, numeric)) + "|"
    return "\n".join([line(cols), rule] + [line(r) for r in rows])


class Shown:
    """A formatted table as a notebook shows it, with the same bytes on every run.

    A pandas ``Styler`` displays with a random HTML id and a plain-text form holding its memory address, so a
    stored notebook would change on every run; this shows the same table with an id derived from its content,
    and as plain text, the table's formatted values (``Styler.to_string``).
    """

    def __init__(self, styler):
        self.styler = styler

    def _text(self) -> str:
        return self.styler.to_string()

    def _repr_html_(self) -> str:
        import hashlib

        self.styler.set_uuid(hashlib.sha256(self._text().encode()).hexdigest()[:8])
        return self.styler.to_html()

    def __repr__(self) -> str:
        return self._text()


def show(table) -> Shown:
    """``show(df.style.format(...))``: the styled table, displayed deterministically (:class:`Shown`); a DataFrame
    is shown as it formats by default."""
    styler = table.style if isinstance(table, pd.DataFrame) else table
    return Shown(styler)


def show_summary(summary: Mapping, formats: Mapping[str, str] | None = None, digits: int = 6) -> Shown:
    """A run's summary (a flat mapping) shown as a two-column table, the same on every machine.

    A dict's own display prints every float to 17 digits, so a stored notebook would change with the last
    rounding bit of a converged optimum or an error estimate. Here a float shows ``digits`` significant digits
    unless ``formats`` (key -> format spec, e.g. ``{"max_error": ".1e"}``) says otherwise; other values as
    ``str``.
    """
    formats = dict(formats or {})
    unknown = sorted(set(formats) - set(summary))
    if unknown:
        raise KeyError(f"formats for unknown keys {unknown}")

    def text(key, value) -> str:
        if value is None:
            return ""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return str(value)
        if isinstance(value, int) and key not in formats:
            return str(value)
        return format(float(value), formats.get(key, f".{digits}g"))

    df = pd.DataFrame({"value": [text(k, v) for k, v in summary.items()]}, index=[str(k) for k in summary])
    return show(df.style.set_properties(**{"text-align": "right"}))
