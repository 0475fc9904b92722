"""House style and deterministic figure files (compendium.plotting)."""

import matplotlib.pyplot as plt
import pytest

from compendium import plotting


def test_saved_figures_are_byte_for_byte_reproducible(tmp_path):
    plotting.use_style()
    blobs = []
    for run in range(2):
        fig, ax = plt.subplots()
        ax.plot([0, 1, 2], [1, 0, 1], label="a")
        ax.legend()
        files = plotting.save_figure(fig, "determinism_check", tmp_path / f"run{run}")
        plt.close(fig)
        blobs.append([f.read_bytes() for f in files])
        assert [f.name for f in files] == ["determinism_check.png", "determinism_check.pdf"]
        assert all(f.parent == tmp_path / f"run{run}" for f in files)
    assert blobs[0] == blobs[1]
    assert b"CreationDate" not in blobs[0][1]


def test_bad_figure_name_rejected(tmp_path):
    fig, _ = plt.subplots()
    with pytest.raises(ValueError, match="plain file stem"):
        plotting.save_figure(fig, "../escape", tmp_path)
    with pytest.raises(ValueError, match="unsupported"):
        plotting.save_figure(fig, "x", tmp_path, formats=("bmp",))
    plt.close(fig)
