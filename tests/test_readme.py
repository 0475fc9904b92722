"""The README: short, its links resolve, and its example and command are the ones the documentation site's tests
run (tests/test_docs.py)."""

from __future__ import annotations

import re

from _examples import DOCS, REPO, examples, section

README = REPO / "README.md"


def _slug(heading: str) -> str:
    """The anchor MyST (and GitHub) give a heading: lower case, punctuation dropped, spaces as hyphens."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def test_the_readme_is_short():
    assert len(README.read_bytes()) <= 12_000, "the README is at most 12 KB: the rest belongs on the site (docs/)"


def test_every_link_in_the_readme_resolves():
    links = re.findall(r"\]\(([^)]+)\)", README.read_text())
    assert links, "the README links to the documentation"
    for link in links:
        assert not link.startswith(("http://", "https://")), f"{link}: the README links to files of the repository"
        path, _, anchor = link.partition("#")
        target = (REPO / path).resolve()
        assert target.exists(), f"{link}: no such file"
        if anchor:
            headings = re.findall(r"^#+ (.+)$", target.read_text(), flags=re.M)
            assert anchor in {_slug(h) for h in headings}, f"{link}: no heading with that anchor"


def test_every_documentation_page_is_linked_from_the_readme():
    readme = README.read_text()
    pages = {"getting-started.md", "guide/stating-a-problem.md", "guide/transcriptions.md", "guide/accuracy.md"}
    pages |= {"benchmarks.md", "reproducibility.md", "layout.md", "api/index.md"}
    pages |= {p.relative_to(DOCS).as_posix() for p in (DOCS / "results").glob("*.md") if p.name != "index.md"}
    assert [p for p in sorted(pages) if f"](docs/{p}" not in readme] == []


def test_the_library_example_is_the_sites_first_and_is_run_there():
    """The README's example and what it prints are those of the site's first guide page, which tests/test_docs.py
    runs, compares and checks against the exact cost; docs/ocpkit.md (the wheel's description) shows the same."""
    readme = examples(section(README, "The library on its own"))
    assert readme and "compendium" not in readme[0][0], "the example uses the library alone"
    site = examples((DOCS / "guide" / "stating-a-problem.md").read_text())
    assert readme[0] == site[0]
    assert readme[0] == examples((DOCS / "ocpkit.md").read_text())[0]


def test_the_readme_command_is_one_the_site_runs_on_a_fresh_clone():
    command = re.findall(r"```sh\n(.*?)```", section(README, "Two commands"), flags=re.S)[-1]
    site = section(DOCS / "guide" / "notebooks-and-lab.md", "One notebook with other parameters")
    assert command.strip() in site, "tests/test_docs.py runs the site's commands on a fresh clone"


def test_sources_are_cited_by_reference_not_by_a_path_outside_the_repository():
    """A reader of the compendium has no ../shared/seeds: the README and the notebooks cite authors and titles."""
    texts = {"README.md": README.read_text()}
    texts |= {p.name: p.read_text() for p in sorted((REPO / "notebooks").glob("*.ipynb"))}
    texts |= {str(p.relative_to(REPO)): p.read_text() for p in DOCS.rglob("*.md")}
    for name, text in texts.items():
        assert "shared/seeds" not in text and "seeds/00" not in text, name
    readme = texts["README.md"]
    for cited in ("Desai", "Conway", "Martinon", "Gergaud", "Fuel optimal entry trajectory with Radau", "Herman"):
        assert cited in readme, cited
