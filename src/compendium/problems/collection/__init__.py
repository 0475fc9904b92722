"""The reference collection: published optimal-control problems, each stated once with its source, its constants in
``data/problems/`` and its published values in ``data/paper/`` (issue 44; notebook 11, the site's gallery).

A :class:`Reference` is one problem of the collection: how to state it (:attr:`~Reference.make`), where it was
published (:attr:`~Reference.source`, with the section or example), which of its published values is compared
(:attr:`~Reference.paper`: a table of ``data/paper`` and the row's problem and quantity; each row says whether the
value is a converged continuous optimum or the optimum of its source's own discretisation, and which mesh), how a
solution gives that value (:attr:`~Reference.value`, in the published units and sense), and what it exercises
(:data:`EXERCISES`). The modules of this package register them by source (:func:`register`); :data:`REFERENCES`
holds them by name, in the order registered.

A published table of the collection (``data/paper/collection_*.csv``) has the columns ``problem, quantity, value,
digits, kind, mesh, source``: ``digits`` the significant digits printed, ``kind`` ``continuous`` (a converged
optimum of the continuous problem, or a closed form) or ``discretised`` (the optimum of the source's own NLP, with
``mesh`` saying which: e.g. ``COPS nh = 800, trapezoidal``), ``source`` the document and its section, table or
example.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from ocpkit import HLGL, Program, Radau

from ...paper import paper_table
from .._data import load_problem_data

#: What a problem exercises, the gallery's groups (a problem has one or more)
EXERCISES: dict[str, str] = {
    "smooth": "smooth solutions, unconstrained controls",
    "closed-form": "a closed-form solution",
    "free-final-time": "a free final time",
    "bang-bang": "bang-bang controls",
    "singular-arc": "singular arcs",
    "path-constraint": "path constraints on states and controls",
    "state-constraint-1": "state constraints of order one",
    "state-constraint-2": "state constraints of order two",
    "mixed-constraint": "mixed state-control constraints",
    "multi-phase": "several phases",
    "parameter-estimation": "parameter estimation and static parameters",
    "stiff": "stiff dynamics and boundary layers",
    "unscaled": "unscaled statements",
    "aerospace": "aerospace trajectories",
}

#: The modules that register problems, by source
MODULES = ("seeds", "classics", "cops", "betts", "mintoc", "psopt", "gpops", "ocpjl", "dymos", "opty")

#: What a published value is: the continuous problem's optimum, or the optimum of its source's discretisation (the
#: mesh named in ``Reference.mesh``)
KINDS = ("continuous", "discretised")


def _digits(value: float) -> int:
    """The significant digits of a value as printed (its shortest repr), where a table does not say."""
    mantissa = repr(abs(float(value))).split("e")[0].replace(".", "").lstrip("0")
    return max(len(mantissa.rstrip("0")) if "." not in repr(float(value)) else len(mantissa), 1)


def _objective(solution: Any) -> float:
    return float(solution.objective)


@dataclass(frozen=True)
class Reference:
    """One problem of the collection (module docstring).

            ``make()`` states it (an :class:`~ocpkit.OptimalControlProblem` or a :class:`~ocpkit.MultiPhaseProblem`);
            ``program(scheme)``, where given, transcribes it instead of ``Program(make(), scheme)`` (a parameter estimation
            whose cost reads the data at fixed times); ``paper``: the table of ``data/paper`` and the ``problem`` of its rows
            (default the reference's name), and ``quantity`` the row compared; ``closed_form``: the exact value, where there is
            one (then compared instead of, or besides, the published row); ``value(solution)``: the solution's value in the
            published units and sense (default its objective); ``start``: Radau's nodes per interval and the number of
            intervals refinement starts from (HLGL starts from as many intervals); ``agreement``: how closely the two
            schemes' converged values can be expected to agree, relative (1e-8; larger where ``why`` says why: a singular
            arc, a state constraint met at points only); ``differs``: why the converged value differs from the published one
        where it does (a typo, another statement), with the evidence; ``tightest``: the tightest tolerance its converged value is refined to, where it is not the study's (1e-9) (a
    comment says why); ``ipopt_options``: IPOPT's options as the source solves it (the refinement tables use them; the solve at
        defaults does not); ``indirect``: cross-checked by :func:`ocpkit.indirect.to_extremal` (False where the chain takes minutes: its
        ``why``-less opt-out names the reason in a comment); ``fast``: among the rows ``make test``
        computes."""

    name: str
    title: str
    source: str
    make: Callable[[], Any] | None
    exercises: tuple[str, ...]
    paper: tuple[str, str] | None = None
    quantity: str = "objective"
    closed_form: Callable[[], float] | None = None
    value: Callable[[Any], float] = _objective
    program: Callable[[Any], Program] | None = None
    guess: Callable[[], Any] | None = None
    ipopt_options: dict[str, Any] = field(default_factory=dict)
    kind: str = "continuous"
    mesh: str = ""
    start: tuple[int, int] = (4, 10)
    agreement: float = 1e-8
    why: str = ""
    statement: str = ""
    differs: str = ""
    max_mesh_iterations: int = 15
    tightest: float | None = None
    indirect: bool = True
    fast: bool = False

    def __post_init__(self) -> None:
        unknown = set(self.exercises) - set(EXERCISES)
        if unknown:
            raise ValueError(f"{self.name}: unknown exercises {sorted(unknown)}; known: {sorted(EXERCISES)}")
        if self.make is None and self.program is None:
            raise ValueError(f"{self.name}: give how to state it (make=) or its program (program=)")
        if self.paper is None and self.closed_form is None:
            raise ValueError(f"{self.name}: give its published value (paper=) or its closed form (closed_form=)")

    # -- its transcriptions -------------------------------------------------------------------------------------
    def scheme(self, name: str, start: tuple[int, int] | None = None):
        """The scheme ``name`` (``"HLGL"`` or ``"Radau"``) at the reference's start (or ``start``), unbound."""
        nodes, intervals = start or self.start
        if name == "HLGL":
            return HLGL(intervals=intervals)
        if name == "Radau":
            return Radau(nodes=nodes, intervals=intervals)
        raise ValueError(f"scheme must be 'HLGL' or 'Radau', got {name!r}")

    def transcribe(self, scheme: Any) -> Program:
        """The reference's program on ``scheme``."""
        if self.program is not None:
            return self.program(scheme)
        assert self.make is not None  # (checked on construction)
        return Program(self.make(), scheme)

    # -- its published value ------------------------------------------------------------------------------------
    def published_rows(self) -> pd.DataFrame:
        """Its rows of its published table (every quantity), empty without one."""
        if self.paper is None:
            return pd.DataFrame(columns=["problem", "quantity", "value", "digits", "kind", "mesh", "source"])
        table, problem = self.paper
        rows = paper_table(table)
        if problem is not None:
            rows = rows[rows.problem == problem]
        if rows.empty:
            raise LookupError(f"{self.name}: no rows of problem {problem!r} in data/paper/{table}.csv")
        return rows

    def published(self) -> dict[str, Any]:
        """The compared published value: ``value``, ``digits``, ``kind``, ``mesh``, ``source`` (the closed form's,
        kind ``closed form``, where there is no published row)."""
        rows = self.published_rows()
        if not rows.empty:
            row = rows[rows.quantity == self.quantity]
            if row.empty:
                raise LookupError(f"{self.name}: no quantity {self.quantity!r} among {list(rows.quantity)}")
            r = row.iloc[0]
            return {
                "value": float(r.value),
                "digits": int(r["digits"]) if "digits" in r.index else _digits(r["value"]),
                "kind": str(r["kind"]) if "kind" in r.index else self.kind,
                "mesh": str(r["mesh"]) if "mesh" in r.index and not pd.isna(r["mesh"]) else self.mesh,
                "source": str(r["source"]) if "source" in r.index else self.source,
            }
        return {"value": float(self.closed_form()), "digits": 16, "kind": "closed form", "mesh": "", "source": ""}

    def spread(self) -> float:
        """How far (relative) the published sources of the compared value disagree: the rows of the same problem
        whose quantity starts with the compared one (``objective`` and ``objective_gpops2``); 0 with one source."""
        rows = self.published_rows()
        if rows.empty:
            return 0.0
        values = rows[rows.quantity.str.startswith(self.quantity)].value.to_numpy(float)
        return float((values.max() - values.min()) / abs(self.published()["value"])) if values.size > 1 else 0.0

    def rounding(self) -> float:
        """Half a unit in the last digit the published value prints, relative to it (0 for a closed form)."""
        p = self.published()
        if p["kind"] == "closed form" or p["value"] == 0:
            return 0.0
        value = abs(p["value"])
        return 0.5 * 10.0 ** (math.floor(math.log10(value)) - p["digits"] + 1) / value


#: Every reference, by name, in the order registered
REFERENCES: dict[str, Reference] = {}


def constants(table: str, key: str) -> dict:
    """A problem's constants: the entry ``key`` of ``data/problems/<table>.toml`` (each family module's table)."""
    return load_problem_data(table)[key]


def register(*references: Reference) -> None:
    """Add references to :data:`REFERENCES` (a name is registered once)."""
    for reference in references:
        if reference.name in REFERENCES:
            raise ValueError(f"reference {reference.name!r} is registered twice")
        REFERENCES[reference.name] = reference


def references(names: Iterable[str] | None = None, *, fast: bool | None = None) -> list[Reference]:
    """The references named (default all), or only the fast ones (``fast=True``)."""
    chosen = list(REFERENCES.values()) if names is None else [reference(n) for n in names]
    return [r for r in chosen if fast is None or r.fast == fast]


def reference(name: str) -> Reference:
    """The reference ``name``, or a KeyError listing the known ones."""
    try:
        return REFERENCES[name]
    except KeyError:
        raise KeyError(f"no reference {name!r}; known: {sorted(REFERENCES)}") from None


def relative(a: float, b: float) -> float:
    """``|a - b| / max(|b|, 1e-300)``; NaN where either is NaN."""
    return float(abs(a - b) / max(abs(b), 1e-300)) if np.isfinite(a) and np.isfinite(b) else float("nan")


for _module in MODULES:
    importlib.import_module(f"{__name__}.{_module}")

__all__ = [
    "EXERCISES",
    "KINDS",
    "REFERENCES",
    "Reference",
    "constants",
    "reference",
    "references",
    "register",
    "relative",
]
