"""Parameter sweeps on Dask: many independent solves, on this machine or a cluster.

    table = sweep(task, points, cache="build/sweeps/thrust.csv")

``task`` is a function of keyword arguments returning a dict of results (a module-level function,
so that workers can import it); ``points`` a list of dicts (or a DataFrame), one solve each. Every
point runs as a Dask task on a ``dask.distributed`` cluster:

* ``client``: a :class:`distributed.Client` of your own; else
* ``scheduler``: the address of a running scheduler (``"tcp://host:8786"``: a cluster started by
  ``dask scheduler`` / ``dask worker``, by dask-jobqueue on a batch system, by dask-kubernetes...);
  its workers need this repository's environment (``make setup``) and ``src`` importable; else
* a :class:`distributed.LocalCluster` of ``workers`` processes (one thread each: CasADi and IPOPT are
  not thread-parallel here) started for the sweep and closed after it.

The result is a :class:`pandas.DataFrame` with one row per point, in the order of ``points``: the
point's columns, the task's results, and ``status`` (``"ok"``, IPOPT's status of a failed solve, or
the exception's type), ``ok`` and ``error`` (the message). A failed point is recorded, never dropped
and never given results: plot ``table[table.ok]`` and mark the others. With ``cache`` (a CSV file),
each finished point is appended as it arrives, and a re-run skips the points already there (failed
ones too, unless ``retry_failed``): an interrupted sweep resumes where it stopped. A point that kills
its worker (a crash, memory) is a failed point too, with the exception's type as its status. The cache is
CSV: results come back as numbers or strings as pandas reads them (a string like ``"007"`` as a number).
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import pandas as pd

from ocpkit import SolverError

#: Columns the sweep adds to every row
STATUS_COLUMNS = ("status", "ok", "error", "wall_s", "worker")


def point_key(point: Mapping) -> str:
    """A point's identity in the cache: its items as canonical JSON (floats to full precision)."""
    return json.dumps({k: _plain(v) for k, v in sorted(point.items())}, sort_keys=True)


def _plain(value):
    if hasattr(value, "item"):  # numpy scalars
        value = value.item()
    if isinstance(value, int) and not isinstance(value, bool):
        value = float(value)  # 2 and 2.0 are the same point
    if isinstance(value, float) and not math.isfinite(value):
        return repr(value)
    return value


def run_point(task: Callable, point: Mapping) -> dict:
    """Run ``task(**point)`` and record how it ended; never raises (a failure is a row, not a crash)."""
    from distributed import get_worker

    try:
        worker = get_worker().name
    except ValueError:  # not on a worker (run_point called directly)
        worker = "local"
    start = time.perf_counter()
    row = {"status": "ok", "ok": True, "error": "", "worker": str(worker)}
    try:
        result = task(**point)
        if not isinstance(result, Mapping):
            raise TypeError(f"a sweep task returns a dict of results, got {type(result).__name__}")
        clash = sorted(set(result) & {*STATUS_COLUMNS, "key"})
        if clash:
            raise ValueError(f"the task's results {clash} clash with the columns the sweep adds")
        row.update(result)
    except SolverError as exc:
        row.update(status=exc.status, ok=False, error=str(exc))
    except Exception as exc:  # noqa: BLE001 - any failure of a point is recorded with its type and message
        row.update(status=type(exc).__name__, ok=False, error=str(exc))
    row["wall_s"] = time.perf_counter() - start
    return row


def sweep(
    task: Callable,
    points: Sequence[Mapping] | pd.DataFrame,
    *,
    client=None,
    scheduler: str | None = None,
    workers: int = 2,
    cache: str | os.PathLike | None = None,
    retry_failed: bool = False,
    progress: bool = True,
) -> pd.DataFrame:
    """Run ``task`` at every point on Dask and gather one row per point (module docstring)."""
    if isinstance(points, pd.DataFrame):
        points = points.to_dict("records")
    points = [dict(p) for p in points]
    if not points:
        raise ValueError("a sweep needs at least one point")
    clash = sorted({k for p in points for k in p} & {*STATUS_COLUMNS, "key"})
    if clash:
        raise ValueError(f"point names {clash} clash with the columns the sweep adds")
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    keys = [point_key(p) for p in points]
    if len(set(keys)) != len(keys):
        raise ValueError("the points must be distinct")

    done = _read_cache(cache, retry_failed)
    todo = [(k, p) for k, p in zip(keys, points) if k not in done]
    if todo:
        own = client is None
        if own:
            client = _client(scheduler, workers)
        try:
            for row in _gather(client, task, todo, progress):
                done[row["key"]] = row
                _append_cache(cache, row)
        finally:
            if own:
                cluster = client.cluster
                client.close()
                if cluster is not None:
                    cluster.close()
    rows = [{**p, **{k: v for k, v in done[key].items() if k != "key" and k not in p}} for key, p in zip(keys, points)]
    table = pd.DataFrame(rows)
    ordered = [c for c in table.columns if c not in STATUS_COLUMNS] + list(STATUS_COLUMNS)
    table = table[ordered]
    table["ok"] = table["ok"].astype(bool)
    return table


def _client(scheduler: str | None, workers: int):
    from distributed import Client, LocalCluster

    if scheduler is not None:
        return Client(scheduler)
    cluster = LocalCluster(
        n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40
    )
    return Client(cluster)


def _gather(client, task, todo, progress):
    from distributed import as_completed

    futures = {}
    for key, point in todo:
        future = client.submit(run_point, task, point, pure=False)
        futures[future] = key
    bar = None
    if progress:
        from .progress import progress

        bar = progress(total=len(futures), desc="sweep", unit="point")
    try:
        for future in as_completed(futures):
            try:
                row = future.result()
            except Exception as exc:  # noqa: BLE001 - the task killed its worker (a crash, memory): a failed point
                row = {"status": type(exc).__name__, "ok": False, "error": str(exc), "worker": "", "wall_s": math.nan}
            row["key"] = futures[future]
            if bar is not None:
                bar.update(1)
            yield row
    finally:
        if bar is not None:
            bar.close()


def _read_cache(cache, retry_failed: bool) -> dict:
    if cache is None or not Path(cache).is_file():
        return {}
    table = pd.read_csv(cache, keep_default_na=True)
    if "key" not in table.columns:
        raise ValueError(f"{cache} is not a sweep cache (no 'key' column)")
    rows = {}
    for row in table.to_dict("records"):
        row["ok"] = bool(row["ok"])
        row["worker"] = "" if isinstance(row.get("worker"), float) else str(row.get("worker", ""))
        row["error"] = "" if isinstance(row.get("error"), float) else row.get("error", "")
        if row["ok"] or not retry_failed:
            rows[row["key"]] = {k: v for k, v in row.items() if not (isinstance(v, float) and math.isnan(v))}
    return rows


def _append_cache(cache, row: dict) -> None:
    if cache is None:
        return
    path = Path(cache)
    path.parent.mkdir(parents=True, exist_ok=True)
    new = pd.DataFrame([row])
    if path.is_file():
        old = pd.read_csv(path)
        new = pd.concat([old, new], ignore_index=True)
    partial = path.with_name(path.name + ".partial")
    new.to_csv(partial, index=False)
    os.replace(partial, path)  # an interrupted write never leaves a damaged cache
