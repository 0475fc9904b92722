"""The documentation site's sources (docs/): every example runs and prints what its page shows, every notebook is
on a results page, and the commands a page gives work on a fresh clone.

``make docs`` (run by ``make test``) builds the site with warnings as errors and every cross-reference checked
(Sphinx's nitpicky mode); these tests check what the build cannot.
"""

from __future__ import annotations

import json
import os
import re
import subprocess

import pytest
from _examples import CODE_WIDTH, DOCS, REPO, TRACKER, code_blocks, examples, run_session, same_print, section

#: the site's pages as written (not the gallery's, which docs/_gallery.py writes from the collection at build time:
#: tests/test_collection.py checks them, and the build runs their code)
PAGES = sorted(
    p
    for p in DOCS.rglob("*.md")
    if not p.relative_to(DOCS).parts[0].startswith("_") and p.relative_to(DOCS).parts[0] != "gallery"
)
WITH_EXAMPLES = [page for page in PAGES if examples(page.read_text())]
LIBRARY_ALONE = {"stating-a-problem.md", "constraints-parameters-phases.md", "indirect.md", "ocpkit.md", "how-do-i.md"}
#: the pages written for users: all but the changelog, which is history by design (it includes CHANGELOG.md)
USER_PAGES = [page for page in PAGES if page.name != "changelog.md"]


@pytest.mark.parametrize("page", WITH_EXAMPLES, ids=[str(p.relative_to(DOCS)) for p in WITH_EXAMPLES])
def test_every_example_on_the_site_runs_and_prints_what_its_page_shows(page, tmp_path):
    """A page's examples run in order, as a reader would paste them, from a folder outside the repository; each
    prints what the page shows after it."""
    cases = examples(page.read_text())
    if page.name in LIBRARY_ALONE:
        assert all("compendium" not in code for code, _ in cases), f"{page.name} is about the library alone"
    printed, stderr = run_session([code for code, _ in cases], tmp_path)
    assert printed is not None, f"{page.relative_to(DOCS)}:\n{stderr[-3000:]}"
    for k, ((_, shown), out) in enumerate(zip(cases, printed)):
        if shown is not None:
            assert same_print(out, shown) == [], f"{page.relative_to(DOCS)}, example {k}"


def test_the_examples_are_found():
    """The runner above sees the pages' examples (a change of fence syntax would otherwise skip them silently)."""
    names = {page.name for page in WITH_EXAMPLES}
    assert {"stating-a-problem.md", "constraints-parameters-phases.md", "indirect.md", "many-solves.md"} <= names
    shown = [printed for page in WITH_EXAMPLES for _, printed in examples(page.read_text()) if printed is not None]
    assert len(shown) >= 4


def test_no_user_page_names_the_tracker():
    """History belongs to the changelog: no user page, nor a docstring the API pages render, says "issue 26"."""
    found = [f"{p.relative_to(DOCS)}: {m}" for p in USER_PAGES for m in TRACKER.findall(p.read_text())]
    library = sorted((REPO / "src" / "ocpkit").rglob("*.py"))
    found += [f"{p.relative_to(REPO)}: {m}" for p in library for m in TRACKER.findall(p.read_text())]
    assert found == []
    assert TRACKER.findall("Issue 26's goals; issues 12 and 22; issue #7") == ["Issue 26", "issues 12", "issue #7"]


def test_every_code_block_on_a_user_page_fits_the_page():
    """A code block's longest line is at most CODE_WIDTH characters, the width a block shows whole in a window
    1440 px wide (docs/_static/site.css; tests/test_site.py measures it in Chromium)."""
    long = [
        f"{page.relative_to(DOCS)}: {len(line)} characters: {line[:60]}..."
        for page in USER_PAGES
        for _, code in code_blocks(page.read_text())
        for line in code.splitlines()
        if len(line) > CODE_WIDTH
    ]
    assert long == []
    assert sum(len(code_blocks(page.read_text())) for page in USER_PAGES) > 30, "the blocks are found"


def test_the_how_do_i_page_answers_the_first_questions():
    """Each question a newcomer asks first has its section, with an example that prints what it shows, or draws the
    picture under it (drawn at build time by that example, docs/_example_figures.py)."""
    page = DOCS / "guide" / "how-do-i.md"
    text = page.read_text()
    for question, call in [
        ("solve for minimum time?", "FreeFinalTime("),
        ("give an initial guess?", "Guess("),
        ("fix an end value, or let it lie in a range?", "final=(-0.1, 0.1)"),
        ("look at a solution?", "fig = sol.plot()"),
        ("refine the mesh until the solution is accurate?", "mesh_history"),
        ("sample a quantity derived from the solution?", ".sample(lambda x, u, t"),
        ("tell whether a solution can be trusted?", "verdict"),
        ("declare an angle, so that whole turns do not matter?", "period="),
        ("use a parameter, and solve for several of its values?", "parameters={"),
        ("link phases?", "MultiPhaseProblem("),
    ]:
        cases = examples(section(page, f"... {question}"))
        assert cases and any(call in code for code, _ in cases), question
        drawn = [code for code, printed in cases if printed is None]
        assert all(code.startswith("fig = ") for code in drawn), f"{question}: every example shows what it prints"
        assert section(page, f"... {question}").count("](../_generated/") == len(drawn), f"{question}: its pictures"
    assert "how-do-i" in (DOCS / "guide" / "index.md").read_text()
    assert "compendium" not in text


def test_the_first_example_matches_the_exact_cost():
    """J = 3/8 - sqrt(3)/12: the saturated-linear control u = 0.5 sat((t - 1.5) / sigma), sigma^2 = 3/4."""
    code, _ = examples((DOCS / "guide" / "stating-a-problem.md").read_text())[0]
    namespace: dict = {}
    exec(compile(code, "stating-a-problem.md", "exec"), namespace)  # noqa: S102
    exact = 3 / 8 - 3**0.5 / 12
    assert abs(namespace["indirect"].objective - exact) < 1e-9
    for name in ("hlgl", "radau"):
        assert abs(namespace[name].objective - exact) < 1e-5, name


def test_the_printed_example_is_compared_by_class_not_digit_for_digit():
    shown = "ShootingTrajectory J = 0.23066243, re-integration error 1.2e-15"
    assert same_print("ShootingTrajectory J = 0.23066243, re-integration error 1.1e-15", shown) == []
    assert same_print("ShootingTrajectory J = 0.23066243, re-integration error 8.0e-16", shown) == []
    assert same_print("ShootingTrajectory J = 0.23067243, re-integration error 1.2e-15", shown)  # 4e-5 relative
    assert same_print("ShootingTrajectory J = 0.23066243, re-integration error 1.2e-05", shown)
    verdict = "passed at 1e-06: state 9.5e-08, objective 1.5e-07; J 0.2306625526, flown 0.2306625191"
    assert same_print(verdict.replace("9.5e-08", "9.1e-08").replace("1.5e-07", "1.6e-07"), verdict) == []
    assert same_print(verdict.replace("9.5e-08", "9.5e-07"), verdict)  # an estimate ten times larger
    assert same_print(verdict.replace("passed at", "failed at"), verdict)  # the words exactly
    assert same_print(verdict.replace("0.2306625526", "0.2306635526"), verdict)  # a cost converged


def test_the_one_call_example_reaches_the_reference_junctions():
    """The Goddard rocket with a speed limit: bang, singular, boundary and off arcs at OptimalControl.jl's
    junctions (the page's printed values are those of data/paper/goddard_control_toolbox.csv to 1e-9)."""
    import pandas as pd

    code, printed = next(e for e in examples((DOCS / "guide" / "indirect.md").read_text()) if "to_extremal(" in e[0])
    shown = dict(line.split(": ", 1) for line in printed.strip().splitlines())
    reference = pd.read_csv(REPO / "data" / "paper" / "goddard_control_toolbox.csv", comment="#")
    reference = reference.set_index("quantity")["value"]
    junctions = [float(v) for v in shown["junctions and t_f"].split(", ")]
    for value, name in zip(junctions, ("t1", "t2", "t3", "tf")):
        assert abs(value - reference[name]) < 1e-9, name


def test_the_results_list_every_notebook():
    listed = set()
    for page in (DOCS / "results").glob("*.md"):
        listed |= set(re.findall(r"_notebooks/(\S+)", page.read_text()))
    assert listed == {p.stem for p in (REPO / "notebooks").glob("*.ipynb")}


def _tables_module():
    import sys

    sys.path.insert(0, str(DOCS))
    try:
        import _tables
    finally:
        sys.path.remove(str(DOCS))
    return _tables


def test_every_generated_table_is_on_a_page():
    TABLES = _tables_module().TABLES
    text = "".join(page.read_text() for page in PAGES)
    assert [name for name in TABLES if f"_generated/{name}.md" not in text] == []


def test_generated_tables_do_not_depend_on_the_csv_files_row_order(monkeypatch):
    """A published run that writes its rows in another order gives the same tables."""
    _tables = _tables_module()
    written = {name: make() for name, make in _tables.TABLES.items()}
    read = _tables._read
    monkeypatch.setattr(_tables, "_read", lambda path: read(path).iloc[::-1].reset_index(drop=True))
    reordered = {name: make() for name, make in _tables.TABLES.items()}
    keyed = ("two_timescale_solvers",)  # tables whose rows are keyed, not listed in the run's order
    assert {name: reordered[name] for name in keyed} == {name: written[name] for name in keyed}
    quoted = _tables.values()
    monkeypatch.setattr(_tables, "_read", read)
    assert quoted == _tables.values()


def test_every_number_the_prose_quotes_from_data_is_on_a_page_and_defined():
    """A page writes ``{{ name }}`` for a number of a published run (MyST substitutions, docs/_tables.py values)."""
    quoted = _tables_module().values()
    used = {name for page in PAGES for name in re.findall(r"\{\{ *(\w+) *\}\}", page.read_text())}
    assert used == set(quoted)
    assert all(value and "nan" not in value for value in quoted.values())


def test_bounds_the_prose_states_are_rounded_to_the_side_it_claims():
    """ "within 7 %" for 6.3 %, "24 % fewer" for 24.9 %, "at or below 3e-13" for 2.1e-13: a bound is never rounded
    past the value it bounds."""
    tables = _tables_module()
    assert tables._percent(0.063) == "6 %" and tables._percent(0.063, "most") == "7 %"
    assert tables._percent(0.249, "least") == "24 %" and tables._percent(0.25, "most") == "25 %"
    assert tables._sci(3.2e-5) == "3e-5" and tables._sci(2.14e-13, "most") == "3e-13"
    assert tables._sci(9.5e-8, "most") == "1e-7" and tables._sci(2e-13, "most") == "2e-13"
    assert tables._sci(1.2149e-10, "most", digits=2) == "1.3e-10" and tables._sci(1.2149e-10, digits=2) == "1.2e-10"
    assert tables._percent(0.07, "most") == "7 %" and tables._percent(0.29, "least") == "29 %"
    assert tables._metres(0.005158, "most") == "6 mm" and tables._metres(0.005158) == "5 mm"


def test_other_parameters_commands_run_verbatim_on_a_fresh_clone(tmp_path):
    """Both commands, as printed, in a fresh clone: they work, and the published record stays as it was."""
    text = section(DOCS / "guide" / "notebooks-and-lab.md", "One notebook with other parameters")
    commands = re.findall(r"```sh\n(.*?)```", text, flags=re.S)
    assert len(commands) == 2 and all("segments 40" in c for c in commands)
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
    (clone / ".venv").symlink_to(REPO / ".venv")  # what `make setup` would build, shared
    env = {k: v for k, v in os.environ.items() if k != "OCPKIT_OUTPUT_DIR"} | {"OCPKIT_ROOT": str(clone)}
    for command in commands:
        proc = subprocess.run(command, shell=True, cwd=clone, env=env, capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, f"{command}\n{proc.stderr[-3000:]}"
    run_dir = clone / "build" / "runs" / "01_lunar_ascent" / "segments-40"
    assert (run_dir / "01_lunar_ascent.ipynb").is_file(), "the runner's executed notebook, beside its figures"
    assert (clone / "build" / "lunar_40.ipynb").is_file()
    record = json.loads((run_dir / "data" / "derived" / "runs" / "01_lunar_ascent.json").read_text())
    assert record["parameters"]["segments"] == 40 and record["published_parameters"] is False
    head = subprocess.run(["git", "-C", str(clone), "rev-parse", "HEAD"], capture_output=True, text=True).stdout
    assert record["git"]["commit"] == head.strip() and record["git"]["dirty"] is False, "the checkout it ran at"
    assert json.loads((run_dir / "data" / "derived" / "lunar_ascent_summary.json").read_text())["segments"] == 40
    assert (run_dir / "figures" / "figure6_theta.png").is_file()
    status = subprocess.run(
        ["git", "status", "--porcelain", "--", "figures", "data", "notebooks", "src"],
        cwd=clone,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert status == "", f"the published record changed:\n{status}"


def test_the_api_reference_documents_every_public_module_and_name():
    """Every public module of ocpkit has its page (an automodule), and every name ocpkit and ocpkit.shooting export
    is documented there with a docstring; a module's page is its own (docs/api/<group>/<module>.md, the group page
    an index of them), so that no page of the reference is tens of thousands of pixels long."""
    import importlib
    import pkgutil

    import ocpkit
    import ocpkit.shooting

    pages = sorted((DOCS / "api").rglob("*.md"))
    documented = set(re.findall(r"automodule:: (\S+)", "".join(p.read_text() for p in pages)))
    assert [p.name for p in pages if p.read_text().count("automodule::") > 1] == [], "one module per page"
    modules = {m.name for m in pkgutil.walk_packages(ocpkit.__path__, "ocpkit.")}
    public = {m for m in modules if not any(part.startswith("_") for part in m.split("."))}
    packages = {m for m in public if hasattr(importlib.import_module(m), "__path__")}
    assert sorted(public - packages - documented) == []
    for package in (ocpkit, ocpkit.shooting):
        for name in package.__all__:
            obj = getattr(package, name)
            if isinstance(obj, (type, type(len))) or callable(obj):
                assert obj.__module__ in documented, f"{package.__name__}.{name}"
                assert (obj.__doc__ or "").strip(), f"{package.__name__}.{name} has no docstring"


def test_the_notebooks_page_quotes_the_runners_own_message_for_a_wrong_type():
    from compendium.notebook_source import check_parameters

    with pytest.raises(ValueError) as caught:
        check_parameters(REPO / "notebooks" / "01_lunar_ascent.ipynb", {"thrust_to_weight": "fast"})
    page = " ".join((DOCS / "guide" / "notebooks-and-lab.md").read_text().split())
    assert f"`{caught.value}`" in page
