"""Markdown rendering of result tables (compendium.tables)."""

import pytest


def test_markdown_table_renders_numbers_and_gaps():
    import math

    import pandas as pd

    from compendium.tables import markdown_table

    df = pd.DataFrame({"scheme": ["standard", "two_to_one"], "n": [20, 10], "diff": [math.nan, 0.0712]})
    text = markdown_table(df, {"diff": ".2f"})
    lines = text.splitlines()
    assert lines[0].startswith("| scheme") and lines[1].endswith(":|")
    assert lines[3].endswith("| 0.07 |") and lines[2].endswith("|      |")
    with pytest.raises(KeyError):
        markdown_table(df, {"nope": ".1f"})
