"""House style and deterministic figure files (compendium.plotting)."""

import matplotlib.pyplot as plt
import pytest

from compendium import paths, plotting


def test_saved_figures_are_byte_for_byte_reproducible():
    plotting.use_style()
    blobs = []
    for _ in range(2):
        fig, ax = plt.subplots()
        ax.plot([0, 1, 2], [1, 0, 1], label="a")
        ax.legend()
        files = plotting.save_figure(fig, "determinism_check")
        plt.close(fig)
        blobs.append([f.read_bytes() for f in files])
        assert all(f.parent == paths.figures_dir() for f in files)
    assert blobs[0] == blobs[1]
    assert b"CreationDate" not in blobs[0][1]


def test_bad_figure_name_rejected():
    fig, _ = plt.subplots()
    with pytest.raises(ValueError, match="plain file stem"):
        plotting.save_figure(fig, "../escape")
    with pytest.raises(ValueError, match="unsupported"):
        plotting.save_figure(fig, "x", formats=("bmp",))
    plt.close(fig)


def test_outputs_follow_ocpkit_output_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("OCPKIT_OUTPUT_DIR", str(tmp_path))
    assert paths.derived_dir() == tmp_path / "data" / "derived"
    assert paths.figures_dir().is_dir()
    assert (paths.repo_root() / "data" / "problems").is_dir()

