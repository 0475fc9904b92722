"""The stored notebooks as readers meet them on GitHub and nbviewer: every figure inline, small files,
and every output written through compendium.outputs (never straight to figures/ or data/derived/)."""

import re

import nbformat
import pytest

from compendium import paths

NOTEBOOKS = sorted(paths.notebooks_dir().glob("*.ipynb"))
MAX_BYTES = 3_000_000  # a stored notebook, figures included


def _code(path):
    return [c for c in nbformat.read(str(path), as_version=4).cells if c.cell_type == "code"]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_every_figure_cell_shows_its_figure(path):
    cells = [c for c in _code(path) if "outputs.figure(" in c.source]
    assert cells, "the notebook draws figures"
    for cell in cells:
        images = [o for o in cell.outputs if o.output_type == "display_data" and "image/png" in o.get("data", {})]
        assert images, f"no inline figure stored for the cell starting {cell.source.splitlines()[1]!r}"
        assert "NBVAL_CHECK_OUTPUT" in cell.source, "nbval checks that the figure is drawn (size and axes)"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_stored_notebooks_stay_small(path):
    assert path.stat().st_size < MAX_BYTES


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_outputs_are_written_through_compendium_outputs(path):
    cells = _code(path)
    sources = "\n".join(c.source for c in cells)
    assert re.search(r"^outputs = Outputs\.start\(\"" + path.stem + r"\", globals\(\)\)", sources, re.M)
    assert cells[-1].source.rstrip().endswith("outputs.publish()"), "the last cell publishes the run's outputs"
    for forbidden in (".to_csv(", ".savefig(", ".write_text(", "derived_dir", "figures_dir", "save_figure("):
        assert forbidden not in sources, f"{forbidden} in {path.name}: write through `outputs`"


_VOLATILE = {
    "a memory address (a Styler's plain-text form: use compendium.tables.show)": re.compile(r" at 0x[0-9a-f]+>"),
    "a random table id (a Styler: use compendium.tables.show)": re.compile(r'id="T_[0-9a-f]{5}_'),
    "a measured time": re.compile(r"\b(build|solve)\b[^\n]{0,12}\d+(\.\d+)? m?s\b"),
}


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_stored_outputs_hold_nothing_that_changes_from_run_to_run(path):
    """So that Run All and save on the reference machine leaves `git status` clean."""
    for cell in _code(path):
        for output in cell.outputs:
            text = output.get("text", "") + "".join(
                v if isinstance(v, str) else "".join(v)
                for k, v in output.get("data", {}).items()
                if k.startswith("text/")
            )
            for what, pattern in _VOLATILE.items():
                assert not pattern.search(text), f"{what} in the cell starting {cell.source.splitlines()[0]!r}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_the_first_output_line_says_where_the_run_writes(path):
    first = next(c for c in _code(path) if "Outputs.start(" in c.source).outputs[0]["text"].splitlines()[0]
    assert first.startswith(f"This run writes its figures and tables to build/runs/{path.stem}/"), first
