"""The HTML report of executed notebooks (``make reproduce``: ``build/report/index.html``), read offline.

One page per notebook (nbconvert's lab template, extended by :data:`TEMPLATE`): its first heading as title, its
headings as a contents list, links to the index and to the previous and next notebooks, a box saying what ran, where
and on what (:class:`RunFacts`; :func:`compendium.provenance.environment`, :func:`compendium.provenance.git_state`)
and the verdicts its checks printed (:func:`verdicts`). Cells are hidden by the tags myst-nb reads too
(:data:`REMOVE_CELL`, :data:`HIDE_CELL` ...): the notebooks' plumbing (opening and publishing
:class:`compendium.outputs.Outputs`) carries them. ``# NBVAL_*`` marker lines leave the code shown, and what a run
printed on standard error (warnings) shows as a note. The index lists every notebook with its outcome, checks and the
folder its figures and tables went to.

Equations are typeset by a copy of MathJax next to the pages, in its TeX fonts (:mod:`compendium.mathjax`); figures
are inline. No page loads anything from the network: nbconvert's require.js (for JavaScript and widget outputs,
which the report does not carry: :func:`compendium.notebook_source.static_views`) and mermaid loader are left out.

It reads the executed notebooks through :mod:`compendium.notebook_source` and their runs' records and provenance
through :mod:`compendium.provenance`; :mod:`compendium.notebooks`, which builds it, sits above it.
"""

from __future__ import annotations

import html
import json
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from html.parser import HTMLParser
from pathlib import Path
from typing import NamedTuple

from . import paths
from .mathjax import copy_mathjax
from .notebook_source import literal_parameters, published_parameters, static_views, written_to
from .provenance import RUN_RECORD_KEY, RUNS, environment, git_state

#: tags, as myst-nb reads them: the cell, its code or its outputs left out of the page, or folded away
REMOVE_CELL, REMOVE_INPUT, REMOVE_OUTPUT = "remove-cell", "remove-input", "remove-output"
HIDE_CELL, HIDE_INPUT, HIDE_OUTPUT = "hide-cell", "hide-input", "hide-output"

_CONTENTS = "<!--report:contents-->"

#: nbconvert's lab page, as a report: no require.js nor mermaid loader (both from a CDN), folded cells, notes for
#: standard error, and the report's navigation, contents list and run box (``resources.report``)
TEMPLATE = """{%- extends 'lab/index.html.j2' -%}
{%- block html_head_js_requirejs -%}{%- endblock html_head_js_requirejs -%}
{%- block html_head_js_mermaidjs -%}{%- endblock html_head_js_mermaidjs -%}
{% block extra_css %}<link rel="icon" href="data:,"><style>{{ resources.report.css }}</style>{% endblock extra_css %}
{%- block body_header -%}
<body class="jp-Notebook report-page" data-jp-theme-light="true" data-jp-theme-name="JupyterLab Light">
{{ resources.report.bar }}
<div class="report-layout">
<nav class="report-toc" aria-label="Contents">{{ resources.report.contents }}</nav>
<main>
{%- if resources.report.box_first %}{{ resources.report.box }}{% endif -%}
{%- endblock body_header -%}
{% block body_footer %}
</main>
</div>
{{ resources.report.bar }}
</body>
{% endblock body_footer %}
{% block markdowncell %}
{{ super() }}
{%- if cell.metadata.get("report_box") %}{{ resources.report.box }}{% endif -%}
{% endblock markdowncell %}
{% block codecell %}
{%- if "hide-cell" in cell.metadata.get("tags", []) -%}
<details class="report-folded"><summary>Hidden code cell
<code>{{ cell.source.splitlines()[0] | default("") | escape_html }} …</code></summary>
{{ super() }}
</details>
{%- else -%}
{{ super() }}
{%- endif -%}
{% endblock codecell %}
{% block input_group %}
{%- if "hide-input" in cell.metadata.get("tags", []) -%}
<details class="report-folded"><summary>Show the code</summary>{{ super() }}</details>
{%- else -%}
{{ super() }}
{%- endif -%}
{% endblock input_group %}
{% block output_group %}
{%- if "hide-output" in cell.metadata.get("tags", []) -%}
<details class="report-folded"><summary>Show the output</summary>{{ super() }}</details>
{%- else -%}
{{ super() }}
{%- endif -%}
{% endblock output_group %}
{% block data_png %}
{%- set image %}{{ super() }}{% endset -%}
{{ image | replace("<img ", '<img alt="' ~ (output.metadata.get("report_alt", "") | escape_html) ~ '" ', 1) }}
{%- endblock data_png %}
{% block stream_stderr -%}
<div class="jp-RenderedText jp-OutputArea-output report-note" data-mime-type="text/plain" role="note">
<p class="report-note-title">Note (printed on standard error)</p>
<pre>
{{- output.text | ansi2html -}}
</pre>
</div>
{%- endblock stream_stderr %}
"""

CSS = """
body.report-page { padding: 0; margin: 0; overflow: visible; }
.report-page main { min-width: 0; }
.report-page .jp-OutputArea-output { overflow-x: auto; }
.report-bar { position: sticky; top: 0; z-index: 10; display: flex; gap: 1.5em; align-items: baseline;
  padding: .45em 1.5em; background: #f6f8fa; border-bottom: 1px solid #d0d7de;
  font: 14px/1.4 var(--jp-ui-font-family, sans-serif); }
.report-bar .report-next { margin-left: auto; }
.report-bar a { color: #0550ae; text-decoration: none; white-space: nowrap; overflow: hidden;
  text-overflow: ellipsis; min-width: 0; }
.report-bar a:hover { text-decoration: underline; } .report-bar .report-home { flex: none; }
.report-bar .report-prev, .report-bar .report-next { max-width: 42%; }
.report-layout { display: grid; grid-template-columns: 15rem minmax(0, 1fr); gap: 2rem; max-width: 82rem;
  margin: 0 auto; padding: 1rem 1.5rem 2rem; }
.report-toc { position: sticky; top: 3rem; align-self: start; max-height: calc(100vh - 4rem); overflow-y: auto;
  font: 13px/1.4 var(--jp-ui-font-family, sans-serif); }
.report-toc p { font-weight: 600; margin: 0 0 .4em; }
.report-toc ol { list-style: none; margin: 0; padding: 0; }
.report-toc li { margin: .2em 0; } .report-toc li.level-2 { padding-left: .9em; }
.report-toc li.level-3 { padding-left: 1.8em; font-size: 12px; }
.report-toc a { color: #24292f; text-decoration: none; } .report-toc a:hover { color: #0550ae; }
@media (max-width: 60rem) { .report-layout { grid-template-columns: minmax(0, 1fr); }
  .report-toc { position: static; max-height: none; } }
.report-box { border: 1px solid #d0d7de; border-radius: 6px; padding: .2em 1.2em .8em; margin: 1em 0 1.5em;
  background: #f9fafb; font: 13px/1.5 var(--jp-ui-font-family, sans-serif); }
.report-box h2 { font-size: 15px; margin: .8em 0 .4em; }
.report-box dl { display: grid; grid-template-columns: max-content minmax(0, 1fr); gap: .2em 1.2em; margin: 0; }
.report-box dt { font-weight: 600; color: #57606a; } .report-box dd { margin: 0; }
.report-box code { font-size: 12px; }
.report-params code { display: inline-block; margin: 0 .8em .1em 0; }
.report-params .changed { background: #fff8c5; }
table.report-table { border-collapse: collapse; margin: .3em 0; font-size: 13px; }
table.report-table th, table.report-table td { border-bottom: 1px solid #d8dee4; padding: .25em .7em;
  text-align: left; vertical-align: top; }
table.report-table th { background: #eef1f4; }
.report-pass { color: #1a7f37; font-weight: 600; } .report-fail { color: #cf222e; font-weight: 600; }
.report-note { background: #eef4fb; border-left: 4px solid #54aeff; padding: .2em .8em; margin: .3em 0; }
.report-note-title { margin: .2em 0; font: 600 12px var(--jp-ui-font-family, sans-serif); color: #0a3069; }
.report-note pre { white-space: pre-wrap; color: #24292f; }
details.report-folded { margin: .4em 0; }
details.report-folded > summary { cursor: pointer; color: #57606a; font: 13px var(--jp-ui-font-family, sans-serif); }
details.report-folded > summary code { color: #6e7781; }
"""

_INDEX = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1.0">
<link rel="icon" href="data:,">
<title>{title}</title>
<style>
body {{ font: 15px/1.5 system-ui, sans-serif; color: #24292f; margin: 0; }}
main {{ max-width: 72rem; margin: 0 auto; padding: 1rem 1.5rem 3rem; }}
h1 {{ font-size: 1.6em; }}
{css}
</style></head><body>
<main>
<h1>{title}</h1>
<p>{intro}</p>
{box}
<h2 id="notebooks">Notebooks</h2>
<table class="report-table report-index">
<tr><th></th><th>notebook</th><th>outcome</th><th>checks</th><th>parameters</th><th>figures and tables</th></tr>
{rows}
</table>
</main></body></html>
"""


# -- what ran, where and on what ---------------------------------------------------------------------------------


@dataclass
class RunFacts:
    """What one executed notebook says of its run, and what its run folder holds.

    ``executed``: when papermill finished it (``None`` for stored outputs); ``failure``: the cell id, error name and
    message of the first error; ``parameters`` and ``parameters_from``: the run's parameters and where they were read;
    ``published``: whether they are the notebook's published parameters (``None`` for a notebook the compendium does
    not hold), ``changed`` the names that differ; ``folder``: where the run wrote its figures and tables (the
    notebook's first output line); ``record``: the run's record, the one the runner kept in the executed notebook
    (``record_kept``; :func:`compendium.notebooks.execute`), else the one in ``folder`` now (a notebook papermill or
    Lab ran); ``in_published_record``: whether that record is the one of the published record (the run was copied
    into ``figures/`` and ``data/derived/``).
    """

    executed: str | None = None
    duration: float | None = None
    python: str | None = None
    failure: tuple[str, str, str] | None = None
    parameters: dict = field(default_factory=dict)
    parameters_from: str = "the notebook's defaults"
    published: bool | None = None
    changed: list[str] = field(default_factory=list)
    folder: Path | None = None
    record: dict | None = None
    record_kept: bool = False
    in_published_record: bool = False


def run_facts(path: Path, nb) -> RunFacts:
    """The :class:`RunFacts` of the executed notebook ``nb``, read from ``path``."""
    facts = RunFacts()
    papermill = nb.metadata.get("papermill", {})
    if papermill.get("end_time"):
        facts.executed = _utc(papermill["end_time"])
        facts.duration = papermill.get("duration")
    facts.python = nb.metadata.get("language_info", {}).get("version")
    facts.failure = _failure(nb)
    facts.folder = written_to(path)
    stem = path.stem
    if RUN_RECORD_KEY in nb.metadata:  # kept by the runner: this run's, whatever ran in its folder since
        facts.record = nb.metadata[RUN_RECORD_KEY]
        facts.record_kept = True
    elif facts.folder is not None and (facts.folder / RUNS / f"{stem}.json").is_file():
        facts.record = json.loads((facts.folder / RUNS / f"{stem}.json").read_text())
    if facts.record is not None and facts.folder is not None:
        published = paths.repo_root() / RUNS / f"{facts.record.get('notebook', stem)}.json"
        facts.in_published_record = (
            facts.folder.resolve() != paths.repo_root().resolve()
            and published.is_file()
            and json.loads(published.read_text()) == facts.record
        )
    if facts.record is not None:
        facts.parameters, facts.parameters_from = facts.record["parameters"], "the run's record"
    else:
        try:
            defaults = literal_parameters(path)
        except ValueError:
            defaults = {}
        given = papermill.get("parameters", {})
        facts.parameters = defaults | given
        facts.parameters_from = "papermill's parameters and the notebook's defaults" if given else facts.parameters_from
    try:
        published = json.loads(json.dumps(published_parameters(stem)))
    except (FileNotFoundError, ValueError):
        return facts
    ran = json.loads(json.dumps(facts.parameters))
    facts.changed = sorted(k for k in published if ran.get(k) != published[k])
    facts.published = not facts.changed
    return facts


def _utc(stamp: str) -> str:
    when = datetime.fromisoformat(stamp.replace("Z", "+00:00"))
    when = when.astimezone(UTC) if when.tzinfo else when.replace(tzinfo=UTC)
    return when.strftime("%Y-%m-%d %H:%M UTC")


def _failure(nb) -> tuple[str, str, str] | None:
    for cell in nb.cells:
        for out in cell.get("outputs", []) if cell.cell_type == "code" else []:
            if out.get("output_type") == "error":
                return cell.get("id", ""), out.get("ename", ""), out.get("evalue", "")
    return None


# -- checks --------------------------------------------------------------------------------------------------------

_CRITERION = r"(?:within|equal to|at most|at least) [^()]*"
_CHECK = re.compile(rf"^(?P<name>.+): (?P<value>[^:()]+) \((?P<criterion>{_CRITERION})\): ok$")
_CONDITION = re.compile(r"^(?P<name>.+): ok$")
_FAILED = re.compile(rf"^check failed: (?P<name>.+?)(?:: (?P<value>[^:()]+) \((?P<criterion>{_CRITERION})\))?$")


@dataclass(frozen=True)
class Verdict:
    """One check a notebook printed (:func:`compendium.checks.check`, :func:`compendium.checks.check_true`): what was
    checked, the value and the criterion (empty for a condition), whether it passed, and the id of its cell."""

    name: str
    value: str
    criterion: str
    passed: bool
    cell: str


def verdicts(nb) -> list[Verdict]:
    """The verdicts the notebook's outputs hold, in order: every printed line ending in ``: ok``, and the check
    whose failure stopped the run (an ``AssertionError`` ``check failed: ...``)."""
    found = []
    for cell in nb.cells:
        for out in cell.get("outputs", []) if cell.cell_type == "code" else []:
            if out.get("output_type") == "stream" and out.get("name") == "stdout":
                for line in out.get("text", "").splitlines():
                    m = _CHECK.match(line.rstrip()) or _CONDITION.match(line.rstrip())
                    if m:
                        parts = m.groupdict()
                        found.append(
                            Verdict(
                                parts["name"],
                                parts.get("value", ""),
                                parts.get("criterion", ""),
                                True,
                                cell.get("id", ""),
                            )
                        )
            elif out.get("output_type") == "error" and out.get("ename") == "AssertionError":
                m = _FAILED.match(out.get("evalue", ""))
                if m:
                    value, criterion = m.group("value") or "", m.group("criterion") or ""
                    found.append(Verdict(m.group("name"), value, criterion, False, cell.get("id", "")))
    return found


# -- pages -------------------------------------------------------------------------------------------------------


class Unfinished(NamedTuple):
    """Why a notebook's run of :func:`compendium.notebooks.reproduce` is not in the published record."""

    #: ``"stopped"`` (it ran and stopped before its end: a cell raised, the kernel died or timed out),
    #: ``"not published"`` (it ran to its end and :func:`compendium.notebooks.publish_run` refused it) or
    #: ``"did not run"`` (no executed notebook: the kernel did not start)
    kind: str
    #: the error, in a line
    why: str

    def sentence(self) -> str:
        """What happened, as a clause after the notebook's name."""
        said = {
            "stopped": "did not complete, nothing of it was published",
            "not published": "ran to the end, but its run was not published",
            "did not run": "did not run",
        }
        return f"{said[self.kind]}: {self.why}"


#: the file, beside the executed notebooks, where :func:`compendium.notebooks.reproduce` records its unfinished runs
UNFINISHED = "unfinished-runs.json"


@dataclass
class Page:
    """One notebook of the report: its file, the notebook as shown (:func:`prepare`), title, run and verdicts."""

    path: Path
    nb: object
    title: str
    facts: RunFacts
    verdicts: list[Verdict]
    #: why the run is not in the published record (:func:`compendium.notebooks.reproduce`), or ``None``
    unfinished: Unfinished | None = None

    @property
    def href(self) -> str:
        """The page's file name in the report (and its link from the other pages)."""
        return f"{self.path.stem}.html"


def title(nb) -> str:
    """The notebook's first Markdown heading, as plain text (``untitled`` without one)."""
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            for line in cell.source.splitlines():
                if line.startswith("#"):
                    return re.sub(r"[*`]", "", line.lstrip("#")).strip()
    return "untitled"


def strip_markers(source: str) -> str:
    """Code without its ``# NBVAL_...`` marker lines (nbval's instructions, not the reader's)."""
    return "\n".join(line for line in source.split("\n") if not line.lstrip().startswith("# NBVAL_"))


def prepare(nb):
    """The notebook as its page shows it (changed in place, and returned): no widget state nor live widget views
    (:func:`compendium.notebook_source.static_views`), no ``# NBVAL_*`` lines, its title in its metadata, and the
    first Markdown cell with a heading marked to be followed by the run box."""
    nb.metadata.pop("widgets", None)
    nb.metadata["title"] = title(nb)
    for cell in nb.cells:
        if cell.cell_type == "code":
            cell.outputs = static_views(cell.outputs)
            cell.source = strip_markers(cell.source)
            _describe_figures(cell)
    shown = [c for c in nb.cells if REMOVE_CELL not in c.metadata.get("tags", [])]
    headed = [c for c in shown if c.cell_type == "markdown" and re.search(r"^#", c.source, re.M)]
    if headed:
        headed[0].metadata["report_box"] = True
    return nb


_FIGURE = re.compile(r"""outputs\.figure\(\s*\w+,\s*["']([\w.-]+)["']""")


def _describe_figures(cell) -> None:
    """Alternative text for the figures of a code cell: the names it saves them under, when it names each."""
    images = [o for o in cell.outputs if "image/png" in o.get("data", {})]
    names = _FIGURE.findall(cell.source)
    for k, out in enumerate(images):
        named = (
            f"figure {names[k]} (saved as {names[k]}.png with the run's figures)" if len(names) == len(images) else ""
        )
        out.setdefault("metadata", {})["report_alt"] = named or "a figure drawn by the code cell above"


def read_page(path: Path) -> Page:
    """The :class:`Page` of the executed notebook at ``path``."""
    import nbformat

    nb = nbformat.read(str(path), as_version=4)
    facts = run_facts(path, nb)
    return Page(path, prepare(nb), title(nb), facts, verdicts(nb))


def exporter(mathjax_url: str):
    """nbconvert's HTML exporter with :data:`TEMPLATE`, no prompts, MathJax from ``mathjax_url``, and the cells,
    code or outputs tagged :data:`REMOVE_CELL`, :data:`REMOVE_INPUT`, :data:`REMOVE_OUTPUT` left out."""
    from jinja2 import DictLoader
    from nbconvert import HTMLExporter
    from nbconvert.preprocessors import TagRemovePreprocessor

    out = HTMLExporter(
        template_file="ocpkit_report.html.j2",
        extra_loaders=[DictLoader({"ocpkit_report.html.j2": TEMPLATE})],
        mathjax_url=mathjax_url,
        exclude_input_prompt=True,
        exclude_output_prompt=True,
    )
    remove = TagRemovePreprocessor(
        remove_cell_tags={REMOVE_CELL},
        remove_input_tags={REMOVE_INPUT},
        remove_all_outputs_tags={REMOVE_OUTPUT},
        enabled=True,
    )
    out.register_preprocessor(remove, enabled=True)
    return out


def render_page(export, page: Page, previous: Page | None, following: Page | None, env: dict, git: dict | None) -> str:
    """The HTML of one page: the notebook through ``export`` (:func:`exporter`) with the report's navigation bar,
    run box and contents list."""
    box = _page_box(page, env, git)
    report = {
        "css": CSS,
        "bar": _bar(previous, following),
        "contents": _CONTENTS,
        "box": box,
        "box_first": not any(c.metadata.get("report_box") for c in page.nb.cells),
    }
    body, _ = export.from_notebook_node(page.nb, resources={"report": report})
    return body.replace(_CONTENTS, contents(body), 1)


def _bar(previous: Page | None, following: Page | None) -> str:
    links = ['<a class="report-home" href="index.html">↑ Index</a>']
    for page, rel, text in ((previous, "prev", "← {}"), (following, "next", "{} →")):
        if page is not None:
            name = html.escape(page.title)
            links.append(
                f'<a class="report-{rel}" rel="{rel}" href="{page.href}" title="{name}">{text.format(name)}</a>'
            )
    return f'<nav class="report-bar" aria-label="Report">{"".join(links)}</nav>'


class _Headings(HTMLParser):
    """The ``h1``-``h3`` of a page with an id: level, id and text (without the anchor links' ``¶``)."""

    def __init__(self, page: str):
        super().__init__(convert_charrefs=True)
        self.found: list[tuple[int, str, str]] = []
        self._open: tuple[int, str, list[str]] | None = None
        self.feed(page)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag in ("h1", "h2", "h3") and attrs.get("id"):
            self._open = (int(tag[1]), attrs["id"], [])

    def handle_endtag(self, tag):
        if self._open is not None and tag == f"h{self._open[0]}":
            level, ident, text = self._open
            self.found.append((level, ident, "".join(text).replace("¶", "").strip()))
            self._open = None

    def handle_data(self, data):
        if self._open is not None:
            self._open[2].append(data)


def contents(page: str) -> str:
    """The contents list of a rendered page: its headings (levels 1 to 3) linked to their anchors."""
    items = "\n".join(
        f'<li class="level-{level}"><a href="#{html.escape(ident)}">{html.escape(text)}</a></li>'
        for level, ident, text in _Headings(page).found
    )
    return f"<p>Contents</p><ol>\n{items}\n</ol>"


def _where(folder: Path | None) -> str:
    if folder is None:
        return "not said"
    try:
        return f"{folder.resolve().relative_to(paths.repo_root().resolve())}/"
    except ValueError:
        return f"{folder}/"


def figures_went(facts: RunFacts) -> str:
    """Where a run's figures and tables went, as HTML: its folder, and whether it was copied into the published
    record (``figures/``, ``data/derived/``)."""
    if facts.folder is None:
        return "not said (the notebook printed no <code>This run writes ...</code> line)"
    where = f"<code>{html.escape(_where(facts.folder))}</code>"
    if facts.record is None and facts.record_kept:
        return f"{where} (the run wrote no record there: it did not complete)"
    if facts.record is None:
        return f"{where} (no record of this run there now)"
    if facts.in_published_record:
        return f"{where}, and copied into the published record <code>figures/</code>, <code>data/derived/</code>"
    return f"{where} only (not copied into the published record <code>figures/</code>, <code>data/derived/</code>)"


def _parameters(facts: RunFacts) -> str:
    marks = {name: ' class="changed"' if name in facts.changed else "" for name in facts.parameters}
    items = " ".join(
        f"<code{marks[name]}>{html.escape(f'{name} = {value!r}')}</code>" for name, value in facts.parameters.items()
    )
    return f'<span class="report-params">{items or "none"}</span>'


def _published(facts: RunFacts) -> str:
    if facts.published is None:
        return "unknown (not a notebook of the compendium's <code>notebooks/</code>)"
    if facts.published:
        return "yes: the published parameters (<code>notebooks/published.toml</code>)"
    names = ", ".join(f"<code>{html.escape(n)}</code>" for n in facts.changed)
    verb = "differs" if len(facts.changed) == 1 else "differ"
    return f"no: {names} {verb} from the published run (highlighted above)"


def _outcome(page: Page) -> str:
    left = page.unfinished
    if page.facts.failure is None and left is not None:
        done = "completed, " if left.kind == "not published" else ""
        return f'{done}<span class="report-fail">{html.escape(left.kind)}</span>: {html.escape(left.why)}'
    if page.facts.failure is None:
        return '<span class="report-pass">completed</span>'
    cell, ename, evalue = page.facts.failure
    return (
        f'<span class="report-fail">stopped</span> in <a href="{page.href}#cell-id={html.escape(cell)}">a cell</a> '
        f"by {html.escape(ename)}: {html.escape(evalue)}"
    )


def _executed(facts: RunFacts) -> str:
    if facts.executed is None:
        return "no date recorded (the notebook's stored outputs)"
    took = f", in {facts.duration:.0f} s" if facts.duration is not None else ""
    return f"{facts.executed} by papermill{took}"


def _commit(git: dict | None) -> str:
    if git is None:
        return "not a git checkout"
    state = '<span class="report-pass">clean</span>'
    if git["dirty"]:
        changed = ", ".join(f"<code>{html.escape(f)}</code>" for f in git["changed"][:6])
        more = f" and {len(git['changed']) - 6} more" if len(git["changed"]) > 6 else ""
        state = f'<span class="report-fail">dirty</span>: tracked files changed since: {changed}{more}'
    record = git.get("record") or []
    if record:
        state += (
            f"; the published record (<code>figures/</code>, <code>data/derived/</code>) differs from the commit's in "
            f"{_count(len(record), 'file')}, rewritten by runs since (<code>make reproduce</code> compares them with "
            "it by the reproducibility contract)"
        )
    return f"<code>{git['commit'][:12]}</code> of {html.escape(str(git['date'])[:10])}, {state}"


def _commit_row(facts: RunFacts, git: dict | None) -> str:
    """The commit the run was of, as its record says, or (a run recorded without it) the checkout's now."""
    if facts.record is not None and "git" in facts.record:
        return f"<dt>Commit</dt><dd>{_commit(facts.record['git'])} <small>(when the run ended, from its record)</small></dd>"
    return f"<dt>Commit</dt><dd>{_commit(git)} <small>(the checkout now; the run recorded none)</small></dd>"


def _environment_rows(env: dict, python: str | None = None) -> str:
    packages = ", ".join(f"{html.escape(k)} {html.escape(v)}" for k, v in env["packages"].items())
    kernel = f" (the kernel: Python {html.escape(python)})" if python and python not in env["python"] else ""
    return (
        f"<dt>Machine</dt><dd>{html.escape(env['platform'])}; {html.escape(env['cpu'])}</dd>"
        f"<dt>Python</dt><dd>{html.escape(env['python'])}{kernel}</dd>"
        f"<dt>Packages</dt><dd>{packages}</dd>"
    )


def verdict_table(page: Page, link: bool = False) -> str:
    """The page's verdicts as a table (``link``: the checks link to their cells on the page)."""
    if not page.verdicts:
        quiet = any("quiet=True" in c.source for c in page.nb.cells if c.cell_type == "code")
        why = "its checks assert quietly (a failed one stops the run) and it prints its own summary" if quiet else ""
        return f"<p>No check verdict printed{': ' + why if why else ''}.</p>"
    rows = []
    for v in page.verdicts:
        name = html.escape(v.name)
        if link:
            name = f'<a href="#cell-id={html.escape(v.cell)}">{name}</a>'
        verdict = '<span class="report-pass">ok</span>' if v.passed else '<span class="report-fail">failed</span>'
        rows.append(
            f"<tr><td>{name}</td><td><code>{html.escape(v.value)}</code></td>"
            f"<td>{html.escape(v.criterion)}</td><td>{verdict}</td></tr>"
        )
    return (
        '<table class="report-table report-verdicts"><tr><th>check</th><th>value</th><th>criterion</th>'
        f"<th>verdict</th></tr>\n{''.join(rows)}\n</table>"
    )


def _tally(page: Page) -> str:
    passed = sum(v.passed for v in page.verdicts)
    failed = len(page.verdicts) - passed
    if not page.verdicts:
        return "none printed"
    text = f'<span class="report-pass">{passed} ok</span>'
    return text + (f', <span class="report-fail">{failed} failed</span>' if failed else "")


def _copy(path: Path) -> str:
    if path.resolve() == (paths.notebooks_dir() / path.name).resolve():
        return " (its stored outputs)"
    return f", executed as <code>{html.escape(_where(path).rstrip('/'))}</code>"


def _page_box(page: Page, env: dict, git: dict | None) -> str:
    facts = page.facts
    return f"""<section class="report-box">
<h2 id="report-run">This run</h2>
<dl>
<dt>Notebook</dt><dd><code>notebooks/{html.escape(page.path.name)}</code>{_copy(page.path)}</dd>
<dt>Executed</dt><dd>{_executed(facts)}</dd>
<dt>Outcome</dt><dd>{_outcome(page)}</dd>
<dt>Parameters</dt><dd>{_parameters(facts)} <small>(from {html.escape(facts.parameters_from)})</small></dd>
<dt>Published run</dt><dd>{_published(facts)}</dd>
<dt>Figures, tables</dt><dd>{figures_went(facts)}</dd>
{_commit_row(facts, git)}
{_environment_rows(env, facts.python)}
</dl>
<h2 id="report-checks">Checks ({_tally(page)})</h2>
{verdict_table(page, link=True)}
</section>
"""


def _count(n: int, what: str) -> str:
    return f"{n} {what}{'' if n == 1 else 's'}"


def index_html(
    pages: list[Page], env: dict, git: dict | None, built: str, executed: Path, not_run: Mapping[str, str] | None = None
) -> str:
    """The index page: the report's provenance, every notebook with its title, outcome, checks, parameters and
    where its figures and tables went, and the tally of the checks; ``not_run``: the notebooks that left no executed
    notebook (file name -> why), each on a row of its own."""
    not_run = dict(not_run or {})
    rows = []
    for k, page in enumerate(pages):
        facts = page.facts
        published = {True: "the published ones", False: "differ: " + ", ".join(facts.changed), None: "—"}[
            facts.published
        ]
        rows.append(
            f'<tr><td>{k + 1}</td><td><a href="{page.href}">{html.escape(page.title)}</a><br>'
            f"<small><code>{html.escape(page.path.name)}</code></small></td><td>{_outcome(page)}</td>"
            f"<td>{_tally(page)}</td><td>{html.escape(published)}</td><td>{figures_went(facts)}</td></tr>"
        )
    for k, (name, why) in enumerate(sorted(not_run.items()), start=len(pages)):
        rows.append(
            f'<tr><td>{k + 1}</td><td><code>{html.escape(name)}</code></td><td><span class="report-fail">did not '
            f"run</span>: {html.escape(why)}</td><td>none</td><td>—</td><td>nothing written</td></tr>"
        )
    checks = [v for p in pages for v in p.verdicts]
    failed = sum(not v.passed for v in checks)
    kinds = [None if p.unfinished is None else p.unfinished.kind for p in pages]
    stopped = sum(p.facts.failure is not None or kind == "stopped" for p, kind in zip(pages, kinds))
    unpublished = sum(p.facts.failure is None and kind == "not published" for p, kind in zip(pages, kinds))
    dated = sorted(p.facts.executed for p in pages if p.facts.executed)
    when = (
        f"executed by papermill from {dated[0]} to {dated[-1]}"
        if dated
        else "their stored outputs (no run date recorded)"
        if pages
        else "none"
    )
    bad = failed or stopped or unpublished or not_run
    summary = (
        f'<span class="{"report-fail" if bad else "report-pass"}">{len(checks) - failed} of '
        f"{len(checks)} printed checks ok</span> in {_count(len(pages), 'notebook')}"
        + (f"; {failed} failed" if failed else "")
        + (f"; {_count(stopped, 'notebook')} stopped before the end" if stopped else "")
        + (f"; {_count(unpublished, 'complete run')} not published" if unpublished else "")
        + (f"; {_count(len(not_run), 'notebook')} did not run" if not_run else "")
    )
    box = f"""<section class="report-box">
<h2>Provenance</h2>
<dl>
<dt>Notebooks</dt><dd>{len(pages)} executed, from <code>{html.escape(_where(executed))}</code>, {when}</dd>
<dt>Report built</dt><dd>{built}</dd>
<dt>Commit</dt><dd>{_commit(git)}</dd>
{_environment_rows(env)}
<dt>Checks</dt><dd>{summary}</dd>
</dl>
</section>"""
    intro = (
        "Each notebook's page shows its text, code, figures and tables, what it checked and with what verdict, and "
        "what ran where. The published record (<code>figures/</code>, <code>data/derived/</code>) holds only "
        "complete runs of the committed notebooks with their published parameters; every other run keeps its "
        "figures and tables in its own folder (last column)."
    )
    title_ = "ocpkit compendium: report of the executed notebooks"
    return _INDEX.format(title=title_, intro=intro, box=box, rows="\n".join(rows), css=CSS)


#: the pages a build wrote, in its output folder: the next build removes those it does not write again
PAGES_WRITTEN = ".report-pages"


def build_report(executed: str | Path, output: str | Path, unfinished: Mapping[str, Unfinished] | None = None) -> Path:
    """Write the report of every executed notebook in ``executed`` into ``output``: one page per notebook
    (:func:`render_page`), ``index.html`` (:func:`index_html`) and the MathJax they load
    (:func:`compendium.mathjax.copy_mathjax`); the index's path. The pages an earlier build wrote there and this
    one does not are removed (they would be of other runs); nothing else in ``output`` is touched.

    ``unfinished``: notebook file name -> why its run is not in the published record
    (:func:`compendium.notebooks.reproduce`); by default what ``reproduce`` recorded beside the executed notebooks
    (:data:`UNFINISHED`). Its page says so; a notebook that left no executed notebook gets a row of the index.
    """
    executed, output = Path(executed), Path(output)
    if unfinished is None:
        recorded = executed / UNFINISHED
        unfinished = (
            {k: Unfinished(*v) for k, v in json.loads(recorded.read_text()).items()} if recorded.is_file() else {}
        )
    notebooks = sorted(executed.glob("*.ipynb")) if executed.is_dir() else []
    if not notebooks and not unfinished:
        raise FileNotFoundError(
            f"no executed notebooks in {executed} (python -m compendium.notebooks reproduce, or make reproduce or make "
            "notebooks, executes them there)"
        )
    if output.exists() and not output.is_dir():
        raise NotADirectoryError(f"the report's folder {output} is a file")
    if any(path.stem == "index" for path in notebooks):
        raise ValueError(f"{executed / 'index.ipynb'}: its page would replace the report's index; rename it")
    output.mkdir(parents=True, exist_ok=True)
    export = exporter(copy_mathjax(output / "mathjax"))
    env, git = environment(), git_state()
    pages = [read_page(path) for path in notebooks]
    for page in pages:
        page.unfinished = unfinished.get(page.path.name)
    for k, page in enumerate(pages):
        previous = pages[k - 1] if k > 0 else None
        following = pages[k + 1] if k + 1 < len(pages) else None
        (output / page.href).write_text(render_page(export, page, previous, following, env, git), encoding="utf-8")
    _remove_earlier_pages(output, {page.href for page in pages})
    shown = {p.path.name for p in pages}
    not_run = {name: left.why for name, left in unfinished.items() if name not in shown}
    built = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    (output / "index.html").write_text(index_html(pages, env, git, built, executed, not_run), encoding="utf-8")
    return output / "index.html"


def _remove_earlier_pages(output: Path, written: set[str]) -> None:
    """Remove the pages an earlier build listed in ``output``'s :data:`PAGES_WRITTEN` that this one did not write,
    and list this build's."""
    listed = output / PAGES_WRITTEN
    try:
        earlier = set(json.loads(listed.read_text())) if listed.is_file() else set()
    except ValueError:  # not a list this function wrote: remove nothing
        earlier = set()
    for name in sorted(earlier - written):
        if name.endswith(".html") and "/" not in name and name != "index.html":
            (output / name).unlink(missing_ok=True)
    listed.write_text(json.dumps(sorted(written)))
