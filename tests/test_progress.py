"""Progress bars routed by OCPKIT_PROGRESS (compendium.progress)."""

import pytest

from compendium.progress import continuation_progress, progress


def test_off_disables_the_bars(monkeypatch):
    monkeypatch.setenv("OCPKIT_PROGRESS", "off")
    bar = progress(range(3), desc="x")
    assert bar.disable
    assert list(bar) == [0, 1, 2]


class _KernelStderr:
    """ipykernel's sys.stderr: what it is written goes into the notebook; fileno() is the original stderr's copy."""

    def __init__(self, fd):
        self.fd, self.notebook = fd, []

    def write(self, text):
        self.notebook.append(text)

    def flush(self):
        pass

    def fileno(self):
        return self.fd


class _NoFileno(_KernelStderr):
    def fileno(self):
        import io

        raise io.UnsupportedOperation("fileno")


@pytest.mark.parametrize("mode", ["terminal", ""])
def test_bars_go_to_the_kernels_terminal_and_never_into_the_notebook(monkeypatch, mode):
    """In JupyterLab (OCPKIT_PROGRESS unset) as in make reproduce: a bar under a cell would be saved with it."""
    import os
    import sys

    from compendium import progress as module

    read, write = os.pipe()
    kernel_stderr = _KernelStderr(write)
    monkeypatch.setattr(sys, "stderr", kernel_stderr)
    monkeypatch.setattr(module, "_TERMINAL", None)
    monkeypatch.setenv("OCPKIT_PROGRESS", mode)
    bar = progress(total=2, desc="continuation")
    bar.update(2)
    bar.close()
    module._TERMINAL.flush()
    os.close(write)
    drawn = os.read(read, 100_000).decode()
    os.close(read)
    assert "continuation" in drawn and kernel_stderr.notebook == []


def test_without_a_file_descriptor_the_bars_go_to_the_process_stderr(monkeypatch):
    import sys

    from compendium import progress as module

    monkeypatch.setattr(sys, "stderr", _NoFileno(None))
    monkeypatch.setattr(module, "_TERMINAL", None)
    monkeypatch.setenv("OCPKIT_PROGRESS", "terminal")
    bar = progress(total=2, desc="x")
    assert not bar.disable and getattr(bar.fp, "_wrapped", bar.fp) is sys.__stderr__
    bar.close()


def test_an_unknown_mode_is_an_error(monkeypatch):
    monkeypatch.setenv("OCPKIT_PROGRESS", "loud")
    with pytest.raises(ValueError, match="OCPKIT_PROGRESS"):
        progress(range(3))


def test_continuation_progress_calls_the_study_log(monkeypatch):
    monkeypatch.setenv("OCPKIT_PROGRESS", "off")
    seen = []
    with continuation_progress("steps", "T", lambda v, r, e: seen.append((v, r, e))) as tick:
        tick(1.0, "result", 0.5)
        tick(0.5, "result", 0.7)
    assert seen == [(1.0, "result", 0.5), (0.5, "result", 0.7)]


# -- the time each notebook of make reproduce takes ----------------------------------------------------------------


def _executed(folder, name, parameters, duration, exception=None):
    import json

    meta = {"papermill": {"parameters": parameters, "duration": duration, "exception": exception}}
    (folder / f"{name}.ipynb").write_text(json.dumps({"cells": [], "metadata": meta, "nbformat": 4}))


def test_the_previous_runs_measured_time_counts_only_for_a_complete_run_with_the_same_parameters(tmp_path):
    from compendium.progress import measured_durations

    _executed(tmp_path, "a", {"thrusts": None}, 1100.5)
    _executed(tmp_path, "b", {"segments": 6}, 3.0)  # a run with other parameters (by hand)
    _executed(tmp_path, "c", {}, 12.0, exception=True)  # stopped in a cell: a part of the run
    (tmp_path / "d.ipynb").write_text("not json")
    given = {"a": {"thrusts": None}, "b": {}, "c": {}, "d": {}, "e": {}}
    assert measured_durations(tmp_path, given) == {"a": 1100.5}
    assert measured_durations(tmp_path / "absent", given) == {}


def test_every_notebook_has_a_prior_duration():
    from compendium import paths
    from compendium.progress import prior_durations

    prior = prior_durations()
    assert set(prior) == {p.stem for p in paths.notebooks_dir().glob("*.ipynb")}
    assert all(seconds > 0 for seconds in prior.values())
    assert max(prior, key=prior.get) == "05_orbit_transfer"  # most of make reproduce's time


def test_the_eta_is_per_notebook_and_the_total_the_sum_of_those_left():
    import time

    from compendium.progress import Estimate, NotebookETA, notebook_estimates

    estimates = notebook_estimates(["a", "b", "c", "d"], {"a": 30.0, "b": 95.0}, {"b": 10.0, "c": 1080.0})
    assert estimates == {
        "a": Estimate(30.0, "last run here"),
        "b": Estimate(95.0, "last run here"),  # measured here wins over the prior
        "c": Estimate(1080.0, "reference machine"),
        "d": None,
    }
    eight = time.mktime((2026, 12, 6, 8, 0, 0, 0, 0, -1))  # 08:00, local time
    eta = NotebookETA(estimates, clock=lambda: eight)
    assert (
        eta.line("a")
        == "a: ~30 s (last run here), until ~08:00; all 4 left: ~20 min + 1 without an estimate, until ~08:20"
    )
    assert (
        eta.line("c")
        == "c: ~18 min (reference machine), until ~08:18; all 2 left: ~18 min + 1 without an estimate, until ~08:18"
    )
    assert eta.line("d") == "d: no estimate (no earlier run); all 1 left: no estimate"


def test_the_runners_bar_shows_the_per_notebook_eta_and_not_an_average(capsys):
    from pathlib import Path

    from compendium.notebooks import _each
    from compendium.progress import Estimate, NotebookETA

    eta = NotebookETA({"fast": Estimate(5.0, "last run here"), "slow": Estimate(4000.0, "reference machine")})
    assert [nb.name for nb in _each([Path("fast.ipynb"), Path("slow.ipynb")], "reproduce", eta)] == [
        "fast.ipynb",
        "slow.ipynb",
    ]
    err = capsys.readouterr().err
    assert "fast: ~5 s (last run here), until ~" in err and "all 2 left: ~1 h 07 min, until ~" in err
    assert "slow: ~1 h 07 min (reference machine), until ~" in err and "all 1 left: ~1 h 07 min" in err
    assert "notebook/s" not in err and "s/notebook" not in err  # tqdm's rate, and its average-based remaining time


def test_make_reproduce_estimates_each_notebook_from_the_run_it_replaces(tmp_path, monkeypatch, capsys):
    """The previous run's executed notebooks are removed first: their times are read before."""
    from compendium import notebooks, paths
    from compendium.notebook_source import published_overrides

    orbit, lunar = paths.notebooks_dir() / "05_orbit_transfer.ipynb", paths.notebooks_dir() / "01_lunar_ascent.ipynb"
    _executed(tmp_path, "05_orbit_transfer", published_overrides(orbit), 1500.0)  # this machine is slower
    monkeypatch.setattr(notebooks, "execute", lambda *a, **k: None)
    monkeypatch.setattr(notebooks, "publish_run", lambda folder: [])
    assert notebooks.reproduce([lunar, orbit], tmp_path) == {}
    err = capsys.readouterr().err
    assert "01_lunar_ascent: ~6 s (reference machine), until ~" in err and "all 2 left: ~25 min, until ~" in err
    assert "05_orbit_transfer: ~25 min (last run here), until ~" in err
    assert not (tmp_path / "05_orbit_transfer.ipynb").exists()


def test_notebooks_at_once_start_longest_first_and_the_schedule_says_how_long():
    from compendium.progress import Estimate, longest_first

    estimates = {"a": Estimate(60.0, "x"), "b": Estimate(900.0, "x"), "c": Estimate(500.0, "x"), "d": None}
    estimates["e"] = Estimate(400.0, "x")
    order, expected = longest_first(["a", "b", "c", "d", "e"], estimates, 2)
    assert order == ["d", "b", "c", "e", "a"]  # no estimate: as if the longest
    assert expected == 960.0  # b then a on one process (960 s), c then e on the other (900 s)
    assert longest_first(["a", "b"], estimates, 1) == (["b", "a"], 960.0)


def test_every_reader_of_anothers_published_record_waits_for_it_when_notebooks_run_at_once():
    """make reproduce --jobs: a study that reads the published record (read_cache) is known, and the notebook that
    calls it starts after the one that writes it (READS_PUBLISHED). A new reader fails this test until it is listed."""
    import re
    from pathlib import Path

    import compendium
    from compendium.notebooks import READS_PUBLISHED

    src = Path(compendium.__file__).parent
    readers = sorted(
        str(p.relative_to(src))
        for p in src.rglob("*.py")
        if re.search(r"(?<!def )(?<!\w)read_cache\(", p.read_text()) and p.name != "cache.py"
    )
    # chain.py is notebook 05's own (its cached continuations, not read by the published run: recompute=True)
    assert readers == ["studies/direct_to_indirect.py", "studies/orbit_transfer/chain.py"]
    assert READS_PUBLISHED == {"10_direct_to_indirect": ("05_orbit_transfer",)}


def test_the_expected_schedule_waits_for_a_notebook_that_reads_anothers_record():
    """Notebook 10 reads 05's published record: it starts after 05 ends, on whichever process is free then."""
    from compendium.progress import Estimate, longest_first

    estimates = {"05": Estimate(900.0, "x"), "10": Estimate(80.0, "x"), "11": Estimate(450.0, "x")}
    estimates["07"] = Estimate(200.0, "x")
    order, expected = longest_first(list(estimates), estimates, 2, {"10": ("05",)})
    assert order == ["05", "11", "07", "10"]
    assert expected == 980.0  # 05 then 10 (the other process is free at 650 s, but 10 waits for 05's end)
    assert longest_first(list(estimates), estimates, 2)[1] == 900.0  # without the wait: 11, 07, 10 beside 05
