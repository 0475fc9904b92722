"""Shared timing harness for the benchmark scripts: best-of-k runs, CSV and Markdown output."""

from __future__ import annotations

import argparse
import ast
import os
import platform
import time

import casadi
import pandas as pd

from compendium.tables import markdown_table


def ipopt_overrides(pairs: list[str]) -> dict:
    """``["tol=1e-12", "max_iter=50"]`` -> ``{"tol": 1e-12, "max_iter": 50}``."""
    out = {}
    for kv in pairs:
        key, sep, value = kv.partition("=")
        if not sep:
            raise SystemExit(f"--ipopt expects KEY=VALUE, got {kv!r}")
        try:
            out[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            out[key] = value
    return out


def parser(description: str, default_output: str) -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--repeat", type=int, default=3, help="runs per row; the fastest is kept")
    ap.add_argument("--ipopt", nargs="*", default=[], metavar="KEY=VALUE", help="IPOPT option overrides")
    ap.add_argument("--output", default=default_output)
    return ap


def timed_solve(make_transcription, ipopt_options: dict) -> dict:
    """Build (NLP and solver) and solve from the default guess; wall times in seconds.

    The solution's error estimate is not computed (``error_threshold=None``): these tables time the NLP.
    ``functions_s`` is the part of ``solve_s`` spent evaluating the NLP's functions and derivatives (CasADi's
    ``t_wall_nlp_*`` statistics); the rest is IPOPT's own work, mostly the KKT factorisations.
    """
    t0 = time.perf_counter()
    tr = make_transcription()
    tr.solver(ipopt_options)
    sol = tr.solve(ipopt_options=ipopt_options, error_threshold=None)
    total = time.perf_counter() - t0
    stats = sol.nlp_result.stats
    functions = sum(v for k, v in stats.items() if k.startswith("t_wall_nlp_"))
    return {
        "nlp_parameters": sol.decision_variables,
        "defect_equations": sol.defect_equations,
        "constraints": sol.constraints,
        "jacobian_nnz": tr.nlp.nnz_jacobian,
        "hessian_nnz": tr.nlp.nnz_hessian,
        "hessian_instructions": tr.nlp.hessian_instructions,
        "build_s": tr.build_s,
        "solve_s": sol.solve_s,
        "functions_s": functions,  # IPOPT's calls of f, g, their derivatives and the Hessian (within solve_s)
        "end_to_end_s": total,
        "iterations": sol.iterations,
        "tf": sol.tf,
        "objective": sol.objective,
    }


def best_of(make_transcription, ipopt_options: dict, repeat: int) -> dict:
    if repeat < 1:
        raise SystemExit("--repeat must be at least 1")
    runs = [timed_solve(make_transcription, ipopt_options) for _ in range(repeat)]
    return min(runs, key=lambda r: r["end_to_end_s"])


def best_of_pair(make_a, make_b, ipopt_options: dict, repeat: int) -> tuple[dict, dict]:
    """The best of ``repeat`` runs of each of two transcriptions, run alternately: a ratio of the two is not moved
    by the machine's speed drifting between them (a shared 2-core machine drifts by tens of percent in minutes)."""
    if repeat < 1:
        raise SystemExit("--repeat must be at least 1")
    runs_a, runs_b = [], []
    for _ in range(repeat):
        runs_a.append(timed_solve(make_a, ipopt_options))
        runs_b.append(timed_solve(make_b, ipopt_options))
    return min(runs_a, key=lambda r: r["end_to_end_s"]), min(runs_b, key=lambda r: r["end_to_end_s"])


def goal(value: float, limit: float, unit: str = "x") -> str:
    """``"<= 1.10x: met"`` or ``"<= 1.10x: not met"``: a measured ratio (or time) beside its goal."""
    return f"<= {limit:g}{unit}: {'met' if value <= limit else 'not met'}"


def sibling(output: str, suffix: str) -> str:
    """A second table's file beside ``output``: ``build/bench/scale.csv`` -> ``build/bench/scale_goals.csv``."""
    root, ext = os.path.splitext(output)
    return f"{root}_{suffix}{ext}"


def report(rows: list[dict], columns: list[str], output: str, title: str, formats: dict | None = None) -> pd.DataFrame:
    df = pd.DataFrame(rows)
    os.makedirs(os.path.dirname(output) or ".", exist_ok=True)
    df.to_csv(output, index=False)
    print()
    print(f"{title}; casadi {casadi.__version__}, {platform.machine()}, {os.cpu_count()} cores")
    print()
    fmt = {c: ".3f" for c in columns if c.endswith("_s")} | dict(formats or {})
    print(markdown_table(df[columns], fmt))
    print(f"\nwritten {output}")
    return df
