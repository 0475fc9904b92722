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


def test_a_shown_table_has_the_same_bytes_on_every_run():
    import pandas as pd

    from compendium.tables import show

    df = pd.DataFrame({"scheme": ["standard", "two_to_one"], "error": [1.23456e-3, 2.0e-4]})
    a, b = show(df.style.format({"error": "{:.2e}"})), show(df.copy().style.format({"error": "{:.2e}"}))
    assert a._repr_html_() == b._repr_html_() and "1.23e-03" in a._repr_html_()
    assert repr(a) == repr(b) and "0x" not in repr(a) and "1.23e-03" in repr(a)
    assert show(df.style.format({"error": "{:.1e}"}))._repr_html_() != a._repr_html_()
