"""The documentation site in headless Chromium: built from docs/ as `make docs` builds it, served from 127.0.0.1,
each page with its title and contents, equations typeset by the site's own MathJax in the TeX web fonts, figures
loaded, and not one request off the machine."""

from __future__ import annotations

import html
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from _browser import FONTCONFIG, Recorder, served
from _examples import CODE_WIDTH, DOCS, REPO, TRACKER
from test_lab import needs_chromium

from compendium import mathjax

#: done once the page has loaded and MathJax (where the page has math) has typeset it and its fonts are in
_SHOWN = """(async () => {
  if (document.readyState !== 'complete') return {done: false, state: 'loading'};
  const hub = window.MathJax && MathJax.Hub;
  const pending = document.querySelectorAll('.math').length;
  if (pending && (!hub || !hub.queue || hub.queue.pending || hub.queue.running
                  || !document.querySelectorAll('.MathJax_CHTML').length)) {
    return {done: false, state: 'MathJax not done'};
  }
  await document.fonts.ready;
  const faces = {};
  document.fonts.forEach(f => { faces[f.family.replace(/"/g, '')] = f.status; });
  const toc = Array.from(document.querySelectorAll('#pst-page-toc-nav a[href^="#"]'));
  return {done: true, title: document.title, h1: (document.querySelector('h1') || {}).textContent || '',
          math: document.querySelectorAll('.MathJax_CHTML').length, raw: pending, faces,
          errors: document.querySelectorAll('.MathJax_Error, .mjx-merror, .merror').length,
          contents: toc.map(a => !!document.getElementById(decodeURIComponent(a.hash.slice(1)))),
          images: Array.from(document.images).filter(i => !i.src.endsWith('.svg'))
                       .map(i => i.complete && i.naturalWidth)};
})()"""

PAGES = {
    "getting-started.html": {"contents": 3, "images": 1},  # the picture of sol.plot()
    "guide/how-do-i.html": {"contents": 9, "images": 1},
    "guide/accuracy.html": {"contents": 5, "images": 1},
    "api/transcriptions/transcription-hlgl.html": {"contents": 5, "math": 5},  # the HLGL formulas, typeset
    "results/desai-conway.html": {"contents": 2, "images": 2},
    "_notebooks/04_shooting_validation.html": {"contents": 3, "math": 10, "images": 3},
    "gallery/index.html": {"contents": 10, "images": 60},  # a thumbnail per problem, by what each exercises
    "gallery/classic_brachistochrone.html": {"contents": 3, "math": 1, "images": 1},  # statement, code, picture
}

#: the characters a line of the first code block on the page shows without scrolling, in a window 1440 px wide
_CODE_FITS = """(() => {
  const pre = document.querySelector('div.highlight pre');
  const probe = document.createElement('span');
  probe.textContent = 'x'.repeat(100);
  pre.appendChild(probe);
  const width = probe.getBoundingClientRect().width / 100;
  probe.remove();
  const style = getComputedStyle(pre);
  return Math.floor((pre.clientWidth - parseFloat(style.paddingLeft) - parseFloat(style.paddingRight)) / width);
})()"""


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built with make docs's command: the one make docs built in this same make run (make unit builds
    it first and names it in OCPKIT_SITE, so that make test builds the site once), else built here."""
    if not mathjax.find_mathjax().tex_fonts:
        pytest.skip("no MathJax 2 with TeX fonts (make mathjax); tests/test_report.py says so")
    built = os.environ.get("OCPKIT_SITE")
    if built and (Path(built) / "index.html").is_file():
        return Path(built)
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-n", "-W", "--keep-going", "-q", "-b", "html", str(DOCS), str(out)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out


@needs_chromium
def test_pages_of_the_site_in_chromium(site, tmp_path, monkeypatch):
    (tmp_path / "fonts").mkdir()
    (tmp_path / "fonts" / "fonts.conf").write_text(FONTCONFIG.format(cache=tmp_path / "fonts" / "cache"))
    monkeypatch.setenv("FONTCONFIG_FILE", str(tmp_path / "fonts" / "fonts.conf"))
    shown = {}
    with served(site) as base:
        recorder = Recorder(tmp_path / "profile", tmp_path / "chromium.log")
        browser = recorder.browser
        try:
            browser.call("Network.enable")
            for page in PAGES:
                browser.call("Page.navigate", url=base + page)
                shown[page] = browser.poll(_SHOWN, 30, f"{page} shown")
            browser.call(
                "Emulation.setDeviceMetricsOverride", width=1440, height=900, deviceScaleFactor=1, mobile=False
            )
            browser.call("Page.navigate", url=base + "guide/how-do-i.html")
            browser.poll(_SHOWN, 30, "guide/how-do-i.html shown at 1440 px")
            fits = browser.js(_CODE_FITS)
        finally:
            browser.close()
    for page, expected in PAGES.items():
        got = shown[page]
        assert got["h1"].strip().rstrip("#").strip() in got["title"] and "ocpkit" in got["title"], (page, got)
        assert len(got["contents"]) >= expected["contents"] and all(got["contents"]), (page, got["contents"])
        assert got["errors"] == 0 and got["math"] >= expected.get("math", 0), (page, got["math"])
        assert got["math"] >= got["raw"], f"{page}: {got['raw']} equations, {got['math']} typeset"
        assert len(got["images"]) >= expected.get("images", 0) and all(got["images"]), (page, got["images"])
    assert shown["_notebooks/04_shooting_validation.html"]["faces"].get("MJXc-TeX-main-Rw") == "loaded"
    assert fits >= CODE_WIDTH, f"a code block shows {fits} characters at 1440 px, the pages' blocks up to {CODE_WIDTH}"
    requests = recorder.requests()
    assert any(url.startswith(f"{base}_static/mathjax/fonts/HTML-CSS/TeX/woff/MathJax_Main") for url in requests)
    assert [url for url in requests if not url.startswith((base, "data:", "about:blank"))] == []
    assert recorder.failures() == []


def test_no_page_of_the_built_site_names_the_tracker(site):
    """What the site shows, from the pages, the docstrings and the tables they include: no "Issue 26" outside the
    changelog, the notebooks' pages included."""
    pages = [p for p in site.rglob("*.html") if p.name != "changelog.html"]
    assert any("_notebooks" in p.parts for p in pages)
    assert len(pages) > 60, "the API pages, the guide, the results and the highlighted sources"
    found = {}
    for page in pages:
        text = html.unescape(re.sub(r"<[^>]+>", " ", page.read_text()))
        if TRACKER.search(text):
            found[str(page.relative_to(site))] = TRACKER.findall(text)
    assert found == {}


def test_the_site_has_copy_buttons_and_source_links(site):
    """sphinx-copybutton on every code block, and viewcode's [source] beside every documented name."""
    assert (site / "_static" / "copybutton.js").is_file()
    assert "copybutton.js" in (site / "guide" / "how-do-i.html").read_text()
    hlgl = (site / "api" / "transcriptions" / "transcription-hlgl.html").read_text()
    assert "_modules/ocpkit/transcription/hlgl.html" in hlgl
    assert (site / "_modules" / "ocpkit" / "transcription" / "hlgl.html").is_file()
