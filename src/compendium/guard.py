"""The published record, guarded: compare what a fresh run wrote with the committed ``figures/`` and ``data/derived/``.

Command line (``make test`` runs it after nbval, whose runs write under ``build/test-output``)::

    python -m compendium.guard build/test-output

Every run leaves a record (:mod:`compendium.outputs`) naming its parameters and the files it wrote.
For each file of each run:

1. **A published run** (the notebook's published parameters) must reproduce the committed file:

   * figures: the same bytes. Should the bytes differ, a PNG whose pixels differ nowhere by more
     than ``PIXEL_TOL`` and a PDF whose drawing commands hold the same numbers to ``rtol = 1e-6``
     pass with a note (a last-bit change of a solver's answer can move a coordinate in the tenth
     decimal of a PDF); anything more is a difference;
   * CSV and JSON tables: the same columns, rows and keys; text, integers and booleans equal; floats
     within ``|a - b| <= atol + rtol |b|`` with ``rtol = 1e-6, atol = 1e-10``, except quantities at
     the level of rounding noise (shooting residuals ``norm_S``, ``noise of S``, Hamiltonian drift,
     re-integration errors), which must agree within a factor of two or both lie below ``1e-10``;
   * Markdown tables: the same text, their printed numbers within 5 % (they are rounded to 2-3 digits).

2. **A run with other parameters** (for instance nbval's fast defaults of the orbit transfer, which
   the published run extends) cannot reproduce whole files; each row of each CSV table it wrote must
   match a row of the committed table with the same tolerances. Its figures, JSON and Markdown are
   listed as not compared.

A file a published run writes that the repository does not hold is a difference. The command prints
what it compared and exits with status 1 and the list of differences if there are any.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .outputs import RUNS
from .paths import repo_root

RTOL, ATOL = 1e-6, 1e-10
#: quantities at the level of rounding noise: compared within a factor of two (or both below NOISE_FLOOR)
NOISE_COLUMNS = re.compile(r"norm_S|noise|drift|reintegration|re-integration")
NOISE_FACTOR, NOISE_FLOOR = 2.0, 1e-10
MARKDOWN_RTOL = 0.05
PIXEL_TOL = 2 / 255  # largest change of one colour channel that counts as the same picture
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


@dataclass
class Report:
    compared: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    differences: list[str] = field(default_factory=list)


def close(a: float, b: float, column: str = "") -> bool:
    """Whether a fresh value ``a`` matches the committed ``b`` (the module docstring's tolerances)."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if NOISE_COLUMNS.search(column):
        if abs(a) <= NOISE_FLOOR and abs(b) <= NOISE_FLOOR:
            return True
        return a * b > 0 and max(abs(a), abs(b)) <= NOISE_FACTOR * min(abs(a), abs(b))
    return abs(a - b) <= ATOL + RTOL * abs(b)


def _value_difference(a, b, where: str) -> str | None:
    if isinstance(a, bool) or isinstance(b, bool) or isinstance(a, str) or isinstance(b, str) or a is None or b is None:
        return None if a == b else f"{where}: {a!r} != committed {b!r}"
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return None if close(float(a), float(b), where) else f"{where}: {a!r} != committed {b!r}"
    return None if a == b else f"{where}: {a!r} != committed {b!r}"


# -- tables ------------------------------------------------------------------------------------------


def _read_csv(path: Path) -> pd.DataFrame:
    return pd.read_csv(path, keep_default_na=True)


def _row_difference(fresh: pd.Series, committed: pd.Series) -> str | None:
    for column in committed.index:
        a, b = fresh[column], committed[column]
        a_nan = isinstance(a, float) and math.isnan(a)
        b_nan = isinstance(b, float) and math.isnan(b)
        if a_nan or b_nan:
            if a_nan != b_nan:
                return f"column {column!r}: {a!r} != committed {b!r}"
            continue
        diff = _value_difference(
            a.item() if hasattr(a, "item") else a, b.item() if hasattr(b, "item") else b, f"column {column!r}"
        )
        if diff:
            return diff
    return None


def compare_csv(fresh: Path, committed: Path, *, subset: bool = False) -> list[str]:
    """Differences of a fresh CSV table from the committed one (``subset``: each fresh row matches some row)."""
    a, b = _read_csv(fresh), _read_csv(committed)
    if list(a.columns) != list(b.columns):
        return [f"columns {list(a.columns)} != committed {list(b.columns)}"]
    if subset:
        out = []
        for i, row in a.iterrows():
            if not any(_row_difference(row, other) is None for _, other in b.iterrows()):
                out.append(f"row {i} matches no committed row: {row.to_dict()}")
        return out
    if len(a) != len(b):
        return [f"{len(a)} rows != committed {len(b)}"]
    out = []
    for i in range(len(a)):
        diff = _row_difference(a.iloc[i], b.iloc[i])
        if diff:
            out.append(f"row {i}, {diff}")
    return out


def compare_json(fresh: Path, committed: Path) -> list[str]:
    out: list[str] = []

    def walk(a, b, where):
        if isinstance(a, dict) and isinstance(b, dict):
            if set(a) != set(b):
                out.append(f"{where or 'top level'}: keys {sorted(set(a) ^ set(b))} differ")
            for k in sorted(set(a) & set(b)):
                walk(a[k], b[k], f"{where}.{k}" if where else k)
        elif isinstance(a, list) and isinstance(b, list):
            if len(a) != len(b):
                out.append(f"{where}: {len(a)} items != committed {len(b)}")
            for i, (x, y) in enumerate(zip(a, b)):
                walk(x, y, f"{where}[{i}]")
        else:
            diff = _value_difference(a, b, where)
            if diff:
                out.append(diff)

    walk(json.loads(fresh.read_text()), json.loads(committed.read_text()), "")
    return out


def compare_markdown(fresh: Path, committed: Path) -> list[str]:
    a, b = fresh.read_text(), committed.read_text()
    if _NUMBER.sub("#", a) != _NUMBER.sub("#", b):
        return ["the text differs (not only its numbers)"]
    out = []
    for x, y in zip(_NUMBER.findall(a), _NUMBER.findall(b)):
        u, v = float(x), float(y)
        if abs(u - v) > MARKDOWN_RTOL * max(abs(u), abs(v)) and max(abs(u), abs(v)) > NOISE_FLOOR:
            out.append(f"number {x} != committed {y}")
    return out


# -- figures -----------------------------------------------------------------------------------------


def compare_png(fresh: Path, committed: Path) -> tuple[list[str], str | None]:
    """``(differences, note)``: equal bytes, or pixels within ``PIXEL_TOL``."""
    if fresh.read_bytes() == committed.read_bytes():
        return [], None
    from matplotlib.image import imread

    a, b = imread(fresh), imread(committed)
    if a.shape != b.shape:
        return [f"image size {a.shape} != committed {b.shape}"], None
    worst = float(np.abs(a.astype(float) - b.astype(float)).max())
    if worst <= PIXEL_TOL:
        return [], f"{fresh.name}: bytes differ, pixels within {PIXEL_TOL:.3f} (largest change {worst:.3f})"
    changed = int((np.abs(a.astype(float) - b.astype(float)) > PIXEL_TOL).any(axis=-1).sum())
    return [f"{changed} pixels differ (largest channel change {worst:.2f})"], None


def _pdf_streams(data: bytes) -> list[bytes]:
    out = []
    for m in re.finditer(rb"stream\r?\n(.*?)\r?\nendstream", data, re.S):
        raw = m.group(1)
        try:
            out.append(zlib.decompress(raw))
        except zlib.error:
            out.append(raw)
    return out


def compare_pdf(fresh: Path, committed: Path) -> tuple[list[str], str | None]:
    """``(differences, note)``: equal bytes, or the same drawing with numbers within ``RTOL``."""
    a, b = fresh.read_bytes(), committed.read_bytes()
    if a == b:
        return [], None
    sa, sb = _pdf_streams(a), _pdf_streams(b)
    if len(sa) != len(sb):
        return [f"{len(sa)} content streams != committed {len(sb)}"], None
    for x, y in zip(sa, sb):
        tx, ty = _NUMBER.sub("#", x.decode("latin-1")), _NUMBER.sub("#", y.decode("latin-1"))
        if tx != ty:
            return ["the drawing differs (not only its coordinates)"], None
        for u, v in zip(_NUMBER.findall(x.decode("latin-1")), _NUMBER.findall(y.decode("latin-1"))):
            if abs(float(u) - float(v)) > 1e-6 + RTOL * abs(float(v)):
                return [f"a coordinate {u} != committed {v}"], None
    return [], f"{fresh.name}: bytes differ, the same drawing to rtol {RTOL:g}"


# -- runs --------------------------------------------------------------------------------------------


def check_run(output_root: Path, record: dict, reference: Path, report: Report) -> None:
    published = record["published_parameters"]
    for rel in record["files"]:
        fresh, committed = output_root / rel, reference / rel
        label = f"{record['notebook']}: {rel}"
        if not fresh.is_file():
            report.differences.append(f"{label}: listed in the run record but not written")
            continue
        if not published:
            if fresh.suffix == ".csv" and committed.is_file():
                diffs = compare_csv(fresh, committed, subset=True)
                report.compared.append(f"{label} (rows against the committed table)")
                report.differences += [f"{label}: {d}" for d in diffs]
            else:
                report.skipped.append(f"{label} (a run with other parameters)")
            continue
        if not committed.is_file():
            report.differences.append(f"{label}: not in the published record (is it committed?)")
            continue
        note = None
        if fresh.suffix == ".png":
            diffs, note = compare_png(fresh, committed)
        elif fresh.suffix == ".pdf":
            diffs, note = compare_pdf(fresh, committed)
        elif fresh.suffix == ".csv":
            diffs = compare_csv(fresh, committed)
        elif fresh.suffix == ".json":
            diffs = compare_json(fresh, committed)
        elif fresh.suffix == ".md":
            diffs = compare_markdown(fresh, committed)
        else:
            diffs = [] if fresh.read_bytes() == committed.read_bytes() else ["bytes differ"]
        report.compared.append(label)
        if note:
            report.notes.append(f"{record['notebook']}: {note}")
        report.differences += [f"{label}: {d}" for d in diffs[:5]]
        if len(diffs) > 5:
            report.differences.append(f"{label}: ... and {len(diffs) - 5} more")


def guard(output_root: str | Path, reference: str | Path | None = None) -> Report:
    """Compare every run recorded under ``output_root`` with the published record in ``reference`` (the repo)."""
    output_root = Path(output_root)
    reference = Path(reference) if reference else repo_root()
    records = sorted((output_root / RUNS).glob("*.json"))
    report = Report()
    if not records:
        report.differences.append(f"no run records under {output_root / RUNS}: did the notebooks run?")
    for path in records:
        check_run(output_root, json.loads(path.read_text()), reference, report)
    return report


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m compendium.guard", description=__doc__.split("\n")[0])
    parser.add_argument("output_root", type=Path, help="where the runs wrote (e.g. build/test-output)")
    parser.add_argument("--reference", type=Path, default=None, help="the published record (default: the repository)")
    args = parser.parse_args(argv)
    report = guard(args.output_root, args.reference)
    print(f"published record: {len(report.compared)} files compared, {len(report.skipped)} not compared")
    for line in report.skipped:
        print(f"  not compared: {line}")
    for line in report.notes:
        print(f"  note: {line}")
    if report.differences:
        print(f"{len(report.differences)} difference(s) from the published record:", file=sys.stderr)
        for line in report.differences:
            print(f"  {line}", file=sys.stderr)
        return 1
    print("every compared file matches the published record")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
