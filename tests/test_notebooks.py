"""Notebook structure, parameter handling and folder independence (compendium.notebooks, compendium.notebook_source)."""

import base64
import json
import re
from pathlib import Path

import nbformat
import pytest

from compendium import paths
from compendium.notebook_source import (
    check_parameters,
    notebook_parameters,
    parameter_types,
    published_overrides,
    published_parameters,
)
from compendium.notebooks import KERNEL_NAME, execute
from compendium.provenance import ONE_THREAD, RUN_RECORD_KEY, read_run_record

NOTEBOOKS = sorted(paths.notebooks_dir().glob("*.ipynb"))
NOTEBOOK_01 = paths.notebooks_dir() / "01_lunar_ascent.ipynb"


def test_there_are_notebooks():
    assert [p.name for p in NOTEBOOKS][:2] == ["00_validation.ipynb", "01_lunar_ascent.ipynb"]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_structure(path):
    nb = nbformat.read(str(path), as_version=4)
    assert nb.metadata["kernelspec"]["name"] == KERNEL_NAME
    assert notebook_parameters(path), "one parseable parameters cell"
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert any("# NBVAL_CHECK_OUTPUT" in c.source for c in code), "key numbers are checked by nbval"
    # stored with the outputs of a complete run (the nbval reference), with no errors
    assert all(c.execution_count is not None for c in code), "store the executed notebook (make store)"
    outputs = [o for c in code for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    text = json.dumps([o for o in outputs if o.output_type != "display_data"])
    assert str(paths.repo_root()) not in text, "outputs must not record machine-specific paths"
    assert "is deprecated; use" not in text, "a notebook uses a renamed name (CHANGELOG.md): use the new one"


def test_unknown_parameter_is_an_error():
    with pytest.raises(ValueError, match=r"unknown parameter\(s\) \['segmnts'\].*segments"):
        check_parameters(paths.notebooks_dir() / "01_lunar_ascent.ipynb", {"segmnts": 10})


def test_unparseable_parameter_line_is_an_error(tmp_path):
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": KERNEL_NAME, "display_name": "Python (ocpkit)", "language": "python"}
    cell = nbformat.v4.new_code_cell("a = 1  # fine\nb = 2  # a comment with = breaks papermill")
    cell.metadata["tags"] = ["parameters"]
    nb.cells.append(cell)
    path = tmp_path / "bad.ipynb"
    nbformat.write(nb, str(path))
    with pytest.raises(ValueError, match=r"cannot parse the parameter line\(s\) of \['b'\]"):
        notebook_parameters(path)


def _parameters_notebook(tmp_path, source: str) -> Path:
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": KERNEL_NAME, "display_name": "Python (ocpkit)", "language": "python"}
    cell = nbformat.v4.new_code_cell(source)
    cell.metadata["tags"] = ["parameters"]
    nb.cells.append(cell)
    path = tmp_path / "typed.ipynb"
    nbformat.write(nb, str(path))
    return path


def test_a_value_of_the_wrong_type_is_named_with_the_type_and_an_example(tmp_path):
    path = _parameters_notebook(
        tmp_path,
        "segments = 20  # a count\n"
        "tol = 1e-8\n"
        "thrust: float = None  # None: the paper's\n"
        "thrusts = [5.0, 1.0]  # type: Optional[list] None: all of them\n"
        "label = 'fast'\n"
        "anything = None  # no type named\n"
        "recompute = False\n",
    )
    types = parameter_types(path)
    assert types["segments"] == (int,) and types["thrust"] == (float, None) and types["thrusts"] == (list, None)
    assert types["anything"] == () and types["recompute"] == (bool,)
    # admitted: an int for a float, None where the default or the type comment says so, anything where nothing does
    check_parameters(path, {"tol": 1, "thrust": 2, "thrusts": None, "anything": "x", "label": "slow", "segments": 4})
    with pytest.raises(ValueError) as caught:
        check_parameters(path, {"thrust": "fast", "segments": True, "tol": None, "recompute": 1, "label": 3})
    lines = str(caught.value).splitlines()
    assert lines == [
        "typed.ipynb: the parameter 'thrust' takes a float or None, but the value given is 'fast' (a str): "
        "give a float or None, e.g. -p thrust 2.5",
        "typed.ipynb: the parameter 'segments' takes an int, but the value given is True (a bool): "
        "give an int, e.g. -p segments 20",
        "typed.ipynb: the parameter 'tol' takes a float, but the value given is None (None): "
        "give a float, e.g. -p tol 1e-08",
        "typed.ipynb: the parameter 'recompute' takes a bool, but the value given is 1 (an int): "
        "give a bool, e.g. -p recompute False",
        "typed.ipynb: the parameter 'label' takes a str, but the value given is 3 (an int): "
        "give a str, e.g. -p label fast",
    ]


def test_a_type_papermill_cannot_read_is_an_error(tmp_path):
    with pytest.raises(ValueError, match=r"cannot parse the parameter line\(s\) of \['a'\]"):
        notebook_parameters(_parameters_notebook(tmp_path, "a: float | None = None  # papermill skips this line"))
    with pytest.raises(ValueError, match=r"annotation 'ndarray' of the parameter 'b' in typed.ipynb is none of"):
        parameter_types(_parameters_notebook(tmp_path, "b: ndarray = None"))


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_every_parameter_of_the_notebooks_has_a_type(path):
    """A default of None names the type the parameter takes, so that a value of another type is caught."""
    assert [name for name, types in parameter_types(path).items() if not types] == []


def test_the_runner_names_a_wrong_type_before_any_kernel_starts(monkeypatch, capsys):
    from compendium import notebooks

    monkeypatch.setattr(notebooks, "execute", lambda *a, **k: pytest.fail("a kernel started"))
    nb = str(paths.notebooks_dir() / "01_lunar_ascent.ipynb")
    other = str(paths.notebooks_dir() / "00_validation.ipynb")
    assert notebooks.main(["run", other, nb, "-p", "thrust_to_weight", "fast"]) == 2
    err = capsys.readouterr().err
    assert "01_lunar_ascent.ipynb: the parameter 'thrust_to_weight' takes a float or None" in err
    assert "the value given is 'fast' (a str)" in err and "e.g. -p thrust_to_weight 2.5" in err
    assert "unknown parameter(s) ['thrust_to_weight'] for 00_validation.ipynb" in err  # the first, checked too


def _kernel_available():
    from jupyter_client.kernelspec import KernelSpecManager

    return KERNEL_NAME in KernelSpecManager().find_kernel_specs()


@pytest.mark.skipif(not _kernel_available(), reason="the 'ocpkit' kernel is registered by `make setup`")
def test_notebook_runs_from_any_folder_with_other_parameters(tmp_path, monkeypatch):
    """papermill in a foreign working directory, outputs redirected: the notebook finds data/ itself. With another
    thrust, it prints the thrust it solved with, its figures (saved and inline) carry the note of a run that is not
    the published one, and the executed notebook keeps its run's record, which says the kernel had one BLAS and one
    OpenMP thread although the process that started it had other settings."""
    out_root = tmp_path / "outputs"
    monkeypatch.setenv("OCPKIT_OUTPUT_DIR", str(out_root))
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)  # started by hand, not by make: OpenBLAS' own threads
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    out = execute(
        paths.notebooks_dir() / "01_lunar_ascent.ipynb",
        tmp_path / "run.ipynb",
        {"segments": 6, "smoothing_study": [1e-8], "plot_points": 11, "thrust_to_weight": 2.5},
        cwd=elsewhere,
    )
    executed, stored = nbformat.read(str(out), as_version=4), nbformat.read(str(NOTEBOOK_01), as_version=4)
    printed = "".join(o.get("text", "") for c in executed.cells if c.get("id") == "3c3812c5" for o in c.outputs)
    assert printed.startswith("a = 2.5 (the paper's 3.0), g = 1.0")

    def heights(nb):  # of the figure cell's inline PNGs, from their IHDR
        cell = next(c for c in nb.cells if c.get("id") == "caf6e89e")
        pngs = [base64.b64decode(o["data"]["image/png"]) for o in cell.outputs if "image/png" in o.get("data", {})]
        return [int.from_bytes(png[20:24], "big") for png in pngs]

    assert len(heights(executed)) == 3
    assert all(h > s for h, s in zip(heights(executed), heights(stored)))  # the note's line above each figure
    assert executed.metadata[RUN_RECORD_KEY]["parameters"]["thrust_to_weight"] == 2.5
    summary = json.loads((out_root / "data" / "derived" / "lunar_ascent_summary.json").read_text())
    assert summary["segments"] == 6 and summary["nlp_parameters"] == 4 * 13 + 25 + 1
    assert summary["status"] == "Solve_Succeeded"
    assert "build_s" not in summary, "timings live in the run record, not in the published table"
    assert (out_root / "figures" / "figure6_theta.pdf").is_file()
    record = read_run_record(out_root, "01_lunar_ascent")
    assert record["parameters"]["segments"] == 6 and not record["published_parameters"]
    assert record["threads"] == ONE_THREAD, "the kernel runs with make's one BLAS and OpenMP thread, whoever starts it"
    assert record["timings"]["lunar_ascent"][0]["solve_s"] > 0
    assert Path(out).is_file()


def test_published_runs_are_declared_for_known_parameters():
    """notebooks/published.toml names only parameters the notebooks declare, as Python literals."""
    for path in NOTEBOOKS:
        overrides = published_overrides(path)
        check_parameters(path, overrides)
        assert published_parameters(path.stem).items() >= overrides.items()
    assert published_overrides(paths.notebooks_dir() / "05_orbit_transfer.ipynb")["thrusts"] is None


def test_the_report_shows_the_figures_and_serves_mathjax_itself(tmp_path):
    """HTML pages with their figures inline and MathJax from the report's own folder (readable offline)."""
    import shutil

    from compendium.report import build_report

    executed = tmp_path / "executed"
    executed.mkdir()
    shutil.copy(paths.notebooks_dir() / "01_lunar_ascent.ipynb", executed)
    index = build_report(executed, tmp_path / "report")
    page = (tmp_path / "report" / "01_lunar_ascent.html").read_text()
    stored = nbformat.read(str(executed / "01_lunar_ascent.ipynb"), as_version=4)
    figures = sum("image/png" in o.get("data", {}) for c in stored.cells if c.cell_type == "code" for o in c.outputs)
    assert figures >= 3 and len(re.findall(r'<img [^>]*src="data:image/png;base64,', page)) == figures
    assert 'src="mathjax/MathJax.js?config=' in page and "libs/mathjax" not in page
    assert (tmp_path / "report" / "mathjax" / "MathJax.js").is_file()
    assert "01_lunar_ascent.html" in index.read_text()


def test_the_example_of_a_wrong_type_can_be_pasted_into_a_shell():
    """A list with strings in it is shown in double quotes, an empty default gives a usable example."""
    import shlex

    from compendium.notebook_source import _wrong_type

    said = _wrong_type("02.ipynb", "case1_fast", 3, (list,), ["U", "V"])
    assert (
        said.endswith("""e.g. -p case1_fast "['U', 'V']\"""") and shlex.split(said.split("e.g. ")[1])[2] == "['U', 'V']"
    )
    assert _wrong_type("05.ipynb", "horizon_seeds", "x", (list,), []).endswith("e.g. -p horizon_seeds '[1.0, 2.0]'")
