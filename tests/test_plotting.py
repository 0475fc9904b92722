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


def test_junctions_drawn_at_the_extremals_converged_times():
    """A junction read from samples (on their grid) is drawn at the extremal's own junction nearest it; a time with
    none near stays as read."""
    from types import SimpleNamespace

    from compendium.plotting import _junction_times

    extremal = SimpleNamespace(t0=0.0, tf=1.0, breakpoints=[0.0, 0.13629903, 0.72523011, 1.0])
    at = _junction_times(extremal)
    assert at(0.1363875) == 0.13629903 and at(0.725125) == 0.72523011 and at(1.0) == 1.0
    assert at(0.5) == 0.5
    assert _junction_times(SimpleNamespace(t0=0.0, tf=2.0))(0.999) == 0.999


def test_a_junction_snaps_only_to_its_own_controls_junctions():
    """Two controls switching 0.005 apart: each control's junction read from the samples goes to its own converged
    time, not to the other control's nearer one."""
    from types import SimpleNamespace

    from ocpkit.shooting.arcs import ArcType

    from compendium.plotting import _junction_times

    extremal = SimpleNamespace(t0=0.0, tf=1.0, breakpoints=[0.0, 0.400, 0.405, 1.0])
    kinds = [ArcType(("upper", "lower")), ArcType(("lower", "lower")), ArcType(("lower", "upper"))]
    first, second = (_junction_times(extremal, kinds=kinds, control=i) for i in (0, 1))
    assert first(0.4049) == 0.400 and second(0.4001) == 0.405
    assert first(1.0) == 1.0 and second(0.0) == 0.0
    assert _junction_times(extremal)(0.4049) == 0.405, "without the arc types, every breakpoint is a candidate"
    # a state constraint becomes active at 0.405 for the second control (a boundary arc): not the first's junction
    kinds = [ArcType(("upper", "lower")), ArcType(("lower", "lower")), ArcType(("lower", "boundary"), "x.upper")]
    first, second = (_junction_times(extremal, kinds=kinds, control=i) for i in (0, 1))
    assert first(0.4049) == 0.400 and second(0.4001) == 0.405
