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
