"""The site's result tables, written from ``data/`` when the build starts (``docs/_generated/``, not tracked).

Each table is computed from the CSV files the notebooks' published runs wrote (``data/derived/``) and the published
values (``data/paper/``); a page includes it with ``{include} ../_generated/<name>.md``, and its prose points to the
table rather than repeating the table's numbers.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pandas as pd

from compendium.tables import markdown_table

ROOT = Path(__file__).resolve().parents[1]
DERIVED = ROOT / "data" / "derived"
PAPER = ROOT / "data" / "paper"


def _read(path: Path) -> pd.DataFrame:
    return pd.read_csv(path, comment="#")


def _escaped(df: pd.DataFrame) -> pd.DataFrame:
    """Column names safe in a Markdown table (a ``|`` in a name would split its column)."""
    return df.rename(columns=lambda c: str(c).replace("|", "\\|"))


def _source(*paths: Path) -> str:
    return "Computed from " + ", ".join(f"`{p.relative_to(ROOT)}`" for p in paths) + "."


def two_timescale_solvers() -> str:
    """Iterations of Tables 1-2's rows under each NLP solver, against the paper's counts."""
    ours = _read(DERIVED / "two_timescale_solvers.csv")
    rows = []
    for table, paper_file in (("table1", PAPER / "table1.csv"), ("table2", PAPER / "table2.csv")):
        paper = _read(paper_file).set_index("scheme")["iterations"]
        part = ours[ours.table == table]
        standard = "standard"
        (other,) = set(part.scheme) - {standard}  # the table's multi-rate scheme (two_to_one, four_to_one)
        by = part.pivot(index="solver", columns="scheme", values="iterations").reset_index()
        for _, counts in by.sort_values([standard, other, "solver"]).iterrows():  # fewest iterations first
            rows.append(
                {"table": table, "solver": counts.solver, "standard": counts[standard], "multi-rate": counts[other]}
            )
        rows.append({"table": table, "solver": "the paper", "standard": paper[standard], "multi-rate": paper[other]})
    return markdown_table(pd.DataFrame(rows)) + "\n\n" + _source(DERIVED / "two_timescale_solvers.csv", PAPER)


def two_timescale_couplings() -> str:
    """The control's fitted convergence order by coupling and ratio M (Case 1's partition)."""
    df = _read(DERIVED / "two_timescale_couplings.csv")
    df = df[df.coupling != "standard"]
    order = df.pivot(index="coupling", columns="ratio", values="control_order")
    order = order.reindex([c for c in ("coarse", "fine", "quadrature", "galerkin") if c in order.index])
    order.columns = [f"M = {m}" for m in order.columns]
    table = order.reset_index()
    formats = {c: ".1f" for c in table.columns if c != "coupling"}
    return markdown_table(table, formats) + "\n\n" + _source(DERIVED / "two_timescale_couplings.csv")


def _derived(name: str, columns: list[str] | None = None, formats: dict | None = None) -> Callable[[], str]:
    def table() -> str:
        df = _read(DERIVED / f"{name}.csv")
        df = df[columns] if columns else df
        return markdown_table(_escaped(df), formats) + "\n\n" + _source(DERIVED / f"{name}.csv")

    table.__doc__ = f"``data/derived/{name}.csv`` as a table."
    return table


def beyond_the_seeds() -> str:
    """Published problems beyond the seeds refined to 1e-6: outcome, meshes, result against the published value."""
    full = _read(DERIVED / "mesh_refinement_beyond_the_seeds.csv")
    df = full[["problem", "start", "outcome", "mesh_iterations", "collocation_points", "objective", "published"]]
    df = df.assign(difference=full.relative_difference, reach=full.published_reach)
    formats = {
        "difference": ".0e",
        "reach": ".0e",
        "objective": ".10g",
        "published": ".10g",
        "collocation_points": ".0f",
    }
    return (
        markdown_table(df, formats)
        + "\n\n"
        + _source(DERIVED / "mesh_refinement_beyond_the_seeds.csv", PAPER / "beyond_the_seeds.csv")
    )


def direct_to_indirect() -> str:
    """Each certified extremal's quantities against their closed form or published reference."""
    df = _read(DERIVED / "direct_to_indirect.csv")
    df = df[["problem", "verdict", "route", "quantity", "reference", "value", "error"]]
    formats = {"reference": ".10g", "value": ".10g", "error": ".1e"}
    return markdown_table(df, formats) + "\n\n" + _source(DERIVED / "direct_to_indirect.csv", PAPER)


TABLES: dict[str, Callable[[], str]] = {
    "two_timescale_solvers": two_timescale_solvers,
    "two_timescale_couplings": two_timescale_couplings,
    "lunar_ascent_smoothing": _derived("lunar_ascent_smoothing"),
    "entry_landing_aero_models": _derived("entry_landing_aero_models"),
    "entry_landing_downrange": _derived("entry_landing_downrange"),
    "entry_landing_rate_limit": _derived("entry_landing_rate_limit"),
    "entry_landing_reintegration": _derived("entry_landing_reintegration"),
    "entry_landing_convergence": _derived("entry_landing_convergence"),
    "shooting_validation": _derived("shooting_validation"),
    "orbit_transfer_summary": _derived("orbit_transfer_summary"),
    "orbit_transfer_no_detection": _derived("orbit_transfer_no_detection"),
    "beyond_the_seeds": beyond_the_seeds,
    "direct_to_indirect": direct_to_indirect,
    "bryson_denham": _derived("bryson_denham"),
    "cops_gasoil_fit": _derived("cops_gasoil_fit"),
}


def write_tables(target: Path) -> None:
    """Write every table of :data:`TABLES` into ``target/<name>.md``."""
    target.mkdir(exist_ok=True)
    for name, table in TABLES.items():
        (target / f"{name}.md").write_text(table() + "\n")
