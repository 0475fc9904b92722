"""The published record, guarded: compare what fresh runs wrote with the committed ``figures/`` and ``data/derived/``
by the reproducibility contract (:mod:`compendium.contract`, ``notebooks/contract.toml``).

Command line (``make test`` runs it after nbval, whose runs write under ``build/test-output``)::

    python -m compendium.guard build/test-output          # against the repository's record
    python -m compendium.guard . --reference-commit HEAD  # the working tree (after make reproduce) against HEAD

Comparing the working tree with a commit, it ends with a note (:func:`closing_note`): how many files of the record
differ byte-wise from the commit yet reproduce it, of which kinds, and the command that restores the committed bytes.

Every run leaves a record (:mod:`compendium.outputs`) naming its notebook, parameters and the files it wrote.

1. **A published run** (the notebook's published parameters) must write exactly the files its contract declares,
   and each must reproduce the committed one:

   * CSV tables: the same columns; rows paired by the table's ``key`` (else by position); each value accepted by
     its column's class; rows of runs that failed (the ``status`` column) by their key and status only;
   * JSON summaries: the same keys, each value by its class; Markdown: the words of the text around the tables
     exactly and its numbers as converged values, the cells by their column's class (numbers as printed: one unit
     of the last digit is part of the tolerance);
   * figures: the arrays they draw (``figures/data/<name>.json``, :mod:`compendium.figure_data`) by the classes
     of the figure's declaration (by default, the class of each axis' scale), their texts word for word with the
     numbers as converged values. PNG and PDF bytes, which depend on the machine's last bits, fonts and
     libraries, are compared only for a note.

2. **A run with other parameters** (nbval's fast defaults of the orbit transfer, which the published run extends)
   cannot reproduce whole files: each row of each CSV table it wrote must match the committed row of the same key.
   Its figures, JSON and Markdown are listed as not compared.

Files the committed record holds that no contract declares are differences too. The command prints what it compared
and exits with status 1 and the list of differences if there are any.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .contract import (
    Class,
    Contract,
    Converged,
    FigureSpec,
    SolverPath,
    TableSpec,
    column_resolutions,
    text_differences,
    to_number,
)
from .paths import repo_root
from .provenance import RUNS

MAX_PER_FILE = 8  # differences listed per file (the rest are counted)
PUBLISHED_FOLDERS = ("figures", "data/derived")


@dataclass
class Report:
    compared: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    differences: list[str] = field(default_factory=list)
    #: the files compared whole against the committed ones (a published run's), by path: their kind in the contract
    reproduced: dict[str, str] = field(default_factory=dict)


# -- values --------------------------------------------------------------------------------------------------------


def _accepts(klass: Class, a: str, b: str, scale: float | None = None, resolution: float = 0.0) -> bool:
    """Does the fresh field ``a`` reproduce the committed ``b`` (both as written; ``resolution``: that of ``b``'s
    format, :func:`compendium.contract.column_resolutions`) under ``klass``?"""
    x, y = to_number(a), to_number(b)
    if x is None or y is None:  # text, booleans; a flag of the solver's path (which of two runs ended lower) is
        return isinstance(klass, SolverPath) or str(a).strip() == str(b).strip()  # recorded, not compared
    return bool(klass.accepts(x, y, resolution, scale))


def _show(value) -> str:
    return repr(value) if isinstance(value, str) else str(value)


# -- tables --------------------------------------------------------------------------------------------------------


def read_csv(path: Path) -> pd.DataFrame:
    """A CSV table as written: every field a string (``""`` where empty), so that each number keeps its digits."""
    return pd.read_csv(path, dtype=str, keep_default_na=False)


def _column_scale(spec: TableSpec, column: str, values: pd.Series) -> float | None:
    klass = spec.class_of(column)
    if isinstance(klass, Converged) and klass.scale == "column":
        numbers = [to_number(v) for v in values]
        finite = [abs(v) for v in numbers if v is not None and math.isfinite(v)]
        return max(finite, default=0.0)
    return None


def _normal_key(row: pd.Series, spec: TableSpec) -> tuple:
    """A row's key, numbers to nine significant digits (``5`` and ``5.0`` are one key): what most matches need."""
    out = []
    for c in spec.key:
        x = to_number(row[c])
        out.append(f"{x:.9g}" if x is not None else str(row[c]).strip())
    return tuple(out)


def _same_key(a: pd.Series, b: pd.Series, spec: TableSpec) -> bool:
    return all(_accepts(spec.class_of(c), a[c], b[c]) for c in spec.key)


def _row_differences(
    fresh: pd.Series, committed: pd.Series, spec: TableSpec, scales: dict, resolutions: dict | None = None
) -> list[str]:
    skip = spec.not_compared(fresh, committed, committed.index)  # a run that failed: its status, never its numbers
    out = []
    for column in [c for c in committed.index if c not in skip]:
        klass = spec.class_of(column)
        a, b = fresh[column], committed[column]
        if not _accepts(klass, a, b, scales.get(column), (resolutions or {}).get(column, 0.0)):
            out.append(f"column {column!r}: {_show(a)} != committed {_show(b)} ({klass.describe()})")
    return out


def _row_label(row: pd.Series, spec: TableSpec, index: int) -> str:
    if spec.key:
        return "row " + ", ".join(f"{c}={row[c]}" for c in spec.key)
    return f"row {index}"


def compare_tables(
    fresh: pd.DataFrame, committed: pd.DataFrame, spec: TableSpec, *, subset: bool = False, notes: list | None = None
) -> list[str]:
    """Differences of a fresh table from the committed one under ``spec`` (``subset``: a run with other
    parameters, each of whose rows must match the committed row of the same key). ``notes`` receives what is
    listed but not compared (the rows the contract's ``only`` leaves out)."""
    if list(fresh.columns) != list(committed.columns):
        return [f"columns {list(fresh.columns)} != committed {list(committed.columns)}"]
    undeclared = spec.undeclared(committed.columns)
    if undeclared:
        return [f"columns {undeclared} have no class in the contract"]
    if spec.only:
        keep_fresh = [spec.reproduces(fresh.iloc[i]) for i in range(len(fresh))]
        keep_committed = [spec.reproduces(committed.iloc[j]) for j in range(len(committed))]
        if notes is not None:
            left = (len(fresh) - sum(keep_fresh), len(committed) - sum(keep_committed))
            notes.append(f"{left[0]} fresh and {left[1]} committed rows are search outcomes, not compared (only)")
        fresh = fresh[keep_fresh].reset_index(drop=True)
        committed = committed[keep_committed].reset_index(drop=True)
    scales = {c: _column_scale(spec, c, committed[c]) for c in committed.columns}
    written = {c: column_resolutions(committed[c]) for c in committed.columns}

    def resolutions(j: int) -> dict:
        return {c: r[j] for c, r in written.items()}

    out: list[str] = []
    if not spec.key:
        if subset:
            return ["a run with other parameters needs the table's key to match its rows (declare `key`)"]
        if len(fresh) != len(committed):
            return [f"{len(fresh)} rows != committed {len(committed)}"]
        for i in range(len(fresh)):
            diffs = _row_differences(fresh.iloc[i], committed.iloc[i], spec, scales, resolutions(i))
            out += [f"row {i}, {d}" for d in diffs]
        return out
    by_key: dict[tuple, list[int]] = {}
    for j in range(len(committed)):
        by_key.setdefault(_normal_key(committed.iloc[j], spec), []).append(j)
    repeated = [k for k, rows in by_key.items() if len(rows) > 1]
    if repeated:
        return [
            f"the key {spec.key} does not identify a row: {repeated[0]} is the key of {len(by_key[repeated[0]])} rows"
        ]
    used: set[int] = set()
    for i in range(len(fresh)):
        row = fresh.iloc[i]
        exact = [j for j in by_key.get(_normal_key(row, spec), []) if j not in used]
        matches = exact or [  # a key that moved within its class (a converged t_f of a grid, say)
            j for j in range(len(committed)) if j not in used and _same_key(row, committed.iloc[j], spec)
        ]
        if not matches:
            out.append(f"{_row_label(row, spec, i)}: no committed row has this key")
            continue
        j = matches[0]
        used.add(j)
        label = _row_label(row, spec, i)
        out += [f"{label}, {d}" for d in _row_differences(row, committed.iloc[j], spec, scales, resolutions(j))]
    if not subset:
        for j in sorted(set(range(len(committed))) - used):
            out.append(f"{_row_label(committed.iloc[j], spec, j)}: committed, but the fresh run has no such row")
    return out


def compare_csv(
    fresh: Path, committed: Path, spec: TableSpec, *, subset: bool = False, notes: list | None = None
) -> list[str]:
    return compare_tables(read_csv(fresh), read_csv(committed), spec, subset=subset, notes=notes)


def _flatten(obj, prefix: str = "") -> dict[str, object]:
    if isinstance(obj, dict):
        out: dict[str, object] = {}
        for k, v in obj.items():
            out |= _flatten(v, f"{prefix}.{k}" if prefix else str(k))
        return out
    if isinstance(obj, list) and obj and all(isinstance(v, dict) for v in obj):
        out = {}
        for i, v in enumerate(obj):
            out |= _flatten(v, f"{prefix}[{i}]")
        return out
    return {prefix: obj}


def _field(value) -> str:
    """A JSON value as a table field: numbers with their digits, ``null`` empty, lists as JSON text."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, list):
        return json.dumps(value)
    return str(value)


def compare_json(fresh: Path, committed: Path, spec: TableSpec) -> list[str]:
    a, b = _flatten(json.loads(fresh.read_text())), _flatten(json.loads(committed.read_text()))
    if set(a) != set(b):
        return [f"keys {sorted(set(a) ^ set(b))} are in one file only"]
    out = []
    for key in b:
        klass = spec.class_of(key)
        if klass is None:
            out.append(f"key {key!r} has no class in the contract")
        elif isinstance(b[key], list) and isinstance(a[key], list):
            numbers = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in a[key] + b[key])
            if not numbers:
                same = a[key] == b[key]
            else:
                x, y = np.asarray(a[key], dtype=float), np.asarray(b[key], dtype=float)
                same = x.shape == y.shape and bool(klass.accepts(x, y).all())
            if not same:
                out.append(f"{key}: {a[key]} != committed {b[key]} ({klass.describe()})")
        elif not _accepts(klass, _field(a[key]), _field(b[key])):
            out.append(f"{key}: {_show(a[key])} != committed {_show(b[key])} ({klass.describe()})")
    return out


def _markdown_blocks(text: str) -> list[tuple[str, object]]:
    """``("text", line)`` and ``("table", DataFrame of strings)`` blocks of a Markdown document."""
    blocks: list[tuple[str, object]] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if (
            line.lstrip().startswith("|")
            and i + 1 < len(lines)
            and set(lines[i + 1].replace("|", "").strip()) <= set("-: ")
        ):
            rows = []
            j = i
            while j < len(lines) and lines[j].lstrip().startswith("|"):
                rows.append([c.strip() for c in lines[j].strip().strip("|").split("|")])
                j += 1
            header, body = rows[0], rows[2:]
            blocks.append(("table", pd.DataFrame(body, columns=header)))
            i = j
        else:
            blocks.append(("text", line))
            i += 1
    return blocks


def compare_markdown(fresh: Path, committed: Path, spec: TableSpec) -> list[str]:
    a, b = _markdown_blocks(fresh.read_text()), _markdown_blocks(committed.read_text())
    if [k for k, _ in a] != [k for k, _ in b]:
        return ["the document's structure (text lines and tables) differs"]
    out = []
    for (kind, x), (_, y) in zip(a, b):
        if kind == "text":
            out += text_differences(x, y)
        else:
            out += compare_tables(x, y, spec)
    return out


# -- figures -------------------------------------------------------------------------------------------------------


def _array(values) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in values], dtype=float)


def _span(artists: list[dict], part: str) -> float:
    """The largest magnitude an axis shows: the scale of its ``converged`` comparisons."""
    values = [np.abs(_array(a[part])) for a in artists if part in a]
    finite = np.concatenate(values) if values else np.zeros(0)
    finite = finite[np.isfinite(finite)]
    return float(finite.max()) if finite.size else 0.0


def _figure_texts(fresh: dict, committed: dict, spec: FigureSpec, i: int, where: str) -> list[str]:
    out = []
    for key in ("xscale", "yscale", "zscale", "colorbar"):
        if fresh.get(key) != committed.get(key):
            out.append(f"{where}: {key} {fresh.get(key)!r} != committed {committed.get(key)!r}")
    for key in ("title", "xlabel", "ylabel", "zlabel"):
        out += text_differences(fresh.get(key) or "", committed.get(key) or "", spec.class_of(i, key), f"{where} {key}")
    for key in ("legend", "texts"):
        klass = spec.class_of(i, key)
        if isinstance(klass, SolverPath):
            continue  # the legend of what a search found, or of a solver's path
        if len(fresh[key]) != len(committed[key]):
            out.append(f"{where}: {len(fresh[key])} {key} entries != committed {len(committed[key])}")
        else:
            for x, y in zip(fresh[key], committed[key]):
                out += text_differences(x, y, klass, f"{where} {key}")
    return out


def _artist_class(spec: FigureSpec, i: int, artist: dict, part: str, axes: dict) -> Class:
    return (
        spec.artist_class(i, artist["label"], part)
        or spec.artist_class(i, artist["label"])
        or spec.class_of(i, part, axes.get(f"{part}scale"))
    )


def _compared_artists(axes: dict, spec: FigureSpec, i: int) -> list[dict]:
    """The artists of an axes the contract compares: not those it declares ``path`` by their label."""
    return [a for a in axes["artists"] if not isinstance(spec.artist_class(i, a["label"]), SolverPath)]


def _figure_artists(fresh: dict, committed: dict, spec: FigureSpec, i: int, where: str) -> list[str]:
    fa, ca = _compared_artists(fresh, spec, i), _compared_artists(committed, spec, i)
    kinds_a, kinds_b = [a["type"] for a in fa], [a["type"] for a in ca]
    if kinds_a != kinds_b:
        return [f"{where}: artists {kinds_a} != committed {kinds_b}"]
    out = []
    for j, (a, b) in enumerate(zip(fa, ca)):
        out += text_differences(a["label"], b["label"], spec.class_of(i, "legend"), f"{where} artist {j} label")
        for part in ("x", "y", "z", "c"):
            if (part in a) != (part in b):
                out.append(f"{where} artist {j}: {part} data in one figure only")
                continue
            klass = _artist_class(spec, i, b, part, committed)
            if part not in b or isinstance(klass, SolverPath):
                continue
            scale = _span(ca, part) if isinstance(klass, Converged) and klass.scale == "column" else None
            x, y = _array(a[part]), _array(b[part])
            if x.shape != y.shape:
                out.append(f"{where} artist {j} ({b['label'] or b['type']}): {x.size} {part} values != {y.size}")
                continue
            bad = ~klass.accepts(x, y, scale=scale)
            if bad.any():
                k = int(np.argmax(bad))
                out.append(
                    f"{where} artist {j} ({b['label'] or b['type']}): {int(bad.sum())} of {y.size} {part} values "
                    f"differ, e.g. [{k}] {x[k]:.9g} != committed {y[k]:.9g} ({klass.describe()})"
                )
    return out


def _figure_limits(fresh: dict, committed: dict, spec: FigureSpec, i: int, where: str) -> list[str]:
    """The axis limits, which follow the data: by each coordinate's class, relative to the axis' span."""
    out = []
    for part in ("x", "y", "z"):
        limits = f"{part}lim"
        if limits not in committed:
            continue
        klass = spec.class_of(i, part, committed.get(f"{part}scale"))
        if isinstance(klass, SolverPath):
            continue
        x, y = _array(fresh[limits]), _array(committed[limits])
        if isinstance(klass, Converged):
            klass = Converged(klass.rtol, klass.atol, "column")
        span = max(_span(_compared_artists(committed, spec, i), part), float(np.nanmax(np.abs(y))) if y.size else 0.0)
        if x.shape != y.shape or not klass.accepts(x, y, scale=span).all():
            out.append(f"{where}: {limits} {fresh[limits]} != committed {committed[limits]}")
    return out


def compare_figure_data(fresh: dict, committed: dict, spec: FigureSpec) -> list[str]:
    """Differences of what a fresh figure draws from the committed one (:mod:`compendium.figure_data`): its texts,
    scales and artists, each coordinate by its class; an axes whose x and y are both ``path`` (what a search found,
    a solver's history) by its texts and scales only."""
    out = text_differences(fresh.get("suptitle", ""), committed.get("suptitle", ""), spec.class_of(None, "suptitle"))
    if len(fresh["axes"]) != len(committed["axes"]):
        return out + [f"{len(fresh['axes'])} axes != committed {len(committed['axes'])}"]
    for i, (fa, ca) in enumerate(zip(fresh["axes"], committed["axes"])):
        where = f"axes {i}"
        out += _figure_texts(fa, ca, spec, i, where)
        if all(isinstance(spec.class_of(i, p, ca.get(f"{p}scale")), SolverPath) for p in ("x", "y")):
            continue
        out += _figure_artists(fa, ca, spec, i, where)
        out += _figure_limits(fa, ca, spec, i, where)
    return out


def _same_bytes(fresh: Path, committed: Path) -> bool:
    return fresh.read_bytes() == committed.read_bytes()


# -- runs ----------------------------------------------------------------------------------------------------------


def _compare_file(kind: str, spec, fresh: Path, committed: Path) -> tuple[list[str], str | None]:
    """``(differences, note)`` of one published file under its contract."""
    if kind == "tables":
        notes: list[str] = []
        return compare_csv(fresh, committed, spec, notes=notes), (f"{fresh.name}: {notes[0]}" if notes else None)
    if kind == "json":
        return compare_json(fresh, committed, spec), None
    if kind == "markdown":
        return compare_markdown(fresh, committed, spec), None
    if kind == "figure data":
        return compare_figure_data(json.loads(fresh.read_text()), json.loads(committed.read_text()), spec), None
    # PNG and PDF: a same-machine note only (the figure's data are compared)
    if _same_bytes(fresh, committed):
        return [], None
    return [], f"{fresh.name}: bytes differ (the figure is compared by its data; expected on another machine)"


def check_run(output_root: Path, record: dict, reference: Path, contract: Contract, report: Report) -> None:
    notebook = record["notebook"]
    if notebook not in contract:
        report.differences.append(f"{notebook}: the contract has no section for this notebook")
        return
    declared = contract[notebook].files()
    published = record["published_parameters"]
    written = list(record["files"])
    for rel in written:
        if rel not in declared:
            report.differences.append(f"{notebook}: {rel}: written, but not declared in the contract")
    if published:
        for rel in declared:
            if rel not in written:
                report.differences.append(f"{notebook}: {rel}: declared in the contract, but the run did not write it")
    for rel in written:
        if rel not in declared:
            continue
        kind, spec = declared[rel]
        fresh, committed = output_root / rel, reference / rel
        label = f"{notebook}: {rel}"
        if not fresh.is_file():
            report.differences.append(f"{label}: listed in the run record but not written")
            continue
        if not committed.is_file():
            report.differences.append(f"{label}: not in the published record (is it committed?)")
            continue
        if not published:
            if kind == "tables":
                diffs = compare_csv(fresh, committed, spec, subset=True)
                report.compared.append(f"{label} (rows against the committed table, by key)")
                report.differences += _limited(label, diffs)
            else:
                report.skipped.append(f"{label} (a run with other parameters)")
            continue
        diffs, note = _compare_file(kind, spec, fresh, committed)
        report.compared.append(label)
        if not diffs:
            report.reproduced[rel] = kind
        if note:
            report.notes.append(f"{notebook}: {note}")
        report.differences += _limited(label, diffs)


def _limited(label: str, diffs: list[str]) -> list[str]:
    out = [f"{label}: {d}" for d in diffs[:MAX_PER_FILE]]
    if len(diffs) > MAX_PER_FILE:
        out.append(f"{label}: ... and {len(diffs) - MAX_PER_FILE} more")
    return out


def undeclared_committed_files(reference: Path, contract: Contract) -> list[str]:
    """Files of the committed record (``figures/``, ``data/derived/``, run records aside) no contract declares."""
    declared = {rel for nc in contract.notebooks.values() for rel in nc.files()}
    out = []
    for folder in PUBLISHED_FOLDERS:
        for path in sorted((reference / folder).rglob("*")):
            rel = path.relative_to(reference).as_posix()
            if path.is_file() and not rel.startswith(RUNS.as_posix() + "/") and rel not in declared:
                if not path.name.startswith("."):
                    out.append(rel)
    return out


def guard(output_root: str | Path, reference: str | Path | None = None) -> Report:
    """Compare every run recorded under ``output_root`` with the published record in ``reference`` (the repo)."""
    output_root = Path(output_root)
    reference = Path(reference) if reference else repo_root()
    contract = Contract.load(reference)
    records = sorted((output_root / RUNS).glob("*.json"))
    report = Report()
    if not records:
        report.differences.append(f"no run records under {output_root / RUNS}: did the notebooks run?")
    seen = set()
    for path in records:
        record = json.loads(path.read_text())
        seen.add(record["notebook"])
        check_run(output_root, record, reference, contract, report)
    if records:
        report.differences += [
            f"{nb}: the contract declares its files, but no run of it is recorded under {output_root / RUNS}"
            for nb in sorted(set(contract.notebooks) - seen)
        ]
    report.differences += [
        f"{rel}: committed, but no notebook's contract declares it"
        for rel in undeclared_committed_files(reference, contract)
    ]
    return report


def committed_record(commit: str, into: Path, repository: Path | None = None) -> Path:
    """The published record and the contract as of ``commit`` (``git archive``), unpacked into ``into``."""
    repository = repository or repo_root()
    paths = ["figures", "data/derived", "notebooks/contract.toml"]
    archive = subprocess.run(
        ["git", "-C", str(repository), "archive", "--format=tar", commit, *paths], capture_output=True, check=True
    ).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


# -- the working tree against the commit ----------------------------------------------------------------------------

#: how each kind of file of the contract differs from the committed bytes and still reproduces it, for the closing note
_WITHIN = {
    "figures": "PNG and PDF figures redrawn: their bytes follow the machine's fonts, libraries and last bits; what "
    "they draw is compared (figures/data)",
    "figure data": "arrays the figures draw (figures/data/*.json), each value within its class",
    "tables": "CSV tables, each number within its class's tolerance",
    "json": "JSON summaries, each value within its class",
    "markdown": "Markdown tables, their words the same and their numbers within their class",
}


@dataclass
class RecordChanges:
    """The published record of a working tree against a commit, after a comparison (:func:`guard`) that passed.

    ``within``: the files that differ byte-wise from the commit and reproduce it by the contract, by kind (the keys
    of the contract's :meth:`~compendium.contract.NotebookContract.files`); ``identical``: the compared files with
    the commit's bytes; ``unchecked``: files of ``figures/`` and ``data/derived/`` changed (or new, or deleted)
    since the commit that the comparison did not check, which restoring the committed bytes would discard too.
    """

    commit: str
    within: dict[str, list[str]] = field(default_factory=dict)
    identical: list[str] = field(default_factory=list)
    unchecked: list[str] = field(default_factory=list)

    @property
    def restore(self) -> str:
        """The command that puts back the commit's bytes of the published record (index and working tree)."""
        return f"git checkout {self.commit} -- {' '.join(PUBLISHED_FOLDERS)}"


def record_changes(report: Report, repository: str | Path, commit: str = "HEAD") -> RecordChanges:
    """What of ``figures/`` and ``data/derived/`` in ``repository``'s working tree differs from ``commit`` (git's
    view: content, not timestamps; git-ignored run records aside), against what ``report`` (:func:`guard` of the
    working tree against that commit's record) found reproduced."""

    def git(*args: str) -> list[str]:
        done = subprocess.run(["git", "-C", str(repository), *args], capture_output=True, text=True, check=True)
        return [line for line in done.stdout.splitlines() if line]

    changed = set(git("diff", "--name-only", "--no-renames", commit, "--", *PUBLISHED_FOLDERS))
    changed |= set(git("ls-files", "--others", "--exclude-standard", "--", *PUBLISHED_FOLDERS))
    out = RecordChanges(commit)
    for rel, kind in sorted(report.reproduced.items()):
        if rel in changed:
            out.within.setdefault(kind, []).append(rel)
        else:
            out.identical.append(rel)
    out.unchecked = sorted(changed - set(report.reproduced))
    return out


def closing_note(changes: RecordChanges) -> str:
    """What ``git status`` will show of the published record after a comparison that passed, and how to get the
    committed bytes back (the words :func:`main` prints at the end of ``make reproduce``)."""
    within = sum(len(files) for files in changes.within.values())
    if not within and not changes.unchecked:
        return f"the published record has the bytes of {changes.commit} ({len(changes.identical)} files compared)"
    lines = [
        f"{within} files of the published record differ byte-wise from {changes.commit} and reproduce it within "
        f"the contract (notebooks/contract.toml); {len(changes.identical)} are byte-identical."
    ]
    kinds = [*(k for k in _WITHIN if k in changes.within), *(k for k in changes.within if k not in _WITHIN)]
    lines += [f"  {len(changes.within[kind])} {_WITHIN.get(kind, kind)}" for kind in kinds]
    if changes.unchecked:
        shown = ", ".join(changes.unchecked[:5]) + (", ..." if len(changes.unchecked) > 5 else "")
        lines.append(
            f"{len(changes.unchecked)} other changed file(s) there were not compared ({shown}): review them with "
            f"git status; `{changes.restore}` would discard them too."
        )
    elif within:
        lines.append(
            f"`git status` lists them as modified. To put back the committed bytes (this discards only the changes "
            f"just found within the contract): {changes.restore}"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m compendium.guard", description=__doc__.split("\n")[0])
    parser.add_argument("output_root", type=Path, help="where the runs wrote (e.g. build/test-output)")
    parser.add_argument("--reference", type=Path, default=None, help="the published record (default: the repository)")
    parser.add_argument(
        "--reference-commit", default=None, help="compare against the record of this git commit (e.g. HEAD)"
    )
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="ocpkit-record-") as tmp:
        reference = args.reference
        if args.reference_commit:  # of the checkout the runs wrote into, where they did (make reproduce)
            repository = args.output_root if _is_checkout(args.output_root) else None
            reference = committed_record(args.reference_commit, Path(tmp), repository=repository)
        report = guard(args.output_root, reference)
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
    print("every compared file reproduces the published record (notebooks/contract.toml)")
    if args.reference_commit and _is_checkout(args.output_root):
        print(closing_note(record_changes(report, args.output_root, args.reference_commit)))
    return 0


def _is_checkout(folder: Path) -> bool:
    """Whether ``folder`` is the top of a git working tree (the runs wrote into the repository itself)."""
    done = subprocess.run(["git", "-C", str(folder), "rev-parse", "--show-toplevel"], capture_output=True, text=True)
    return done.returncode == 0 and Path(done.stdout.strip()).resolve() == folder.resolve()


if __name__ == "__main__":
    raise SystemExit(main())
