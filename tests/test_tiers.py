"""The test tiers (tests/conftest.py): ``make check`` runs the fast tier, which starts no browser, notebook kernel,
Sphinx build or virtual environment; the modules that do are in the integration tier."""

import ast
from pathlib import Path

from conftest import INTEGRATION

TESTS = Path(__file__).resolve().parent
#: what only the integration tier may import: a browser driver, a notebook kernel's client, Sphinx, a fresh venv
HEAVY = frozenset(
    {"_browser", "jupyter_client", "jupyter_server", "nbclient", "nbconvert", "papermill", "sphinx", "venv"}
)


def heavy_imports(path: Path) -> set[str]:
    """The :data:`HEAVY` modules ``path`` imports, anywhere in it."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module.split(".")[0])
    return found & HEAVY


def test_a_module_that_starts_a_browser_a_kernel_sphinx_or_a_venv_is_in_the_integration_tier():
    fast = {p.name: heavy_imports(p) for p in sorted(TESTS.glob("test_*.py")) if p.name not in INTEGRATION}
    assert {name: sorted(found) for name, found in fast.items() if found} == {}
    assert heavy_imports(TESTS / "test_site.py") == {"_browser"}, "the rule sees what it is for"


def test_every_integration_module_exists():
    assert sorted(name for name in INTEGRATION if not (TESTS / name).is_file()) == []
