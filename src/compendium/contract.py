"""The reproducibility contract: what "reproduces" means for each published quantity, in one place.

Every published quantity (each column of each table in ``data/derived/``, each key of a JSON summary, each
cell of a Markdown table, each array a figure draws) belongs to one **class**. The class follows from how the
quantity is computed, not from what passed on one machine, and says how a fresh value ``a`` is compared with
the committed ``b``:

``exact``
    identifiers, parameters of a run, sizes, statuses, booleans, counts of a converged extremal's switchings:
    equal.
``converged(rtol=1e-6, atol=1e-10, scale="value")``
    values of a converged solution (objective, t_f, fuel, states at nodes, a trajectory on a grid):
    ``|a - b| <= atol + rtol * s + r``, with ``s = |b|`` (``scale="value"``) or the largest ``|b|`` of the
    column or figure axis (``scale="column"``: a time history, whose values near zero are no more accurate than
    its scale), and ``r`` the resolution of ``b`` as written (one unit of its last printed digit). IPOPT stops
    at 1e-8 (scaled) or tighter and the shooting solvers at |S| <= 1e-8; a converged optimum moves between
    machines by about 1e-12 relative, so 1e-6 leaves orders of margin and still catches a fuel changed by
    0.01 kg (2e-6 of the landing's 5365 kg).
``error(factor=2, floor=0)``
    error estimates, errors against a reference or a closed form, re-integration errors, residuals (|S| at
    convergence), noise measures: small differences of nearly equal numbers, accurate only in magnitude.
    ``max(a', b') <= factor * min(a', b')`` with ``a' = max(|a|, floor)`` (a value below the floor, the level
    below which the quantity is noise, stated where it is declared, counts as the floor; so two values below it are
    equal), of the same sign unless one is below the floor.
``order(atol=0.1)``
    fitted convergence orders, slopes of log error against log mesh size: ``|a - b| <= atol`` (the README
    states them to one decimal).
``path(factor=3, slack=10)``
    how a solver got there: iterations, function and Jacobian evaluations, integration steps, mesh iterations
    and the mesh sizes refinement chose; where a stalled run stopped. Compared loosely,
    ``b / factor - slack <= a <= factor * b + slack``; a path-class flag (which of two runs ended lower) or array of
    a figure (an iteration history) is recorded, not compared.

Rows of runs that did not converge are compared by their key and status only: a table's ``status`` column
(boolean, or text with the ``succeeded`` values) says which rows failed, and their numbers are not
reproducible by nature.

**Declaring.** A notebook declares the class of every quantity it publishes in ``notebooks/contract.toml``,
one section per published file (see the file's header). :class:`compendium.outputs.Outputs` warns when a run
writes something undeclared, and :mod:`compendium.guard`, which compares fresh runs with the committed record
by this contract, reports it as a difference. Numbers a notebook prints for nbval follow the same classes
(:mod:`compendium.checks`): exact and converged values are printed well above their variation, the others with
``≈``, whose digits nbval does not compare.
"""

from __future__ import annotations

import ast
import fnmatch
import math
import re
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

CONTRACT_FILE = Path("notebooks") / "contract.toml"

# -- the classes -------------------------------------------------------------------------------------------------


class Class:
    """A class of published quantities: how a fresh value ``a`` is compared with the committed ``b``."""

    name = "class"

    def accepts(self, a, b, resolution=0.0, scale=None) -> np.ndarray:
        """Element-wise: does ``a`` reproduce ``b`` (float arrays; NaN equals NaN)?"""
        raise NotImplementedError

    def describe(self) -> str:
        params = ", ".join(f"{k}={v!r}" for k, v in vars(self).items())
        return f"{self.name}({params})" if params else self.name

    def __repr__(self) -> str:
        return self.describe()

    def __eq__(self, other) -> bool:
        return type(self) is type(other) and vars(self) == vars(other)

    def __hash__(self) -> int:
        return hash((type(self), tuple(sorted(vars(self).items()))))


def _nan_mask(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    both, either = np.isnan(a) & np.isnan(b), np.isnan(a) | np.isnan(b)
    return a, b, both, either


class Exact(Class):
    name = "exact"

    def accepts(self, a, b, resolution=0.0, scale=None):
        a, b, both, either = _nan_mask(a, b)
        return both | (~either & (a == b))


class Converged(Class):
    name = "converged"

    def __init__(self, rtol: float = 1e-6, atol: float = 1e-10, scale: str = "value"):
        if scale not in ("value", "column"):
            raise ValueError(f"converged: scale must be 'value' or 'column', got {scale!r}")
        self.rtol, self.atol, self.scale = float(rtol), float(atol), scale

    def accepts(self, a, b, resolution=0.0, scale=None):
        a, b, both, either = _nan_mask(a, b)
        s = np.abs(b) if scale is None else scale
        with np.errstate(invalid="ignore"):
            ok = (a == b) | (np.abs(a - b) <= self.atol + self.rtol * s + np.asarray(resolution, dtype=float))
        return both | (~either & ok)


class Error(Class):
    name = "error"

    def __init__(self, factor: float = 2.0, floor: float = 0.0):
        if factor < 1:
            raise ValueError(f"error: factor must be at least 1, got {factor!r}")
        self.factor, self.floor = float(factor), float(floor)

    def accepts(self, a, b, resolution=0.0, scale=None):
        a, b, both, either = _nan_mask(a, b)
        with np.errstate(invalid="ignore", divide="ignore"):
            fa, fb = np.maximum(np.abs(a), self.floor), np.maximum(np.abs(b), self.floor)
            lo, hi = np.minimum(fa, fb), np.maximum(fa, fb)
            signs = (np.sign(a) == np.sign(b)) | (np.abs(a) <= self.floor) | (np.abs(b) <= self.floor)
            ok = signs & (hi <= self.factor * lo + np.asarray(resolution, dtype=float))
        return both | (~either & (ok | (a == b)))


class Order(Class):
    name = "order"

    def __init__(self, atol: float = 0.1):
        self.atol = float(atol)

    def accepts(self, a, b, resolution=0.0, scale=None):
        a, b, both, either = _nan_mask(a, b)
        with np.errstate(invalid="ignore"):
            return both | (~either & (np.abs(a - b) <= self.atol + np.asarray(resolution, dtype=float)))


class SolverPath(Class):
    name = "path"

    def __init__(self, factor: float = 3.0, slack: float = 10.0):
        self.factor, self.slack = float(factor), float(slack)

    def accepts(self, a, b, resolution=0.0, scale=None):
        a, b, both, either = _nan_mask(a, b)
        with np.errstate(invalid="ignore"):
            ok = (a <= self.factor * np.abs(b) + self.slack) & (a >= np.abs(b) / self.factor - self.slack)
        return both | (~either & ok)


CLASSES: dict[str, type[Class]] = {c.name: c for c in (Exact, Converged, Error, Order, SolverPath)}


def parse_class(spec: str) -> Class:
    """``"error(floor=1e-9)"`` -> ``Error(floor=1e-9)``: a class name, optionally called with keyword literals."""
    text = spec.strip()
    try:
        node = ast.parse(text, mode="eval").body
    except SyntaxError:
        raise ValueError(f"cannot read the class {spec!r} (e.g. 'converged' or 'error(floor=1e-9)')") from None
    name, kwargs = None, {}
    if isinstance(node, ast.Name):
        name = node.id
    elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and not node.args:
        name = node.func.id
        try:
            kwargs = {kw.arg: ast.literal_eval(kw.value) for kw in node.keywords}
        except ValueError:
            raise ValueError(f"the parameters of {spec!r} must be literals") from None
    if name not in CLASSES:
        raise ValueError(f"unknown class {spec!r}; the classes are {sorted(CLASSES)}")
    try:
        return CLASSES[name](**kwargs)
    except TypeError as exc:
        raise ValueError(f"{spec!r}: {exc}") from None


# -- numbers as written -------------------------------------------------------------------------------------------

NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w.])")
_SPECIAL = {"nan": math.nan, "inf": math.inf, "-inf": -math.inf, "+inf": math.inf}


def to_number(text) -> float | None:
    """The number ``text`` writes (``None`` when it is not one); an empty field is NaN."""
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        return float(text)
    if not isinstance(text, str):
        return None
    t = text.strip()
    if t == "":
        return math.nan
    if t.lower() in _SPECIAL:
        return _SPECIAL[t.lower()]
    if t in ("True", "False"):
        return None
    try:
        return float(t)
    except ValueError:
        return None


_WRITTEN = re.compile(r"\s*[-+]?(\d*)(?:\.(\d*))?(?:[eE]([-+]?\d+))?\s*")


def _written(text) -> tuple[int, int, int | None] | None:
    """``(decimals, significant digits, exponent or None)`` of a number as written, ``None`` for anything else."""
    m = _WRITTEN.fullmatch(text) if isinstance(text, str) else None
    if not m or not (m.group(1) or m.group(2)):
        return None
    digits = ((m.group(1) or "") + (m.group(2) or "")).lstrip("0")
    return len(m.group(2) or ""), max(len(digits), 1), int(m.group(3)) if m.group(3) else None


def resolution(text) -> float:
    """One unit of the last digit ``text`` prints: ``"0.4466"`` -> 1e-4, ``"4.6e-08"`` -> 1e-9, ``"5365"`` -> 1."""
    w = _written(text)
    return 0.0 if w is None else 10.0 ** ((w[2] or 0) - w[0])


def column_resolutions(texts) -> list[float]:
    """The resolution of each number of a column as written by one format.

    A fixed-point format (every number with the same decimals, no exponent: a Markdown table's ``.3f``) resolves
    one unit of its last decimal; a ``%g`` format, which drops trailing zeros (``0.5`` for 0.5000000000), resolves
    one unit of the column's most significant digits (the longest number written), relative to each value.
    """
    texts = list(texts)
    written = [_written(t) for t in texts]
    numbers = [w for w in written if w is not None]
    if not numbers:
        return [0.0] * len(texts)
    if all(w[2] is None and w[0] == numbers[0][0] for w in numbers):
        return [10.0 ** -numbers[0][0] if w is not None else 0.0 for w in written]
    significant = max(w[1] for w in numbers)
    out = []
    for t, w in zip(texts, written):
        x = to_number(t) if w is not None else None
        if x is None or not math.isfinite(x) or x == 0:
            out.append(0.0)
        else:
            out.append(10.0 ** (math.floor(math.log10(abs(x))) - significant + 1))
    return out


def text_differences(a: str, b: str, number_class: Class | None = None, where: str = "") -> list[str]:
    """Differences of a fresh text from the committed one: the words exactly, the numbers by ``number_class``."""
    number_class = number_class or Converged()
    label = f"{where}: " if where else ""
    if NUMBER.sub("#", a) != NUMBER.sub("#", b):
        return [f"{label}{a!r} != committed {b!r}"]
    out = []
    for x, y in zip(NUMBER.findall(a), NUMBER.findall(b)):
        if not bool(number_class.accepts(float(x), float(y), resolution(y))):
            out.append(f"{label}{x} != committed {y} ({number_class.describe()}) in {b!r}")
    return out


# -- what a notebook declares -------------------------------------------------------------------------------------

#: sections of a notebook's contract, the file each names and its suffixes
KINDS = {
    "tables": ("data/derived", (".csv",)),
    "json": ("data/derived", (".json",)),
    "markdown": ("data/derived", (".md",)),
    "figures": ("figures", (".png", ".pdf")),
}
FIGURE_DATA = "figures/data"  # <name>.json: the arrays a figure draws (compendium.figure_data)


@dataclass
class TableSpec:
    """The classes of a table's columns (a CSV, a JSON summary's keys or a Markdown table's columns).

    ``columns``: (name or glob pattern, class) in declaration order; ``key``: the columns that identify a row
    (a run's parameters), so that the rows of a run with other parameters are matched with the committed ones;
    ``statuses``: (status column, the columns it governs, ``None`` for the whole row): where the status says the
    run failed (boolean ``False``, or text not among ``succeeded``), the governed columns are not compared.
    ``only``: the rows that reproduce, as alternative conditions (column -> values as written); the others are what
    a search happened to find among many local solutions (the extremals restarts reached, the branch a
    continuation followed from a start that is itself such an outcome), listed but not compared.
    """

    name: str
    columns: list[tuple[str, Class]] = field(default_factory=list)
    key: list[str] = field(default_factory=list)
    statuses: list[tuple[str, list[str] | None]] = field(default_factory=list)
    succeeded: tuple[str, ...] = ("True",)
    only: list[dict[str, tuple[str, ...]]] = field(default_factory=list)

    def reproduces(self, row: Mapping) -> bool:
        """Whether a row is one the contract compares (:attr:`only`)."""
        if not self.only:
            return True
        for condition in self.only:
            if all(_same_field(row[c], values) for c, values in condition.items()):
                return True
        return False

    def class_of(self, column: str) -> Class | None:
        for pattern, cls in self.columns:
            if pattern == column:
                return cls
        for pattern, cls in self.columns:
            if "*" in pattern and fnmatch.fnmatchcase(column, pattern):
                return cls
        return None

    def undeclared(self, columns: Iterable[str]) -> list[str]:
        return [str(c) for c in columns if self.class_of(str(c)) is None]

    def failed(self, status_value) -> bool:
        """Whether a status field (as written) says its run failed."""
        return str(status_value).strip() not in self.succeeded

    def not_compared(self, fresh: Mapping, committed: Mapping, columns: Iterable[str]) -> set[str]:
        """The columns of a row pair that belong to a run that failed (in either): its numbers, never compared."""
        skip: set[str] = set()
        columns = list(columns)
        for status, governed in self.statuses:
            if self.failed(fresh[status]) or self.failed(committed[status]):
                skip |= set(governed) if governed is not None else set(columns) - set(self.key) - {status}
        return skip

    @classmethod
    def from_toml(cls, name: str, table: Mapping) -> TableSpec:
        spec = cls(name)
        for entry, value in table.items():
            if entry == "key":
                spec.key = _names(value, f"{name}.key")
            elif entry == "status":
                if isinstance(value, str):
                    spec.statuses = [(value, None)]
                elif isinstance(value, Mapping):
                    spec.statuses = [(k, _names(v, f"{name}.status.{k}")) for k, v in value.items()]
                else:
                    raise ValueError(f"{name}.status must name a column, or map columns to those they govern")
            elif entry == "succeeded":
                spec.succeeded = tuple(str(v) for v in _names(value, f"{name}.succeeded"))
            elif entry == "only":
                conditions = value if isinstance(value, list) else [value]
                if not all(isinstance(c, Mapping) for c in conditions):
                    raise ValueError(f"{name}.only must be a table (or a list of tables) of column = values")
                spec.only = [{c: tuple(_names(v, f"{name}.only.{c}")) for c, v in cond.items()} for cond in conditions]
            else:
                klass = parse_class(entry)
                spec.columns += [(c, klass) for c in _names(value, f"{name}.{entry}")]
        seen: dict[str, Class] = {}
        for column, klass in spec.columns:
            if column in seen and seen[column] != klass:
                raise ValueError(f"{name}: column {column!r} is declared twice ({seen[column]} and {klass})")
            seen[column] = klass
        named = spec.key + [s for s, _ in spec.statuses] + [c for _, g in spec.statuses for c in (g or [])]
        named += [c for cond in spec.only for c in cond]
        for column in named:
            if spec.class_of(column) is None:
                raise ValueError(f"{name}: the key or status column {column!r} needs a class too")
        return spec


_SELECTOR = re.compile(
    r"suptitle|(?P<axes>\d+|\*)(?:\[(?P<label>[^\]]+)\])?(?:\.(?P<part>x|y|z|c|title|xlabel|ylabel|legend|texts))?"
)


@dataclass
class FigureSpec:
    """The classes of what a figure draws, by selector: ``"1.y"`` (the y data of the second axes), ``"*.x"``, ``"0"``
    (every coordinate of the first axes), ``"0[interval ends]"`` (the artists of the first axes whose label matches
    the glob pattern), ``"0.legend"``, ``"0.title"``, ``"suptitle"``. Anything not selected: ``error()`` for y and z
    on a logarithmic axis (a magnitude is what it shows), ``converged(scale="column")`` otherwise (relative to the
    axis' span; x is a parameter or a mesh even on a logarithmic axis), numbers in texts ``converged``. An artist
    whose class is ``path`` (what a search found, an iteration history) is not compared, nor counted."""

    name: str
    selectors: list[tuple[str, Class]] = field(default_factory=list)

    def class_of(self, axes: int | None, part: str, scale: str | None = None, label: str | None = None) -> Class:
        if axes is None:
            candidates = [part]
        else:
            candidates = [f"{axes}.{part}", f"{axes}", f"*.{part}", "*"]
        for want in candidates:
            for selector, klass in self.selectors:
                if selector == want:
                    return klass
        if part in ("y", "z") and scale == "log":
            return Error()
        return Converged(scale="column")

    def artist_class(self, axes: int, label: str, part: str | None = None) -> Class | None:
        """The class a label selector gives the artist (``None`` when none selects it)."""
        for selector, klass in self.selectors:
            m = _SELECTOR.fullmatch(selector)
            if not m or m["label"] is None or m["axes"] not in (str(axes), "*"):
                continue
            if fnmatch.fnmatchcase(label, m["label"]) and (m["part"] is None or m["part"] == part):
                return klass
        return None

    @classmethod
    def from_toml(cls, name: str, table: Mapping) -> FigureSpec:
        spec = cls(name)
        for entry, value in table.items():
            klass = parse_class(entry)
            for selector in _names(value, f"{name}.{entry}"):
                if not _SELECTOR.fullmatch(selector):
                    raise ValueError(f"figure {name}: cannot read the selector {selector!r}")
                spec.selectors.append((selector, klass))
        return spec


@dataclass
class NotebookContract:
    notebook: str
    tables: dict[str, TableSpec] = field(default_factory=dict)
    json: dict[str, TableSpec] = field(default_factory=dict)
    markdown: dict[str, TableSpec] = field(default_factory=dict)
    figures: dict[str, FigureSpec] = field(default_factory=dict)

    def files(self) -> dict[str, tuple[str, TableSpec | FigureSpec]]:
        """Every file the notebook's published run writes: relative path -> (kind, spec)."""
        out: dict[str, tuple[str, TableSpec | FigureSpec]] = {}
        for kind, (folder, suffixes) in KINDS.items():
            for name, spec in getattr(self, kind).items():
                stem = name if kind != "markdown" else name.removesuffix(".md")
                for suffix in suffixes:
                    out[f"{folder}/{stem}{suffix}"] = (kind, spec)
                if kind == "figures":
                    out[f"{FIGURE_DATA}/{stem}.json"] = ("figure data", spec)
        return out


def _same_field(text, values) -> bool:
    """Whether a field as written is one of ``values`` (numbers by value: ``5`` is ``5.0``)."""
    x = to_number(text)
    for v in values:
        y = to_number(v)
        if (x is not None and y is not None and x == y) or str(text).strip() == str(v).strip():
            return True
    return False


def _names(value, where: str) -> list[str]:
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list) or not all(isinstance(v, (str, bool, int, float)) for v in value):
        raise ValueError(f"{where} must be a list of names, got {value!r}")
    return [str(v) for v in value]


@dataclass
class Contract:
    """``notebooks/contract.toml`` read: one :class:`NotebookContract` per notebook."""

    notebooks: dict[str, NotebookContract]
    path: Path | None = None

    def __getitem__(self, notebook: str) -> NotebookContract:
        if notebook not in self.notebooks:
            where = self.path or CONTRACT_FILE
            raise KeyError(f"{where} has no section for the notebook {notebook!r}")
        return self.notebooks[notebook]

    def __contains__(self, notebook: str) -> bool:
        return notebook in self.notebooks

    @classmethod
    def parse(cls, text: str, path: Path | None = None) -> Contract:
        data = tomllib.loads(text)
        notebooks = {}
        for notebook, sections in data.items():
            nc = NotebookContract(notebook)
            for kind, entries in sections.items():
                if kind not in KINDS:
                    raise ValueError(f"{notebook}: unknown section {kind!r}; the sections are {sorted(KINDS)}")
                for name, table in entries.items():
                    if kind == "figures":
                        nc.figures[name] = FigureSpec.from_toml(name, table)
                    else:
                        getattr(nc, kind)[name] = TableSpec.from_toml(name, table)
            notebooks[notebook] = nc
        return cls(notebooks, path)

    @classmethod
    def load(cls, root: Path) -> Contract:
        path = Path(root) / CONTRACT_FILE
        return cls.parse(path.read_text(), path)


def load_contract(root: Path | None = None) -> Contract:
    """The contract of the compendium at ``root`` (default: this repository)."""
    if root is None:
        from .paths import repo_root

        root = repo_root()
    return Contract.load(root)
