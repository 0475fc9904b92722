"""The reference collection's tables (notebook 11): for every problem of :mod:`compendium.problems.collection`, its
converged value, its mesh-refinement table and the solve at defaults, computed point by point on Dask
(:func:`compendium.sweep.sweep`, one point per problem, scheme and tolerance).

* **converged value**: refined to :data:`CONVERGED` (1e-9) with HLGL and with Radau from the reference's start; the
  reference value is Radau's where it met the tolerance (else HLGL's), and the two schemes' relative difference is
  reported against the reference's ``agreement``; where :func:`ocpkit.indirect.to_extremal` certifies an extremal
  from Radau's solution refined to :data:`INDIRECT`, its value cross-checks it;
* **mesh-refinement table**: HLGL and Radau refined to each of :data:`TOLERANCES` from the same start: the meshes,
  intervals, collocation points, IPOPT iterations, time, the error estimate (the largest part of the solution's
  :class:`~ocpkit.accuracy.Accuracy`) and the true error against the converged value; every mesh of every refinement
  is a row of the history (:func:`history`), with its breakpoints, so that another tool's refinement can be compared
  row by row;
* **solve at defaults**: :data:`DEFAULT_CALL`, one call from the statement alone; it is *right* when it converges,
  its refinement says the tolerance is met and its value lies within :func:`right_within` of the converged value,
  *failed* with a named reason (IPOPT's status, or the refinement's) when it says it is not, and *wrong* when it
  claims a tolerance its value does not meet (the collection's defect to fix).
"""

from __future__ import annotations

import json
import time
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from ocpkit import Radau, SolverError
from ocpkit.accuracy import AccuracyWarning
from ocpkit.verdict import SolutionNote

from ..problems.collection import EXERCISES, Reference, reference, references, relative

#: The tolerance of the converged value
CONVERGED = 1e-9
#: The tolerances of the mesh-refinement tables
TOLERANCES = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
#: A converged value refined no further than this is replaced by a certified extremal's, where there is one
LOOSE = 1e-7
#: The tolerance of the direct solution the indirect cross-check starts from
INDIRECT = 1e-7
#: The solve at defaults: Radau's default transcription (one interval of 20 nodes), refined to this tolerance
DEFAULT_TOLERANCE = 1e-6
DEFAULT_CALL = f"Radau(problem).solve(mesh_tolerance={DEFAULT_TOLERANCE:g})"
#: The schemes of the tables
SCHEMES = ("HLGL", "Radau")


def right_within(ref: Reference) -> float:
    """How close (relative) the solve at defaults must come to the converged value to be right: ten times its
    tolerance (an estimate is an estimate), or the reference's stated ``agreement`` where that is larger."""
    return max(10 * DEFAULT_TOLERANCE, ref.agreement)


def points(refs: Sequence[Reference], tolerances: Sequence[float] = TOLERANCES, *, indirect: bool = True) -> list:
    """The sweep's points: per problem, each scheme's chain of refinements (:func:`chain`: every tolerance, then
    :data:`CONVERGED`), the solve at defaults and (``indirect``, where the reference asks for it) the indirect
    cross-check."""
    chained = " ".join(f"{t:g}" for t in tolerances)
    out = []
    for ref in refs:
        for scheme in SCHEMES:
            out.append({"problem": ref.name, "scheme": scheme, "tolerance": chained})
        out.append({"problem": ref.name, "scheme": "defaults", "tolerance": f"{DEFAULT_TOLERANCE:g}"})
        if indirect and ref.indirect:
            out.append({"problem": ref.name, "scheme": "indirect", "tolerance": f"{INDIRECT:g}"})
    return out


def _mesh_rows(solution: Any) -> list[dict]:
    rows = []
    for m in solution.mesh_history:
        breaks = np.concatenate([[0.0], np.cumsum(m.fractions)])
        rows.append(
            {
                "iteration": m.iteration,
                "transcription": m.transcription,
                "intervals": len(m.fractions),
                "points": m.collocation_points,
                "decision_variables": m.decision_variables,
                "estimate": m.error_estimate,
                "worst": m.worst,
                "failing": " ".join(m.failing),
                "ipopt_iterations": m.ipopt_iterations,
                "build_s": m.build_s,
                "solve_s": m.solve_s,
                "recovery": m.recovery,
                "breakpoints": " ".join(f"{b:.10g}" for b in breaks),
            }
        )
    return rows


def _refined(ref: Reference, scheme: Any, tolerance: float, *, defaults: bool = False) -> dict:
    """One refinement of ``ref`` on ``scheme`` to ``tolerance``: its row (a failed mesh raises SolverError). At
    ``defaults``, with the library's defaults (not the reference's IPOPT options and mesh limit)."""
    start = time.perf_counter()
    program = ref.transcribe(scheme)
    guess = ref.guess() if ref.guess is not None else None
    if defaults:  # one call, as a user makes it: the library's own limits and options
        solution = program.solve(guess, mesh_tolerance=tolerance)
    else:
        solution = program.solve(
            guess,
            mesh_tolerance=tolerance,
            max_mesh_iterations=ref.max_mesh_iterations,
            ipopt_options=ref.ipopt_options or None,
        )
    seconds = time.perf_counter() - start
    part, estimate = solution.accuracy.worst
    history = _mesh_rows(solution)
    return {
        "outcome": solution.refinement_outcome,
        "reason": solution.refinement_reason or "",
        "met": bool(solution.refinement_outcome == "met" and not solution.accuracy.failing(tolerance)),
        "value": ref.value(solution),
        "meshes": len(history),
        "intervals": history[-1]["intervals"],
        "points": history[-1]["points"],
        "ipopt_iterations": int(sum(h["ipopt_iterations"] for h in history)),
        "estimate": float(estimate),
        "estimate_part": part,
        "time_s": seconds,
        "history": json.dumps(history),
    }


def _indirect(ref: Reference) -> dict:
    """The certified extremal from Radau's solution refined to :data:`INDIRECT`. Where the refinement meets it, from
    the refined solution alone; where it stops short (it stalls, runs out of meshes or stops), from the solution the
    refinement returns first, the direct solution nearest the extremal, then from the solution on the reference's
    start mesh; where the refinement fails (a singular arc on which collocation chatters: IPOPT stops at its
    acceptable level), from the start mesh's, as notebook 10 starts catalyst mixing. The reason names the start the
    extremal came from, and the starts tried before it; the last start's errors are the row's. The tumour's
    refinement to 1e-7 can end short on some 500 points, from which its extremal is certified, and not from its
    40-point start mesh."""
    from ocpkit.indirect import to_extremal

    guess = ref.guess() if ref.guess is not None else None
    options = ref.ipopt_options or None
    starts: list[tuple[str, Any]] = []
    try:
        refined = ref.transcribe(ref.scheme("Radau")).solve(
            guess, mesh_tolerance=INDIRECT, max_mesh_iterations=ref.max_mesh_iterations, ipopt_options=options
        )
        met = refined.refinement_outcome == "met"
        label = (
            "refined mesh" if met else f"refinement's last mesh ({refined.refinement_outcome}, short of {INDIRECT:g})"
        )
        starts.append((label, lambda: refined))
    except SolverError:
        met = False
    if not met:
        starts.append(("start mesh", lambda: ref.transcribe(ref.scheme("Radau")).solve(guess, ipopt_options=options)))
    tried, spent = [], 0.0  # the starts not certified; the chain's time from each (not the direct solves')
    for k, (start, direct) in enumerate(starts):
        solution, last = direct(), k == len(starts) - 1
        clock = time.perf_counter()
        try:
            extremal = to_extremal(solution, raise_on_failure=False)
        except (SolverError, ValueError) as exc:
            if last:
                raise
            tried.append(f"from its {start}: {exc}")
            continue
        finally:
            spent += time.perf_counter() - clock
        certified = bool(extremal.converged and extremal.certificate.passed)
        if certified or last:
            break
        tried.append(f"from its {start}: {extremal.status.name} {', '.join(extremal.certificate.failed)}".strip())
    value = float("nan")
    if certified:
        try:
            value = float(ref.value(extremal.trajectory))
        except Exception:  # noqa: BLE001 - a value only a direct solution gives (several phases): no cross-check
            value = float("nan")
    failed = ", ".join(extremal.certificate.failed) if not certified else ""
    before = f" (not certified {'; '.join(tried)})" if tried else ""
    return {
        "outcome": "certified" if certified else f"not certified: {extremal.status.name} {failed}".strip(),
        "reason": f"from Radau's solution on its {start}{before}" + ("" if certified else f"; {extremal.detail}"),
        "met": certified,
        "value": value,
        "time_s": spent,
    }


def chain(ref: Reference, scheme: str, tolerances: Sequence[float]) -> list[dict]:
    """``ref`` refined on ``scheme`` to each tolerance, loosest first, then to :data:`CONVERGED`: a row per tolerance
    (``ok``, ``status`` and ``error`` as :func:`compendium.sweep.run_point` writes them). Once a tolerance is not met
    (the refinement stalled, ran out of meshes, or a mesh's solve failed), the tighter ones are not run: their rows
    say so (status ``skipped``), since a refinement that cannot meet a tolerance does not meet a smaller one and
    would only spend its meshes finding that out."""
    rows, blocked = [], ""
    for tol in (*sorted(tolerances, reverse=True), CONVERGED):
        row: dict[str, Any] = {"tolerance": tol, "ok": True, "status": "ok", "error": ""}
        if ref.tightest is not None and tol < ref.tightest and not blocked:
            blocked = f"not run: the problem is refined to {ref.tightest:g} at most (its reference says why)"
        if blocked:
            rows.append(row | {"ok": False, "status": "skipped", "error": blocked})
            continue
        try:
            row |= _refined(ref, ref.scheme(scheme), tol)
        except SolverError as exc:
            row |= {"ok": False, "status": exc.status, "error": str(exc)}
        if not (row["ok"] and row["met"]):
            blocked = f"not run: the refinement to {tol:g} did not meet it ({row.get('outcome', row['status'])})"
        rows.append(row)
    return rows


def collection_point(problem: str, scheme: str, tolerance: str) -> dict:
    """One point of the sweep (a module-level function, for Dask's workers): the chain of refinements of
    ``problem`` on ``scheme`` (``"HLGL"``, ``"Radau"``) to the tolerances ``tolerance`` (space-separated; its rows as
    JSON in ``chain``), its solve at defaults (``"defaults"``) or its indirect cross-check (``"indirect"``)."""
    ref = reference(problem)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)  # the rows say how each refinement ended
        warnings.simplefilter("ignore", SolutionNote)
        if scheme == "indirect":
            return _indirect(ref)
        if scheme == "defaults":
            return _refined(ref, Radau(), float(tolerance), defaults=True)
        return {"chain": json.dumps(chain(ref, scheme, [float(t) for t in tolerance.split()]))}


def expand(swept: pd.DataFrame) -> pd.DataFrame:
    """The sweep's rows with each chain as its rows: one row per problem, scheme (or ``defaults``, ``indirect``)
    and tolerance."""
    out = []
    for _, r in swept.iterrows():
        point = r.to_dict()
        if point["scheme"] in SCHEMES:
            tolerances = [float(t) for t in str(point["tolerance"]).split()]
            if point["ok"]:
                for row in json.loads(point["chain"]):
                    out.append({"problem": point["problem"], "scheme": point["scheme"], **row})
            else:  # the chain itself failed (not a solve: those are its rows)
                for tol in (*tolerances, CONVERGED):
                    out.append({"problem": point["problem"], "scheme": point["scheme"], "tolerance": tol,
                                "ok": False, "status": point["status"], "error": point["error"]})  # fmt: skip
        else:
            out.append({k: v for k, v in point.items() if k != "chain"} | {"tolerance": float(point["tolerance"])})
    rows = pd.DataFrame(out)
    for column in ("met", "outcome", "reason", "value", "meshes", "history"):
        if column not in rows:
            rows[column] = np.nan
    rows["met"] = rows.met.fillna(False).astype(bool)
    rows["ok"] = rows.ok.astype(bool)
    return rows


def run(
    names: Sequence[str] | None = None,
    *,
    tolerances: Sequence[float] = TOLERANCES,
    indirect: bool = True,
    workers: int = 2,
    cache: str | None = None,
    progress: bool = True,
) -> pd.DataFrame:
    """Every point of the problems ``names`` (default all) on ``workers`` processes, expanded (:func:`expand`):
    one row per problem, scheme and tolerance."""
    from ..sweep import sweep

    refs = references(names)
    swept = sweep(
        collection_point, points(refs, tolerances, indirect=indirect), workers=workers, cache=cache, progress=progress
    )
    return expand(swept)


# -- the tables ----------------------------------------------------------------------------------------------------
def _get(rows: pd.DataFrame, problem: str, scheme: str, tolerance: float) -> pd.Series | None:
    hit = rows[(rows.problem == problem) & (rows.scheme == scheme) & np.isclose(rows.tolerance, tolerance)]
    return None if hit.empty else hit.iloc[0]


def _value(row: pd.Series | None) -> float:
    return float(row["value"]) if row is not None and bool(row["ok"]) else float("nan")


def _outcome(row: pd.Series | None) -> str:
    if row is None:
        return "not run"
    return str(row["outcome"]) if bool(row["ok"]) else str(row["status"])


def converged_value(rows: pd.DataFrame, problem: str) -> tuple[float, str, float]:
    """The converged value of ``problem``, which gave it and to which tolerance: the refinement that met the
    smallest tolerance (:data:`CONVERGED` where it can; Radau's where both met it). A problem whose refinements stop
    above :data:`LOOSE` (a bang-bang or singular arc converges at a low order; collocation chatters on a singular
    arc) gives the certified extremal's value where there is one (``"indirect"``, to its shooting's tolerance,
    tolerance NaN), else the value at the tightest tolerance met, which the table says; NaN where there is neither."""
    met = rows[(rows.problem == problem) & rows.scheme.isin(SCHEMES) & rows.ok]
    met = met[met.met.astype(bool)] if not met.empty else met
    best = None
    if not met.empty:
        best = met.assign(order=met.scheme.map({"Radau": 0, "HLGL": 1})).sort_values(["tolerance", "order"]).iloc[0]
    if best is None or float(best["tolerance"]) > LOOSE:
        indirect = _get(rows, problem, "indirect", INDIRECT)
        if indirect is not None and bool(indirect["ok"]) and bool(indirect["met"]) and np.isfinite(indirect["value"]):
            return float(indirect["value"]), "indirect", float("nan")
    if best is None:
        return float("nan"), "", float("nan")
    return float(best["value"]), str(best["scheme"]), float(best["tolerance"])


def _tightest(rows: pd.DataFrame, problem: str, scheme: str) -> tuple[pd.Series | None, float]:
    """The row of the tightest tolerance ``scheme`` met on ``problem``, and that tolerance (None, NaN: none)."""
    mine = rows[(rows.problem == problem) & (rows.scheme == scheme) & rows.ok]
    mine = mine[mine.met.astype(bool)]
    if mine.empty:
        return None, float("nan")
    best = mine.sort_values("tolerance").iloc[0]
    return best, float(best["tolerance"])


def published_verdict(ref: Reference, reference_value: float) -> tuple[str, float, float]:
    """Whether the converged value reproduces the published one: ``(verdict, difference, reach)``, the relative
    difference and how close it can be shown to agree (the printed digits' rounding, the published sources' spread,
    the schemes' agreement)."""
    published = ref.published()
    difference = relative(reference_value, published["value"])
    reach = max(ref.rounding(), ref.spread(), ref.agreement, 10 * CONVERGED)
    if not np.isfinite(difference):
        return "not converged", difference, reach
    if difference <= reach:
        return "reproduced", difference, reach
    if published["kind"] == "discretised":
        why = f"; {ref.differs}" if ref.differs else ""
        return f"differs: the value of a discretisation ({published['mesh']}){why}", difference, reach
    if ref.differs:
        return f"differs: {ref.differs}", difference, reach
    return "differs: unexplained", difference, reach


def problem_table(rows: pd.DataFrame, refs: Sequence[Reference] | None = None) -> pd.DataFrame:
    """``data/derived/reference_collection.csv``: one row per problem."""
    if refs is None:
        order = references_names()
        refs = references(sorted(set(rows.problem), key=order.index))
    out = []
    for ref in refs:
        value, by, reached = converged_value(rows, ref.name)
        published = ref.published()
        verdict, difference, reach = published_verdict(ref, value)
        (hlgl, hlgl_tol), (radau, radau_tol) = (_tightest(rows, ref.name, s) for s in SCHEMES)
        agree = relative(_value(hlgl), _value(radau))
        expected = max(ref.agreement, 10 * np.nanmax([hlgl_tol, radau_tol, CONVERGED]))
        default = _get(rows, ref.name, "defaults", DEFAULT_TOLERANCE)
        default_value = _value(default)
        default_error = relative(default_value, value)
        if default is None:
            default_verdict, default_reason = "not run", ""
        elif not bool(default["ok"]):
            default_verdict, default_reason = "failed", f"{default['status']}: {str(default['error'])[:200]}"
        elif not bool(default["met"]):
            default_verdict, default_reason = "failed", f"{default['outcome']}: {str(default['reason'])[:200]}"
        elif np.isfinite(default_error) and default_error <= right_within(ref):
            default_verdict, default_reason = "right", ""
        elif not np.isfinite(value):
            default_verdict, default_reason = "unchecked", "no converged value to check it against"
        else:
            default_verdict, default_reason = "wrong", f"met its tolerance, but {default_error:.1e} from the value"
        indirect = _get(rows, ref.name, "indirect", INDIRECT)
        indirect_value = _value(indirect)
        closed = float(ref.closed_form()) if ref.closed_form is not None else float("nan")
        out.append(
            {
                "problem": ref.name,
                "title": ref.title,
                "source": ref.source,
                "exercises": " ".join(ref.exercises),
                "quantity": ref.quantity,
                "published": published["value"],
                "published_kind": published["kind"],
                "published_mesh": published["mesh"],
                "published_digits": published["digits"],
                "closed_form": closed,
                "hlgl": _value(hlgl),
                "hlgl_tolerance": hlgl_tol,
                "hlgl_outcome": _outcome(_get(rows, ref.name, "HLGL", CONVERGED)),
                "radau": _value(radau),
                "radau_tolerance": radau_tol,
                "radau_outcome": _outcome(_get(rows, ref.name, "Radau", CONVERGED)),
                "value": value,
                "value_by": by,
                "value_tolerance": reached,
                "schemes_differ": agree,
                "agreement": expected,
                "schemes_agree": bool(np.isfinite(agree) and agree <= expected),
                "agreement_why": ref.why,
                "closed_form_difference": relative(value, closed),
                "published_difference": difference,
                "published_reach": reach,
                "published_verdict": verdict,
                "indirect": _outcome(indirect) if ref.indirect else "not tried",
                "indirect_reason": ""
                if indirect is None
                else str(indirect["reason"] if bool(indirect["ok"]) else indirect["error"])[:200],
                "indirect_value": indirect_value,
                "indirect_difference": relative(indirect_value, value) if by != "indirect" else float("nan"),
                "defaults": default_verdict,
                "defaults_value": default_value,
                "defaults_error": default_error,
                "defaults_meshes": int(default["meshes"]) if default is not None and bool(default["ok"]) else -1,
                "defaults_reason": default_reason,
            }
        )
    return pd.DataFrame(out)


def references_names() -> list[str]:
    return [r.name for r in references()]


def mesh_table(rows: pd.DataFrame) -> pd.DataFrame:
    """``data/derived/reference_collection_meshes.csv``: one row per problem, scheme and tolerance (the converged
    value's refinements too), with the true error against the converged value."""
    table = rows[rows.scheme.isin(SCHEMES)].copy()
    values = {p: converged_value(rows, p)[0] for p in table.problem.unique()}
    table["outcome"] = [_outcome(r) for _, r in table.iterrows()]
    table["true_error"] = [relative(float(r["value"]), values[r["problem"]]) if r["ok"] else np.nan
                           for _, r in table.iterrows()]  # fmt: skip
    columns = ["problem", "scheme", "tolerance", "outcome", "met", "meshes", "intervals", "points",
               "ipopt_iterations", "time_s", "estimate", "estimate_part", "value", "true_error", "reason"]  # fmt: skip
    for c in columns:
        if c not in table:
            table[c] = np.nan
    return table[columns].reset_index(drop=True)


def history(rows: pd.DataFrame) -> pd.DataFrame:
    """``data/derived/reference_collection_history.csv``: every mesh of every refinement (problem, scheme, tolerance,
    iteration), with its breakpoints (fractions of the horizon), size, estimate and IPOPT iterations."""
    out = []
    for _, r in rows[rows.scheme.isin(SCHEMES) & rows.ok].iterrows():
        for h in json.loads(r["history"]):
            out.append({"problem": r["problem"], "scheme": r["scheme"], "tolerance": r["tolerance"], **h})
    return pd.DataFrame(out)


def exercised(table: pd.DataFrame) -> pd.DataFrame:
    """How many problems exercise each of :data:`EXERCISES`, and how many of them are right at defaults."""
    out = []
    for tag, words in EXERCISES.items():
        mine = table[table.exercises.str.split().apply(lambda t, tag=tag: tag in t)]
        out.append(
            {
                "exercises": tag,
                "what": words,
                "problems": len(mine),
                "right_at_defaults": int((mine.defaults == "right").sum()),
            }
        )
    return pd.DataFrame(out)


__all__ = [
    "CONVERGED",
    "DEFAULT_CALL",
    "DEFAULT_TOLERANCE",
    "INDIRECT",
    "LOOSE",
    "SCHEMES",
    "TOLERANCES",
    "chain",
    "collection_point",
    "expand",
    "converged_value",
    "exercised",
    "history",
    "mesh_table",
    "points",
    "problem_table",
    "published_verdict",
    "right_within",
    "run",
]
