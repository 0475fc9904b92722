"""The HTML report (compendium.report, compendium.mathjax): pages that read as a report, offline, in TeX fonts.

nbval keeps no executed notebooks, so the report is built here from the stored notebooks (their outputs are those
of a complete run), into a temporary folder: a few for the page-by-page checks, all of them once. The browser test
serves a report over a local HTTP server to headless Chromium, driven over the DevTools Protocol as in
test_lab_roundtrip, with the system's MathJax fonts hidden from it (as on a reader's machine without them), and
checks what it shows and every request it makes.
"""

from __future__ import annotations

import html
import json
import os
import re
import shutil
import subprocess
import time
from html.parser import HTMLParser
from pathlib import Path

import nbformat
import pytest
from _browser import FONTCONFIG, Recorder, served
from test_lab import REQUIRE_BROWSER, needs_chromium

from compendium import mathjax, paths
from compendium.checks import check, check_true
from compendium.notebooks import keep_run_record
from compendium.provenance import PACKAGES, RUN_RECORD_KEY, environment
from compendium.report import (
    HIDE_CELL,
    REMOVE_CELL,
    UNFINISHED,
    Unfinished,
    build_report,
    run_facts,
    strip_markers,
    title,
    verdicts,
)

NOTEBOOKS = sorted(paths.notebooks_dir().glob("*.ipynb"))
#: equations, a warning on standard error and printed checks; printed checks; quiet checks and other parameters
SOME = ["00_validation", "04_shooting_validation", "05_orbit_transfer"]


def _text(page: str) -> str:
    """The text of HTML, tags left out (highlighted code is split into spans)."""
    return re.sub(r"<[^>]+>", "", page)


def _read(path: Path):
    return nbformat.read(str(path), as_version=4)


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> Path:
    executed = tmp_path_factory.mktemp("executed")
    for name in SOME:
        shutil.copy(paths.notebooks_dir() / f"{name}.ipynb", executed)
    out = tmp_path_factory.mktemp("report")
    build_report(executed, out)
    return out


def _page(report: Path, name: str) -> str:
    return (report / f"{name}.html").read_text(encoding="utf-8")


class _Elements(HTMLParser):
    """Tags with their attributes, ids, the text of ``<title>``, and the CSS of ``<style>`` elements."""

    def __init__(self, page: str):
        super().__init__()
        self.tags: list[tuple[str, dict]] = []
        self.ids: set[str] = set()
        self.title = ""
        self.css: list[str] = []
        self._in: str | None = None
        self.feed(page)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        self.tags.append((tag, attrs))
        if attrs.get("id"):
            self.ids.add(attrs["id"])
        self._in = tag if tag in ("title", "style") else None

    def handle_endtag(self, tag):
        self._in = None

    def handle_data(self, data):
        if self._in == "title":
            self.title += data
        elif self._in == "style":
            self.css.append(data)

    def of(self, tag: str, **having) -> list[dict]:
        return [a for t, a in self.tags if t == tag and all(a.get(k) == v for k, v in having.items())]


# -- the notebooks' tags ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_plumbing_cells_carry_the_tags_that_hide_them(path):
    """Opening the run's outputs is folded away, publishing them left out (the report and myst-nb read the tags)."""
    code = [c for c in _read(path).cells if c.cell_type == "code"]
    tagged = {tag: [c for c in code if tag in c.metadata.get("tags", [])] for tag in (HIDE_CELL, REMOVE_CELL)}
    assert [c.source for c in tagged[HIDE_CELL]] == [c.source for c in code if "Outputs.start(" in c.source]
    assert tagged[REMOVE_CELL] == [code[-1]] and code[-1].source.rstrip().endswith("outputs.publish()")


# -- pages ---------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", SOME)
def test_plumbing_is_hidden_and_nbval_markers_are_gone(report, name):
    page = _page(report, name)
    assert "outputs.publish()" not in page and "wrote " not in page  # the removed cell, and its output
    folded = re.findall(r'<details class="report-folded">.*?</details>', page, re.S)
    assert len(folded) == 1 and "Outputs.start" in _text(folded[0])
    assert "Outputs.start" not in _text(page.replace(folded[0], ""))
    assert "NBVAL" not in page
    assert "NBVAL_CHECK_OUTPUT" in json.dumps(_read(paths.notebooks_dir() / f"{name}.ipynb"))  # still in the file


def test_strip_markers_keeps_every_other_line():
    source = "# NBVAL_CHECK_OUTPUT (a note)\nx = 1\n    # NBVAL_IGNORE_OUTPUT\n# a comment\ny = 2"
    assert strip_markers(source) == "x = 1\n# a comment\ny = 2"


@pytest.mark.parametrize("name", SOME)
def test_each_page_has_its_title_and_a_contents_list_of_its_headings(report, name):
    page = _page(report, name)
    dom = _Elements(page)
    first = title(_read(paths.notebooks_dir() / f"{name}.ipynb"))
    assert dom.title.strip() == first and first.startswith(name[:2])
    toc = re.search(r'<nav aria-label="Contents" class="report-toc">(.*?)</nav>', page, re.S).group(1)
    targets = re.findall(r'<a href="#([^"]+)">', toc)
    headings = sum(
        len(re.findall(r"^#{1,3} ", c.source, re.M))
        for c in _read(paths.notebooks_dir() / f"{name}.ipynb").cells
        if c.cell_type == "markdown"
    )
    assert len(targets) == headings + 2  # the notebook's headings, "This run" and "Checks"
    assert {"report-run", "report-checks"} <= set(targets)
    assert all(html.unescape(t) in dom.ids for t in targets), [t for t in targets if html.unescape(t) not in dom.ids]


def test_pages_link_to_the_index_and_to_each_other_in_order(report):
    for k, name in enumerate(SOME):
        dom = _Elements(_page(report, name))
        assert dom.of("a", href="index.html")
        previous = [a["href"] for a in dom.of("a", rel="prev")]
        following = [a["href"] for a in dom.of("a", rel="next")]
        assert previous == ([f"{SOME[k - 1]}.html"] * 2 if k > 0 else [])  # in the bars above and below
        assert following == ([f"{SOME[k + 1]}.html"] * 2 if k + 1 < len(SOME) else [])
    index = (report / "index.html").read_text()
    for name in SOME:
        assert f'href="{name}.html"' in index and (report / f"{name}.html").is_file()
        assert title(_read(paths.notebooks_dir() / f"{name}.ipynb")).replace("&", "&amp;") in index


def _git(*args: str) -> str | None:
    done = subprocess.run(["git", "-C", str(paths.repo_root()), *args], capture_output=True, text=True)
    return done.stdout.strip() if done.returncode == 0 else None


@pytest.mark.parametrize("where", ["index", *SOME])
def test_provenance_names_commit_machine_python_packages_and_the_run(report, where):
    page = _page(report, where) if where != "index" else (report / "index.html").read_text()
    env = environment()
    commit = _git("rev-parse", "HEAD")
    path = paths.notebooks_dir() / f"{where}.ipynb"
    record = run_facts(path, _read(path)).record if where != "index" else None
    if record is not None and record.get("git"):  # a run of this notebook recorded here (make store, nbval): its commit
        assert f"<code>{record['git']['commit'][:12]}</code>" in page and "from its record" in page
    elif commit is None:
        assert "not a git checkout" in page
    else:
        assert f"<code>{commit[:12]}</code>" in page
        changed = [line[3:] for line in _git("status", "--porcelain", "--untracked-files=no").splitlines()]
        dirty = any(not f.startswith(("figures/", "data/derived/")) for f in changed)
        assert ('class="report-fail">dirty</span>' in page) is dirty and ('">clean</span>' in page) is not dirty
    assert env["platform"] in page and "logical CPUs" in page and env["python"] in page
    for name in PACKAGES:
        assert f"{name} {env['packages'][name]}" in page
    if where == "index":
        assert "Report built" in page and "their stored outputs (no run date recorded)" in page
        return
    assert "no date recorded (the notebook's stored outputs)" in page
    assert f"<code>build/runs/{where}/defaults/</code>" in page  # the first output line of the stored notebook
    published = "yes: the published parameters" in page
    assert published is (where != "05_orbit_transfer")  # notebooks/published.toml: the orbit transfer's full run
    if not published:
        assert '<code class="changed">thrusts = [5.0, 1.0]</code>' in page


def test_a_record_rewritten_by_runs_is_not_a_dirty_checkout(tmp_path):
    """After make reproduce on another machine, the published record differs from the commit's at rounding level:
    the report says so apart, and the checkout stays clean; a changed source makes it dirty."""
    import subprocess

    from compendium.provenance import git_state
    from compendium.report import _commit

    def git(*args):
        subprocess.run(["git", "-C", str(tmp_path), *args], check=True, capture_output=True)

    git("init", "-q")
    (tmp_path / "data" / "derived").mkdir(parents=True)
    (tmp_path / "data" / "derived" / "x.csv").write_text("1\n")
    (tmp_path / "src.py").write_text("")
    git("add", ".")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-q", "-m", "x")
    (tmp_path / "data" / "derived" / "x.csv").write_text("1.0000000001\n")
    state = git_state(tmp_path)
    assert state is not None and not state["dirty"] and state["record"] == ["data/derived/x.csv"]
    text = _commit(state)
    assert '">clean</span>; the published record' in text and "differs from the commit's in 1 file," in text
    (tmp_path / "src.py").write_text("changed")
    state = git_state(tmp_path)
    assert state is not None and state["dirty"] and state["changed"] == ["src.py"]


def test_verdicts_are_read_from_what_compendium_checks_prints(capsys):
    check("t_f: the final time (s) (HLGL, 20 segments)", 481.2038, 481.2038723, atol=1e-3)
    check("error of x: largest", 2.3e-10, 1e-8, how="at most")
    check_true("every mesh converged (relative 1e-8)", True)
    printed = capsys.readouterr().out
    with pytest.raises(AssertionError) as failed:
        check("NLP parameters", 245, 246)
    cell = nbformat.v4.new_code_cell("checks", id="c1")
    cell.outputs = [
        nbformat.v4.new_output("stream", name="stdout", text=printed + "a line that is no verdict\n"),
        nbformat.v4.new_output("error", ename="AssertionError", evalue=str(failed.value), traceback=[]),
    ]
    nb = nbformat.v4.new_notebook(cells=[cell])
    found = [(v.name, v.value, v.criterion, v.passed, v.cell) for v in verdicts(nb)]
    assert found == [
        ("t_f: the final time (s) (HLGL, 20 segments)", "481.20", "within 0.001 of 481.2", True, "c1"),
        ("error of x: largest", "≈ 2.3e-10", "at most 1e-08", True, "c1"),
        ("every mesh converged (relative 1e-8)", "", "", True, "c1"),
        ("NLP parameters", "245.0", "equal to 246", False, "c1"),
    ]


def test_each_page_tables_its_verdicts_and_the_index_sums_them(report):
    page = _page(report, "00_validation")
    table = re.search(r'<table class="report-table report-verdicts">(.*?)</table>', page, re.S).group(1)
    stored = _read(paths.notebooks_dir() / "00_validation.ipynb")
    printed = [line for c in stored.cells for o in c.get("outputs", []) for line in o.get("text", "").splitlines()]
    assert table.count('<span class="report-pass">ok</span>') == sum(line.endswith(": ok") for line in printed) == 4
    assert "HLGL convergence order of theta" in table and "at least 4" in table and "≈ 4.7" in table
    assert "its checks assert quietly" in _page(report, "05_orbit_transfer")
    index = (report / "index.html").read_text()
    assert "7 of 7 printed checks ok</span> in 3 notebooks" in index
    assert index.count('<span class="report-pass">completed</span>') == 3


def test_figures_say_what_they_are(report):
    alts = re.findall(r'<img alt="([^"]*)"[^>]* src="data:image/png', _page(report, "00_validation"))
    assert alts == [f"figure flat_moon_{n} (saved as flat_moon_{n}.png with the run's figures)"
                    for n in ("convergence", "theta", "costates")]  # fmt: skip


def test_warnings_show_as_notes_not_as_errors(report):
    page = _page(report, "00_validation")
    notes = re.findall(r'<div class="jp-RenderedText jp-OutputArea-output report-note".*?</div>', page, re.S)
    assert notes and all("AccuracyWarning" in n for n in notes)
    assert 'data-mime-type="application/vnd.jupyter.stderr"' not in page


def _loaded_urls(page: str) -> list[str]:
    """Every URL the page loads by itself: scripts, stylesheets and icons, images, CSS imports, urls and fonts."""
    dom = _Elements(page)
    urls = [a.get("src", "") for t, a in dom.tags if t in ("script", "img", "iframe", "source", "embed", "audio")]
    urls += [a.get("href", "") for a in dom.of("link")]
    urls += [u for css in dom.css for u in re.findall(r"url\(\s*['\"]?([^'\")]+)", css)]
    urls += [u for css in dom.css for u in re.findall(r"@import\s+['\"]([^'\"]+)", css)]
    scripts = re.findall(r"<script[^>]*>(.*?)</script>", page, re.S)
    urls += [u for s in scripts for u in re.findall(r"(?:https?:)?//[\w.-]+\.[a-z]{2,}[^\s'\"]*", s)]
    return [u for u in urls if u]


@pytest.mark.parametrize("name", [*SOME, "index"])
def test_nothing_is_loaded_from_the_network(report, name):
    page = (report / f"{name}.html").read_text()
    urls = _loaded_urls(page)
    remote = [u for u in urls if re.match(r"(https?:)?//", u)]
    assert not remote
    assert "require.min.js" not in page and "mermaid" not in page
    if name != "index":
        scripts = [a["src"] for a in _Elements(page).of("script") if a.get("src")]
        assert scripts == ["mathjax/MathJax.js?config=local/ocpkit"] or scripts[0].endswith(",local/ocpkit")
        assert (report / "mathjax" / "MathJax.js").is_file()
        assert (report / "mathjax" / "config" / "local" / "ocpkit.js").is_file()


# -- a run's record, a failed run ----------------------------------------------------------------------------------


def _compendium(root: Path) -> None:
    """A throw-away compendium (``OCPKIT_ROOT``): one notebook ``demo`` with a parameter ``n`` (published: 3)."""
    (root / "data" / "derived" / "runs").mkdir(parents=True)
    (root / "notebooks").mkdir()
    (root / "notebooks" / "published.toml").write_text("[demo]\nn = '3'\n")
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "ocpkit", "display_name": "Python (ocpkit)", "language": "python"}
    nb.cells = [nbformat.v4.new_markdown_cell("# Demo: $x^2$\n\n## Part")]
    cell = nbformat.v4.new_code_cell("n = 2")
    cell.metadata["tags"] = ["parameters"]
    nb.cells.append(cell)
    nbformat.write(nb, str(root / "notebooks" / "demo.ipynb"))


def _executed_demo(root: Path, folder: Path, run: Path, *, fails: bool, n: int) -> Path:
    """``demo`` as papermill executed it with ``n`` into ``folder``: it says it writes to ``run``, prints a verdict
    and (``fails``) stops on a failed check."""
    nb = _read(root / "notebooks" / "demo.ipynb")
    nb.metadata["papermill"] = {"end_time": "2026-01-02T03:04:05.6", "duration": 12.3, "parameters": {"n": n}}
    first = nbformat.v4.new_code_cell("outputs = Outputs.start('demo', globals())", id="start")
    first.outputs = [nbformat.v4.new_output("stream", name="stdout", text=f"This run writes its figures and tables to "
                                            f"{run}/ when it completes (why).\n")]  # fmt: skip
    last = nbformat.v4.new_code_cell("check(...)", id="last")
    last.outputs = [nbformat.v4.new_output("stream", name="stdout", text="x: 1 (equal to 1): ok\n")]
    if fails:
        error = {"ename": "AssertionError", "evalue": "check failed: y: 2.0 (equal to 3)", "traceback": []}
        last.outputs.append(nbformat.v4.new_output("error", **error))
    nb.cells += [first, last]
    folder.mkdir(exist_ok=True)
    nbformat.write(nb, str(folder / "demo.ipynb"))
    return folder / "demo.ipynb"


def test_where_a_run_wrote_and_whether_it_was_published(tmp_path, monkeypatch):
    root = tmp_path / "root"
    _compendium(root)
    monkeypatch.setenv("OCPKIT_ROOT", str(root))
    run = tmp_path / "runs" / "demo" / "defaults"
    record = {"notebook": "demo", "published_parameters": True, "parameters": {"n": 3}, "files": []}
    checkout = {"commit": "abc123def4567890", "date": "2026-01-01T00:00:00", "dirty": True, "changed": ["src/x.py"]}
    record["git"] = checkout | {"record": []}  # what Outputs.publish records: the checkout the run was of
    (run / "data" / "derived" / "runs").mkdir(parents=True)
    (run / "data" / "derived" / "runs" / "demo.json").write_text(json.dumps(record))
    shutil.copy(run / "data" / "derived" / "runs" / "demo.json", root / "data" / "derived" / "runs" / "demo.json")
    executed = _executed_demo(root, tmp_path / "executed", run, fails=False, n=3)
    build_report(executed.parent, tmp_path / "report")
    page, index = (tmp_path / "report" / "demo.html").read_text(), (tmp_path / "report" / "index.html").read_text()
    assert "2026-01-02 03:04 UTC by papermill, in 12 s" in page
    assert "<code>n = 3</code></span> <small>(from the run's record)</small>" in page
    assert "yes: the published parameters" in page
    for text in (page, index):
        assert f"<code>{run}/</code>, and copied into the published record" in text
    assert "not a git checkout" in index  # OCPKIT_ROOT, no repository of its own
    assert "<code>abc123def456</code> of 2026-01-01" in page and "<code>src/x.py</code>" in page
    assert "(when the run ended, from its record)" in page

    (root / "data" / "derived" / "runs" / "demo.json").write_text("{}")  # another run published since
    executed = _executed_demo(root, tmp_path / "executed", run, fails=True, n=3)
    build_report(executed.parent, tmp_path / "report")
    page, index = (tmp_path / "report" / "demo.html").read_text(), (tmp_path / "report" / "index.html").read_text()
    assert f"<code>{run}/</code> only (not copied into the published record" in page
    assert '<span class="report-fail">stopped</span> in <a href="demo.html#cell-id=last">a cell</a>' in page
    assert "by AssertionError: check failed: y: 2.0 (equal to 3)" in index
    verdict_rows = re.findall(r"<tr><td><a href=\"#cell-id=last\">(\w)</a></td>.*?</tr>", page)
    assert verdict_rows == ["x", "y"] and '<span class="report-fail">failed</span>' in page
    assert "1 of 2 printed checks ok</span> in 1 notebook; 1 failed; 1 notebook stopped before the end" in index

    shutil.rmtree(run)
    executed = _executed_demo(root, tmp_path / "executed", run, fails=False, n=2)
    build_report(executed.parent, tmp_path / "report")
    page = (tmp_path / "report" / "demo.html").read_text()
    assert "(no record of this run there now)" in page
    assert '<code class="changed">n = 2</code>' in page and "(from papermill's parameters and the notebook" in page
    assert "no: <code>n</code> differs from the published run" in page


def test_a_page_shows_the_record_of_its_own_run_whatever_ran_since(tmp_path, monkeypatch):
    """The runner keeps a run's record in the executed notebook (compendium.notebooks.keep_run_record): after a
    published run, a later run with the same parameters (Lab's Run All, plain papermill) rewrites the run folder's
    record, and the page built from the executed notebook is the same, still copied into the published record; an
    executed notebook whose run wrote no record says so rather than showing an earlier run's."""
    root = tmp_path / "root"
    _compendium(root)
    monkeypatch.setenv("OCPKIT_ROOT", str(root))
    run = tmp_path / "runs" / "demo" / "defaults"
    runs = run / "data" / "derived" / "runs"
    runs.mkdir(parents=True)
    record = {"notebook": "demo", "published_parameters": True, "parameters": {"n": 3}, "files": [], "code": ["a"]}
    record |= {"timings": {"solve": [{"solve_s": 1.5}]}, "git": None}
    (runs / "demo.json").write_text(json.dumps(record, indent=2) + "\n")
    shutil.copy(runs / "demo.json", root / "data" / "derived" / "runs" / "demo.json")  # published (publish_run)
    executed = _executed_demo(root, tmp_path / "executed", run, fails=False, n=3)
    assert keep_run_record(executed, since=0.0) == record
    build_report(executed.parent, tmp_path / "report")
    page = (tmp_path / "report" / "demo.html").read_text()
    assert f"<code>{run}/</code>, and copied into the published record" in page

    later = record | {"timings": {"solve": [{"solve_s": 1.7}]}, "code": ["b"]}  # a later run, same parameters
    (runs / "demo.json").write_text(json.dumps(later, indent=2) + "\n")
    build_report(executed.parent, tmp_path / "report")
    assert (tmp_path / "report" / "demo.html").read_text() == page
    assert "and copied into the published record" in (tmp_path / "report" / "index.html").read_text()

    shutil.copy(executed, tmp_path / "plain.ipynb")  # the same notebook without the kept record reads the folder's
    (tmp_path / "plain").mkdir()
    shutil.move(tmp_path / "plain.ipynb", tmp_path / "plain" / "demo.ipynb")
    plain = _read(tmp_path / "plain" / "demo.ipynb")
    del plain.metadata[RUN_RECORD_KEY]
    nbformat.write(plain, str(tmp_path / "plain" / "demo.ipynb"))
    build_report(tmp_path / "plain", tmp_path / "report-plain")
    assert f"<code>{run}/</code> only (not copied" in (tmp_path / "report-plain" / "demo.html").read_text()

    stopped = _executed_demo(root, tmp_path / "stopped", run, fails=True, n=3)
    assert keep_run_record(stopped, since=time.time() + 60) is None  # no record written by this run
    build_report(stopped.parent, tmp_path / "report-stopped")
    page = (tmp_path / "report-stopped" / "demo.html").read_text()
    assert f"<code>{run}/</code> (the run wrote no record there: it did not complete)" in page
    other = record | {"notebook": "other"}  # another notebook's run, just now, in a shared folder
    (runs / "other.json").write_text(json.dumps(other, indent=2) + "\n")
    future = time.time() + 60
    os.utime(runs / "other.json", (future, future))
    assert keep_run_record(stopped, since=future - 1) is None  # not demo's
    assert keep_run_record(stopped, since=future - 1, notebook="other") == other


def test_runs_not_published_or_not_run_are_on_the_report_and_earlier_pages_go(tmp_path, monkeypatch):
    """make reproduce's report: a complete run it could not publish says why on its page and the index, apart from a
    stop; a notebook that left no executed notebook has an index row; what reproduce recorded beside the executed
    notebooks is read by a later build; a page of an earlier build that this one does not write is removed, and no
    other file of the folder."""
    root = tmp_path / "root"
    _compendium(root)
    monkeypatch.setenv("OCPKIT_ROOT", str(root))
    out = tmp_path / "report"
    out.mkdir()
    (out / "notes.html").write_text("mine")
    executed = _executed_demo(root, tmp_path / "executed", tmp_path / "run", fails=False, n=3)
    shutil.copy(executed, executed.parent / "old page.ipynb")
    build_report(executed.parent, out)
    assert (out / "old page.html").exists()
    (executed.parent / "old page.ipynb").unlink()
    why = {"demo.ipynb": Unfinished("not published", "demo is not committed")}
    why["gone.ipynb"] = Unfinished("did not run", "NoSuchKernel: no kernel")
    (executed.parent / UNFINISHED).write_text(json.dumps({k: list(v) for k, v in why.items()}))
    build_report(executed.parent, out)  # reads what reproduce recorded
    page, index = (out / "demo.html").read_text(), (out / "index.html").read_text()
    for text in (page, index):
        assert 'completed, <span class="report-fail">not published</span>: demo is not committed' in text
    assert '<code>gone.ipynb</code></td><td><span class="report-fail">did not run</span>: NoSuchKernel' in index
    assert (
        'class="report-fail">1 of 1 printed checks ok</span> in 1 notebook; 1 complete run not published; 1 ' in index
    )
    assert sorted(p.name for p in out.glob("*.html")) == ["demo.html", "index.html", "notes.html"]

    stopped = {"demo.ipynb": Unfinished("stopped", "DeadKernelError: the kernel died")}
    page = (build_report(executed.parent, out, stopped).parent / "demo.html").read_text()
    assert '<span class="report-fail">stopped</span>: DeadKernelError: the kernel died' in page
    assert "1 notebook stopped before the end" in (out / "index.html").read_text()

    empty = tmp_path / "none"
    empty.mkdir()
    index = build_report(empty, tmp_path / "report2", {"demo.ipynb": why["gone.ipynb"]}).read_text()
    assert "1 notebook did not run" in index and "0 executed" in index and '<span class="report-pass">' not in index
    with pytest.raises(FileNotFoundError, match="no executed notebooks"):
        build_report(empty, tmp_path / "report3")


# -- MathJax -------------------------------------------------------------------------------------------------------


def test_tex_fonts_are_installed():
    """`make mathjax` installs Debian's MathJax with its TeX fonts; `make unit` (OCPKIT_REQUIRE_BROWSER) needs them."""
    if mathjax.tex_fonts_root() is None:
        if REQUIRE_BROWSER:
            pytest.fail("no MathJax 2 with TeX fonts (make mathjax installs Debian's libjs-mathjax and fonts-mathjax)")
        pytest.skip("no MathJax 2 with TeX fonts (make mathjax)")
    assert mathjax.find_mathjax().tex_fonts


@pytest.mark.skipif(not mathjax.find_mathjax().tex_fonts, reason="no MathJax 2 with TeX fonts (make mathjax)")
def test_copy_mathjax_copies_what_pages_need_with_the_tex_fonts(tmp_path):
    url = mathjax.copy_mathjax(tmp_path / "mj")
    assert url == "mj/MathJax.js?config=local/ocpkit"
    copied = {str(p.relative_to(tmp_path / "mj")) for p in (tmp_path / "mj").rglob("*") if p.is_file()}
    for needed in (
        "MathJax.js",
        "config/local/ocpkit.js",
        "jax/input/TeX/jax.js",
        "jax/output/CommonHTML/jax.js",
        "jax/output/CommonHTML/fonts/TeX/fontdata.js",
        "jax/output/HTML-CSS/jax.js",
        "jax/output/HTML-CSS/fonts/TeX/fontdata.js",
        "jax/element/mml/jax.js",
        "extensions/tex2jax.js",
        "extensions/TeX/AMSmath.js",
        "fonts/HTML-CSS/TeX/woff/MathJax_Main-Regular.woff",
    ):
        assert needed in copied
    assert not [f for f in copied if "STIX" in f or "/SVG/" in f or f.startswith("unpacked/")]
    assert sum((tmp_path / "mj" / f).stat().st_size for f in copied) < 4_000_000
    config = (tmp_path / "mj" / "config" / "local" / "ocpkit.js").read_text()
    assert json.loads(config.split("MathJax.Hub.Config(", 1)[1].split(");\n", 1)[0]) == mathjax.CONFIG
    assert mathjax.CONFIG["HTML-CSS"] == {"availableFonts": ["TeX"], "preferredFont": "TeX", "webFont": "TeX",
                                          "imageFont": None}  # fmt: skip
    assert config.endswith('MathJax.Ajax.loadComplete("[MathJax]/config/local/ocpkit.js");\n')
    assert mathjax.copy_mathjax(tmp_path / "mj") == url  # an earlier copy is replaced


def test_without_tex_fonts_mathjax_falls_back_to_stix_and_says_so(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(mathjax, "TEX_FONT_ROOTS", (tmp_path / "none",))
    found = mathjax.find_mathjax()
    assert not found.tex_fonts and found.font == "STIX-Web"
    assert "no MathJax 2 with its TeX web fonts" in capsys.readouterr().err
    url = mathjax.copy_mathjax(tmp_path / "mj", found)
    assert url == "mj/MathJax.js?config=TeX-AMS-MML_HTMLorMML-full,local/ocpkit"
    assert (tmp_path / "mj" / "fonts" / "HTML-CSS" / "STIX-Web" / "woff").is_dir()
    assert '"webFont": "STIX-Web"' in (tmp_path / "mj" / "config" / "local" / "ocpkit.js").read_text()


def test_make_mathjax_asks_where_the_report_looks(tmp_path, monkeypatch, capsys):
    """`make mathjax` installs nothing when `python -m compendium.mathjax` finds the TeX fonts in any of the roots
    the report looks in (not only Debian's), and installs them when it finds none."""
    fedora = tmp_path / "mathjax2"
    (fedora / "fonts/HTML-CSS/TeX/woff").mkdir(parents=True)
    (fedora / "MathJax.js").write_text("")
    monkeypatch.setattr(mathjax, "TEX_FONT_ROOTS", (tmp_path / "javascript" / "mathjax", tmp_path / "mathjax2"))
    assert mathjax.tex_fonts_root() is None and mathjax.main() == mathjax.NO_TEX_FONTS == 3
    (fedora / "fonts/HTML-CSS/TeX/woff/MathJax_Main-Regular.woff").write_bytes(b"")
    capsys.readouterr()
    assert mathjax.tex_fonts_root() == fedora and mathjax.main() == 0
    assert capsys.readouterr().out == f"{fedora}\n" and mathjax.find_mathjax().root == fedora
    recipe = (paths.repo_root() / "Makefile").read_text().split("\nmathjax:", 1)[1].split("\n\n", 1)[0]
    assert "$(PY) -m compendium.mathjax" in recipe and "/usr/share" not in recipe
    assert "[ $$found != 3 ]" in recipe, "only 'no fonts' installs them; any other failure is shown and stops"


def test_copy_mathjax_replaces_nothing_but_a_copy(tmp_path):
    (tmp_path / "static").mkdir()
    (tmp_path / "static" / "site.css").write_text("")
    with pytest.raises(FileExistsError):
        mathjax.copy_mathjax(tmp_path / "static")
    assert (tmp_path / "static" / "site.css").is_file()


# -- every stored notebook -----------------------------------------------------------------------------------------


def test_the_report_of_every_stored_notebook(tmp_path):
    """What `make reproduce` writes, from the stored notebooks (nbval keeps no executed notebooks to build it from)."""
    index = build_report(paths.notebooks_dir(), tmp_path).read_text()
    for path in NOTEBOOKS:
        nb = _read(path)
        page = (tmp_path / f"{path.stem}.html").read_text()
        assert f'href="{path.stem}.html"' in index and f"<title>{title(nb)}</title>" in page.replace("&amp;", "&")
        assert len(re.findall(r'<img [^>]*src="data:image/png;base64,', page)) == sum(
            "image/png" in o.get("data", {}) for c in nb.cells if c.cell_type == "code" for o in c.outputs
        )
        assert "NBVAL" not in page and "outputs.publish()" not in page
        assert len(verdicts(nb)) == sum(
            line.endswith(": ok")
            for c in nb.cells
            for o in c.get("outputs", [])
            for line in o.get("text", "").split("\n")
        )
    assert "stopped" not in index and "failed" not in index


# -- in a browser ----------------------------------------------------------------------------------------------------

#: fontconfig without the system's MathJax fonts (Debian's fonts-mathjax installs them for every program): the page
#: must then take the TeX fonts from its own copy, as on a reader's machine
#: done once MathJax has typeset the page and the fonts it asked for are in: what the page shows
_TYPESET = """(async () => {
  const hub = window.MathJax && MathJax.Hub;
  if (document.readyState !== 'complete' || !hub || !hub.queue || hub.queue.pending || hub.queue.running) {
    return {done: false, state: 'MathJax not done'};
  }
  const math = document.querySelectorAll('.MathJax_CHTML, .MathJax').length;
  if (!math) return {done: false, state: 'no typeset math yet'};
  await document.fonts.ready;
  const faces = {};
  document.fonts.forEach(f => { faces[f.family.replace(/"/g, '')] = f.status; });
  const probe = document.createElement('div');
  probe.style.background = 'var(--jp-rendermime-error-background)';
  document.body.appendChild(probe);
  const note = document.querySelector('.report-note');
  return {done: true, title: document.title, math, faces,
          errors: document.querySelectorAll('.MathJax_Error, .mjx-merror, .merror, .noError, .mjx-noError').length,
          contents: Array.from(document.querySelectorAll('.report-toc a'))
                         .map(a => !!document.getElementById(a.hash.slice(1))),
          images: Array.from(document.images).map(i => i.complete && i.naturalWidth),
          note: note && getComputedStyle(note).backgroundColor, pink: getComputedStyle(probe).backgroundColor,
          next: (document.querySelector('a[rel=next]') || {}).href || null};
})()"""


@needs_chromium
@pytest.mark.parametrize("fonts", ["TeX", "STIX-Web"])
def test_a_report_page_in_chromium(fonts, tmp_path, monkeypatch):
    """Title, contents, equations typeset in the copied web fonts, figures, notes, and no request but to the report's
    own server. ``STIX-Web``: jupyter-server-mathjax's fonts, where no MathJax with TeX fonts is installed."""
    if fonts == "TeX" and not mathjax.find_mathjax().tex_fonts:
        pytest.skip("no MathJax 2 with TeX fonts (make mathjax); test_tex_fonts_are_installed says so")
    if fonts == "STIX-Web":
        monkeypatch.setattr(mathjax, "TEX_FONT_ROOTS", ())
    executed = tmp_path / "executed"
    executed.mkdir()
    for name in ("00_validation", "04_shooting_validation"):
        shutil.copy(paths.notebooks_dir() / f"{name}.ipynb", executed)
    build_report(executed, tmp_path / "report")
    (tmp_path / "fonts").mkdir()
    (tmp_path / "fonts" / "fonts.conf").write_text(FONTCONFIG.format(cache=tmp_path / "fonts" / "cache"))
    monkeypatch.setenv("FONTCONFIG_FILE", str(tmp_path / "fonts" / "fonts.conf"))
    with served(tmp_path / "report") as base:
        recorder = Recorder(tmp_path / "profile", tmp_path / "chromium.log")
        browser = recorder.browser
        try:
            browser.call("Network.enable")
            browser.call("Page.navigate", url=base + "00_validation.html")
            shown = browser.poll(_TYPESET, 30, "the page typeset by MathJax")
            browser.call("Page.navigate", url=shown["next"])
            second = browser.poll(_TYPESET, 30, "the next page typeset by MathJax")
        finally:
            browser.close()
    first = title(_read(executed / "00_validation.ipynb"))
    assert shown["title"] == first and second["title"] == title(_read(executed / "04_shooting_validation.ipynb"))
    assert shown["next"] == base + "04_shooting_validation.html"
    assert len(shown["contents"]) >= 5 and all(shown["contents"])
    assert shown["math"] >= 10 and shown["errors"] == 0
    assert shown["images"] and all(shown["images"]), shown["images"]
    assert shown["note"] and shown["note"] != shown["pink"]
    woff = f"{base}mathjax/fonts/HTML-CSS/{fonts}/woff/"
    face = "MJXc-TeX-main-Rw" if fonts == "TeX" else "STIXMathJax_Main"
    assert shown["faces"].get(face) == "loaded", shown["faces"]
    requests = recorder.requests()
    assert any(url.startswith(woff + ("MathJax_Main" if fonts == "TeX" else "STIXMathJax_Main")) for url in requests)
    assert [url for url in requests if not url.startswith((base, "data:", "about:blank"))] == []
    failures = recorder.failures()
    assert not failures, failures
