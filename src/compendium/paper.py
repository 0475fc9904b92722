"""Published values transcribed from the source documents (``data/paper``)."""

from __future__ import annotations

import pandas as pd

from .paths import paper_dir


def paper_table(name: str) -> pd.DataFrame:
    """A table of published values, e.g. ``paper_table("table1")``; comment lines name the source."""
    path = paper_dir() / f"{name}.csv"
    if not path.is_file():
        known = sorted(p.stem for p in paper_dir().glob("*.csv"))
        raise FileNotFoundError(f"no published table {name!r}; available: {known}")
    return pd.read_csv(path, comment="#", dtype={"segments": str})


def paper_source(name: str) -> str:
    """The comment header (source, table, notes) of a published table."""
    lines = (paper_dir() / f"{name}.csv").read_text(encoding="utf-8").splitlines()
    return "\n".join(line.lstrip("# ").rstrip() for line in lines if line.startswith("#"))
