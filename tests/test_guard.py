"""The published record guarded against fresh runs (compendium.guard)."""

import json

import matplotlib.pyplot as plt
import pandas as pd
import pytest

from compendium import plotting
from compendium.guard import close, guard
from compendium.outputs import RUNS


def _figure(folder, name, y=(1.0, 0.0, 1.0)):
    plotting.use_style()
    fig, ax = plt.subplots()
    ax.plot([0, 1, 2], list(y))
    files = plotting.save_figure(fig, name, folder)
    plt.close(fig)
    return files


def _record(root, notebook, files, published=True):
    (root / RUNS).mkdir(parents=True, exist_ok=True)
    (root / RUNS / f"{notebook}.json").write_text(
        json.dumps(
            {"notebook": notebook, "published_parameters": published, "parameters": {}, "files": files, "timings": {}}
        )
    )


@pytest.fixture
def record(tmp_path):
    """A committed record and a fresh run that reproduces it: a figure, a CSV table, a JSON summary, a Markdown table."""
    ref, fresh = tmp_path / "repo", tmp_path / "fresh"
    for root in (ref, fresh):
        _figure(root / "figures", "f")
        (root / "data" / "derived").mkdir(parents=True)
        pd.DataFrame(
            {
                "scheme": ["a", "b"],
                "tf": [0.4466453337, 0.4466453338],
                "norm_S": [1e-12, 3e-9],
                "converged": [True, False],
            }
        ).to_csv(root / "data" / "derived" / "t.csv", index=False)
        (root / "data" / "derived" / "s.json").write_text(json.dumps({"tf": 1.2345678, "status": "Solve_Succeeded"}))
        (root / "data" / "derived" / "t.md").write_text("| a | 0.0041 |\n")
    files = ["figures/f.png", "figures/f.pdf", "data/derived/t.csv", "data/derived/s.json", "data/derived/t.md"]
    _record(fresh, "nb", files)
    return ref, fresh


def test_a_faithful_run_passes(record):
    ref, fresh = record
    report = guard(fresh, ref)
    assert report.differences == []
    assert len(report.compared) == 5


def test_a_changed_number_a_changed_figure_and_a_new_file_are_differences(record):
    ref, fresh = record
    table = pd.read_csv(fresh / "data" / "derived" / "t.csv")
    table.loc[1, "tf"] *= 1 + 1e-4
    table.to_csv(fresh / "data" / "derived" / "t.csv", index=False)
    (fresh / "data" / "derived" / "s.json").write_text(json.dumps({"tf": 1.2345678, "status": "Infeasible"}))
    _figure(fresh / "figures", "f", y=(1.0, 0.5, 1.0))
    (fresh / "data" / "derived" / "new.csv").write_text("x\n1\n")
    _record(
        fresh,
        "nb",
        ["figures/f.png", "figures/f.pdf", "data/derived/t.csv", "data/derived/s.json", "data/derived/new.csv"],
    )
    diffs = "\n".join(guard(fresh, ref).differences)
    assert "t.csv: row 1, column 'tf'" in diffs
    assert "s.json: status: 'Infeasible' != committed 'Solve_Succeeded'" in diffs
    assert "f.png: " in diffs and "pixels differ" in diffs
    assert "f.pdf: " in diffs
    assert "new.csv: not in the published record" in diffs


def test_noise_level_quantities_agree_within_a_factor_of_two():
    assert close(3e-9, 2e-9, "norm_S") and not close(3e-9, 1e-9, "norm_S")
    assert close(1e-13, 5e-11, "noise of S"), "both below the noise floor"
    assert not close(0.446655, 0.446645, "tf") and close(0.44664533379, 0.44664533378, "tf")


def test_a_markdown_table_differs_in_its_text_or_beyond_its_rounding(record):
    ref, fresh = record
    (fresh / "data" / "derived" / "t.md").write_text("| a | 0.0042 |\n")
    assert guard(fresh, ref).differences == []  # the last printed digit of a rounded number
    (fresh / "data" / "derived" / "t.md").write_text("| a | 0.0050 |\n")
    assert "t.md: number 0.0050 != committed 0.0041" in "\n".join(guard(fresh, ref).differences)
    (fresh / "data" / "derived" / "t.md").write_text("| b | 0.0041 |\n")
    assert "t.md: the text differs" in "\n".join(guard(fresh, ref).differences)


def test_a_run_with_other_parameters_is_checked_row_by_row(record):
    ref, fresh = record
    pd.read_csv(ref / "data" / "derived" / "t.csv").iloc[[1]].to_csv(fresh / "data" / "derived" / "t.csv", index=False)
    _figure(fresh / "figures", "f", y=(1.0, 0.5, 1.0))
    _record(fresh, "nb", ["figures/f.png", "data/derived/t.csv"], published=False)
    report = guard(fresh, ref)
    assert report.differences == [] and any("f.png" in s for s in report.skipped)
    table = pd.read_csv(fresh / "data" / "derived" / "t.csv")
    table.loc[0, "tf"] = 0.5
    table.to_csv(fresh / "data" / "derived" / "t.csv", index=False)
    assert "row 0 matches no committed row" in "\n".join(guard(fresh, ref).differences)


def test_no_run_records_is_a_failure(tmp_path):
    assert "no run records" in guard(tmp_path, tmp_path).differences[0]
