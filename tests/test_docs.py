"""The documentation site's sources (docs/): its examples are the tested ones, and it lists every notebook.

``make docs`` (run by ``make test``) builds the site with warnings as errors; these tests check what the build
cannot: that a page's code example is one a test runs, and that no notebook is left out of the results.
"""

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"


def _python_blocks(path: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", path.read_text(), flags=re.S)


def test_every_python_example_on_the_site_is_run_by_a_test():
    """The site's examples are the README's library example, which tests/test_readme.py runs and checks (and
    tests/test_wheel.py from the long description)."""
    readme = (REPO / "README.md").read_text()
    tested = _python_blocks(DOCS / "ocpkit.md")
    assert tested and all(block in readme for block in tested)
    for page in DOCS.rglob("*.md"):
        for block in _python_blocks(page):
            assert block in tested, f"{page.relative_to(REPO)} has an example no test runs"


def test_the_results_list_every_notebook():
    listed = set(re.findall(r"_notebooks/(\S+)", (DOCS / "results.md").read_text()))
    notebooks = {p.stem for p in (REPO / "notebooks").glob("*.ipynb")}
    assert listed == notebooks
