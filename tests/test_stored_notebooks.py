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
