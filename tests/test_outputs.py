"""Where and when a notebook run writes (compendium.outputs), and what may become the published record
(compendium.notebooks.publish_run)."""

import json
import os
import shutil
import socket

import matplotlib.pyplot as plt
import pandas as pd
import pytest

from compendium import paths
from compendium.notebook_source import notebook_code, published_parameters
from compendium.notebooks import PublishError, publish_run
from compendium.outputs import STAGING, ContractWarning, Outputs, executed_code
from compendium.plotting import NOTE_GID, note_figures, save_figure
from compendium.provenance import ONE_THREAD, read_run_record, run_key

NOTEBOOK = "01_lunar_ascent"


@pytest.fixture
def repo(tmp_path, monkeypatch):
    """A repository of one notebook: data/, notebooks/01_lunar_ascent.ipynb, published.toml and contract.toml."""
    root = tmp_path / "repo"
    (root / "data").mkdir(parents=True)
    (root / "notebooks").mkdir()
    shutil.copy(paths.notebooks_dir() / f"{NOTEBOOK}.ipynb", root / "notebooks")
    (root / "notebooks" / "published.toml").write_text("")
    (root / "notebooks" / "contract.toml").write_text(
        f'["{NOTEBOOK}".tables.a_table]\nconverged = ["x"]\n'
        f'["{NOTEBOOK}".json.a_summary]\nexact = ["answer"]\n'
        f'["{NOTEBOOK}".figures.a_figure]\n'
    )
    monkeypatch.setenv("OCPKIT_ROOT", str(root))
    monkeypatch.delenv("OCPKIT_OUTPUT_DIR", raising=False)
    monkeypatch.delenv("OCPKIT_RUNS_DIR", raising=False)
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


def test_a_run_names_its_folder_by_the_parameters_that_differ_from_the_defaults(repo):
    defaults = published_parameters(NOTEBOOK)
    assert run_key(NOTEBOOK, defaults) == "defaults"
    assert run_key(NOTEBOOK, defaults | {"segments": 40}) == "segments-40"
    assert run_key(NOTEBOOK, defaults | {"segments": 40, "plot_points": 11}) == "plot_points-11_segments-40"
    listed = run_key(NOTEBOOK, defaults | {"smoothing_study": [1e-8]})
    assert listed.startswith("smoothing_study-") and len(listed) == len("smoothing_study-") + 8
    assert run_key(NOTEBOOK, defaults | {"smoothing_study": [1e-6]}) != listed


def test_the_published_parameters_write_the_runs_own_folder_never_the_published_record(repo, capsys):
    out = Outputs.start(NOTEBOOK, published_parameters(NOTEBOOK))
    assert out.is_published_run and out.root == repo / "build" / "runs" / NOTEBOOK / "defaults"
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("This run writes its figures and tables to build/runs/01_lunar_ascent/defaults/")
    _write_some(out)
    assert not (out.root / "figures").exists(), "nothing before publish()"
    out.publish()
    assert sorted(p.name for p in (out.root / "figures").iterdir()) == ["a_figure.pdf", "a_figure.png", "data"]
    assert json.loads((out.root / "figures" / "data" / "a_figure.json").read_text())["axes"][0]["artists"]
    assert pd.read_csv(out.root / "data" / "derived" / "a_table.csv").columns.tolist() == ["x"]
    record = read_run_record(out.root, NOTEBOOK)
    assert record["published_parameters"] is True and record["code"] is None  # not run in a kernel
    assert record["timings"]["solve"] == [{"x": 1.0, "build_s": 0.1}, {"x": 2.0, "build_s": 0.2}]
    assert not (repo / "figures").exists() and not (repo / "data" / "derived").exists()
    assert not (out.root / STAGING).exists(), "the staging folder is cleaned up"
    with pytest.raises(RuntimeError, match="already published"):
        out.publish()


def test_runs_with_other_parameters_get_their_own_folders(repo):
    params = published_parameters(NOTEBOOK)
    a, b = Outputs(NOTEBOOK, params | {"segments": 30}), Outputs(NOTEBOOK, params | {"segments": 50})
    assert not a.is_published_run and a.changed == {"segments": 30}
    assert a.root.name == "segments-30" and b.root.name == "segments-50" and a.root.parent == b.root.parent
    assert "segments = 30" in a.describe()
    for out in (a, b):
        _write_some(out)
        out.publish()
    assert read_run_record(a.root, NOTEBOOK)["parameters"]["segments"] == 30
    assert read_run_record(b.root, NOTEBOOK)["parameters"]["segments"] == 50


def _drawn():
    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    ax.set_title("Figure 4")
    return fig


def test_a_figure_of_a_run_with_other_parameters_says_so_and_the_published_runs_are_as_before(repo, capsys):
    """Saved and inline: the published run's figure is the bytes save_figure writes of it alone; another run's
    carries a note naming the parameters that differ, which figures/data leaves out (the guard compares the same
    arrays and texts); Outputs.start of such a run notes every figure pyplot draws after it, and of the published
    run none."""
    params = published_parameters(NOTEBOOK)
    alone = _drawn()
    save_figure(alone, "a_figure", repo / "alone")
    published, other = Outputs(NOTEBOOK, params), Outputs(NOTEBOOK, params | {"thrust_to_weight": 2.5})
    assert published.note is None
    assert other.note == "Not the published run: thrust_to_weight = 2.5 (published: None, the paper's)"
    for out in (published, other):
        fig = _drawn()
        out.figure(fig, "a_figure")
        out.figure(fig, "a_figure")  # once on a figure, however often it is saved
        assert [t.get_text() for t in fig.texts if t.get_gid() == NOTE_GID] == ([out.note] if out.note else [])
        plt.close(fig)
        out.publish()
    for ext in ("png", "pdf"):
        assert (published.root / "figures" / f"a_figure.{ext}").read_bytes() == (
            repo / "alone" / f"a_figure.{ext}"
        ).read_bytes()
        assert (other.root / "figures" / f"a_figure.{ext}").read_bytes() != (
            repo / "alone" / f"a_figure.{ext}"
        ).read_bytes()
    data = [(out.root / "figures" / "data" / "a_figure.json").read_text() for out in (published, other)]
    assert data[0] == data[1]
    try:
        Outputs.start(NOTEBOOK, params | {"thrust_to_weight": 2.5})
        inline = plt.figure()
        assert [t.get_text() for t in inline.texts] == [other.note]
        Outputs.start(NOTEBOOK, params)
        assert plt.figure().texts == []
    finally:
        note_figures(None)
        plt.close("all")
    assert "compendium.plotting:_note_new_figure" not in plt.rcParams["figure.hooks"]


def test_a_later_run_replaces_the_earlier_one_with_the_same_parameters_whole(repo):
    params = published_parameters(NOTEBOOK)
    first = Outputs(NOTEBOOK, params)
    _write_some(first)
    first.publish()
    second = Outputs(NOTEBOOK, params)
    second.table(pd.DataFrame({"x": [3.0]}), "a_table")
    second.publish()
    assert pd.read_csv(second.root / "data" / "derived" / "a_table.csv").x.tolist() == [3.0]
    assert not (second.root / "figures" / "a_figure.png").exists(), "what the earlier run wrote and this one did not"


def test_a_run_that_stops_midway_leaves_its_folder_as_it_was_and_no_staging(repo):
    out = Outputs(NOTEBOOK, published_parameters(NOTEBOOK))
    _write_some(out)  # ... and the notebook fails before its last cell: publish() never runs, the kernel exits
    assert not (out.root / "figures").exists()
    out._discard()  # what the kernel's exit does (atexit)
    assert not (out.root / STAGING).exists()


def test_the_staging_folder_of_a_killed_run_is_removed_by_the_next_run(repo):
    dead = 2**22 + 12345  # no such process
    while True:
        try:
            os.kill(dead, 0)
            dead += 1
        except ProcessLookupError:
            break
    root = repo / "build" / "runs" / NOTEBOOK / "defaults"
    killed = root / STAGING / f"{NOTEBOOK}-{socket.gethostname()}-{dead}-abc123"
    alive = root / STAGING / f"{NOTEBOOK}-{socket.gethostname()}-{os.getpid()}-def456"
    for folder in (killed, alive):
        (folder / "figures").mkdir(parents=True)
    Outputs(NOTEBOOK, published_parameters(NOTEBOOK))
    assert not killed.exists() and alive.exists(), "only the staging of a process that no longer runs"


def test_ocpkit_output_dir_and_ocpkit_runs_dir_are_explicit_choices(repo, tmp_path, monkeypatch):
    monkeypatch.setenv("OCPKIT_RUNS_DIR", str(tmp_path / "runs"))
    assert Outputs(NOTEBOOK, published_parameters(NOTEBOOK)).root == tmp_path / "runs" / NOTEBOOK / "defaults"
    monkeypatch.setenv("OCPKIT_OUTPUT_DIR", str(tmp_path / "elsewhere"))
    out = Outputs(NOTEBOOK, published_parameters(NOTEBOOK) | {"segments": 40})
    assert out.root == tmp_path / "elsewhere" and "OCPKIT_OUTPUT_DIR" in out.describe()
    monkeypatch.setenv("OCPKIT_OUTPUT_DIR", str(repo))
    with pytest.raises(ValueError, match="the published record is written only by"):
        Outputs(NOTEBOOK, published_parameters(NOTEBOOK))


def test_every_parameter_is_needed(repo):
    params = published_parameters(NOTEBOOK)
    params.pop("segments")
    with pytest.raises(ValueError, match=r"missing \['segments'\]"):
        Outputs(NOTEBOOK, params)


def test_what_the_contract_does_not_declare_is_written_with_a_warning(repo):
    out = Outputs(NOTEBOOK, published_parameters(NOTEBOOK))
    with pytest.warns(ContractWarning, match="table 'other' is not declared"):
        out.table(pd.DataFrame({"x": [1.0]}), "other")
    with pytest.warns(ContractWarning, match=r"columns \['y'\] of table 'a_table' have no class"):
        out.table(pd.DataFrame({"x": [1.0], "y": [2.0]}), "a_table")


def test_executed_code_leaves_out_papermill_s_injected_cell_and_only_that():
    parameters = "segments = 20"
    sources = [parameters, "# Parameters\nsegments = 40\n", "print(segments)  "]
    assert executed_code(sources, parameters) == executed_code([parameters, "print(segments)"], parameters)
    # the same cell run by a user after the notebook's first cells is code like any other
    later = [parameters, "print(segments)", "# Parameters\nsegments = 50"]
    assert len(executed_code(later, parameters)) == 3


def _complete_run(repo, code=None, parameters=None, threads=ONE_THREAD):
    """A run whose record says the kernel ran ``code`` (default: the committed notebook's) with ``threads`` in its
    environment (default: one BLAS and one OpenMP thread, as compendium.notebooks.execute gives every kernel)."""
    with pytest.MonkeyPatch.context() as patch:
        for name, value in threads.items():
            if value is None:
                patch.delenv(name, raising=False)
            else:
                patch.setenv(name, value)
        out = Outputs(NOTEBOOK, parameters or published_parameters(NOTEBOOK))
        _write_some(out)
        out.publish()
    path = out.root / "data" / "derived" / "runs" / f"{NOTEBOOK}.json"
    record = json.loads(path.read_text())
    assert record["threads"] == threads, "the record keeps the threads of the process that ran the notebook"
    record["code"] = code if code is not None else notebook_code(repo / "notebooks" / f"{NOTEBOOK}.ipynb")
    path.write_text(json.dumps(record))
    return out.root


def test_a_complete_run_of_the_committed_notebook_publishes(repo):
    folder = _complete_run(repo)
    files = publish_run(folder)
    assert (repo / "figures" / "a_figure.png").is_file() and (repo / "figures" / "data" / "a_figure.json").is_file()
    assert (repo / "data" / "derived" / "a_table.csv").read_bytes() == (
        folder / "data/derived/a_table.csv"
    ).read_bytes()
    assert (repo / "data" / "derived" / "runs" / f"{NOTEBOOK}.json").is_file() and len(files) == 5


@pytest.mark.parametrize(
    "how, message",
    [
        ("edited", "is not that of notebooks/01_lunar_ascent.ipynb"),
        ("parameters", "other parameters than the published run: \\['segments'\\]"),
        ("no kernel", "recorded no executed code"),
        ("threads", "ran with OPENBLAS_NUM_THREADS=unset, OMP_NUM_THREADS=2: the published record is computed with"),
    ],
)
def test_anything_else_does_not_publish(repo, how, message):
    code = notebook_code(repo / "notebooks" / f"{NOTEBOOK}.ipynb")
    if how == "edited":
        folder = _complete_run(repo, code=code[:3] + ["0123456789abcdef"] + code[4:])
    elif how == "parameters":
        folder = _complete_run(repo, parameters=published_parameters(NOTEBOOK) | {"segments": 40})
    elif how == "threads":  # a Lab or a runner started without make's environment: OpenBLAS' own threads
        folder = _complete_run(repo, threads={"OPENBLAS_NUM_THREADS": None, "OMP_NUM_THREADS": "2"})
    else:
        out = Outputs(NOTEBOOK, published_parameters(NOTEBOOK))
        _write_some(out)
        out.publish()
        folder = out.root
    with pytest.raises(PublishError, match=message):
        publish_run(folder)
    assert not (repo / "figures").exists()


def test_the_note_says_what_a_none_stands_for_where_the_parameters_cell_says_it():
    from compendium.notebook_source import none_meanings
    from compendium.plotting import run_note

    meanings = none_meanings(paths.notebooks_dir() / "05_orbit_transfer.ipynb")
    assert meanings["thrusts"] == "all of the slides'"
    note = run_note({"thrusts": [5.0], "recompute": False}, {"thrusts": None, "recompute": True}, meanings)
    assert " ".join(note.split()) == (
        "Not the published run: thrusts = [5.0] (published: None, all of the slides'); recompute = False "
        "(published: True)"
    )
    assert run_note({"x": None}, {"x": 1.0}) == "Not the published run: x = None (published: 1.0)"
