"""Where and when a notebook run writes (compendium.outputs): the published record is protected."""

import json
import shutil

import matplotlib.pyplot as plt
import pandas as pd
import pytest

from compendium import paths
from compendium.outputs import Outputs, published_parameters, read_run_record

NOTEBOOK = "01_lunar_ascent"


@pytest.fixture
def repo(tmp_path, monkeypatch):
    """A repository of one notebook: data/, notebooks/01_lunar_ascent.ipynb and notebooks/published.toml."""
    root = tmp_path / "repo"
    (root / "data").mkdir(parents=True)
    (root / "notebooks").mkdir()
    shutil.copy(paths.notebooks_dir() / f"{NOTEBOOK}.ipynb", root / "notebooks")
    (root / "notebooks" / "published.toml").write_text("")
    monkeypatch.setenv("OCPKIT_ROOT", str(root))
    monkeypatch.delenv("OCPKIT_OUTPUT_DIR", raising=False)
    return root


def _write_some(out):
    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    out.figure(fig, "a_figure")
    plt.close(fig)
    out.table(pd.DataFrame({"x": [1.0, 2.0], "build_s": [0.1, 0.2]}).drop(columns="build_s"), "a_table")
    out.json({"answer": 42}, "a_summary")
    out.timing("solve", pd.DataFrame({"x": [1.0, 2.0], "build_s": [0.1, 0.2]}))


def test_published_parameters_are_the_defaults_updated_by_published_toml(repo):
    defaults = published_parameters(NOTEBOOK)
    assert defaults["segments"] == 20
    (repo / "notebooks" / "published.toml").write_text(f'[{NOTEBOOK}]\nsegments = "40"\n')
    assert published_parameters(NOTEBOOK)["segments"] == 40
    (repo / "notebooks" / "published.toml").write_text(f'[{NOTEBOOK}]\nsegmnts = "40"\n')
    with pytest.raises(ValueError, match=r"unknown parameter\(s\) \['segmnts'\]"):
        published_parameters(NOTEBOOK)


def test_the_published_run_writes_the_published_record_when_it_completes(repo):
    out = Outputs(NOTEBOOK, published_parameters(NOTEBOOK))
    assert out.is_published_run and out.root == repo
    _write_some(out)
    assert not (repo / "figures").exists() and not (repo / "data" / "derived").exists(), "nothing before publish()"
    out.publish()
    assert sorted(p.name for p in (repo / "figures").iterdir()) == ["a_figure.pdf", "a_figure.png"]
    assert pd.read_csv(repo / "data" / "derived" / "a_table.csv").columns.tolist() == ["x"]
    assert json.loads((repo / "data" / "derived" / "a_summary.json").read_text()) == {"answer": 42}
    record = read_run_record(repo, NOTEBOOK)
    assert record["published_parameters"] is True
    assert record["timings"]["solve"] == [{"x": 1.0, "build_s": 0.1}, {"x": 2.0, "build_s": 0.2}]
    assert "data/derived/a_table.csv" in record["files"]
    assert not list((repo / "build" / "staging").iterdir()), "the staging folder is cleaned up"
    with pytest.raises(RuntimeError, match="already published"):
        out.publish()


def test_a_run_with_other_parameters_writes_under_build_runs(repo):
    params = published_parameters(NOTEBOOK) | {"segments": 40}
    out = Outputs(NOTEBOOK, params)
    assert not out.is_published_run and out.changed == {"segments": 40}
    assert out.root == repo / "build" / "runs" / NOTEBOOK
    assert "segments = 40" in out.describe()
    _write_some(out)
    out.publish()
    assert (out.root / "figures" / "a_figure.png").is_file()
    assert not (repo / "figures").exists() and not (repo / "data" / "derived").exists()


def test_a_run_that_stops_midway_leaves_the_destination_as_it_was(repo):
    (repo / "figures").mkdir()
    (repo / "figures" / "a_figure.png").write_bytes(b"the published figure")
    out = Outputs(NOTEBOOK, published_parameters(NOTEBOOK))
    _write_some(out)  # ... and the notebook fails before its last cell: publish() never runs
    assert (repo / "figures" / "a_figure.png").read_bytes() == b"the published figure"
    assert not (repo / "data" / "derived").exists()


def test_ocpkit_output_dir_is_an_explicit_choice(repo, tmp_path, monkeypatch):
    monkeypatch.setenv("OCPKIT_OUTPUT_DIR", str(tmp_path / "elsewhere"))
    out = Outputs(NOTEBOOK, published_parameters(NOTEBOOK) | {"segments": 40})
    assert out.root == tmp_path / "elsewhere"
    assert "OCPKIT_OUTPUT_DIR" in out.describe()


def test_every_parameter_is_needed(repo):
    params = published_parameters(NOTEBOOK)
    params.pop("segments")
    with pytest.raises(ValueError, match=r"missing \['segments'\]"):
        Outputs(NOTEBOOK, params)


def test_start_reads_the_parameters_from_the_namespace(repo, capsys):
    namespace = published_parameters(NOTEBOOK) | {"unrelated": 1}
    out = Outputs.start(NOTEBOOK, namespace)
    assert out.is_published_run
    assert "figures/ and data/derived/ of the repository" in capsys.readouterr().out
