"""Progress bars routed by OCPKIT_PROGRESS (compendium.progress)."""

import pytest

from compendium.progress import continuation_progress, progress


def test_off_disables_the_bars(monkeypatch):
    monkeypatch.setenv("OCPKIT_PROGRESS", "off")
    bar = progress(range(3), desc="x")
    assert bar.disable
    assert list(bar) == [0, 1, 2]


def test_terminal_writes_to_the_process_stderr(monkeypatch):
    import sys

    monkeypatch.setenv("OCPKIT_PROGRESS", "terminal")
    bar = progress(total=2, desc="x")
    assert not bar.disable
    assert getattr(bar.fp, "_wrapped", bar.fp) is sys.__stderr__  # the terminal of make reproduce, not the notebook
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
