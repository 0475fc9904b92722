"""Shared fixtures, and the test tiers.

The tests run in two tiers (markers registered in pyproject.toml):

* the fast tier, ``make check``: the library's own tests and the compendium's modules called as functions, but
  those marked ``slow`` (a refinement through many meshes, a continuation: several seconds each);
* ``integration``: what starts JupyterLab, Chromium, a notebook kernel, Sphinx, pip or a fresh virtual environment,
  or reads the whole published record (the modules in :data:`INTEGRATION`). ``make unit`` (and so ``make test``
  and CI) runs both.
"""

import matplotlib
import pytest

matplotlib.use("Agg")

#: the test modules of the integration tier (module docstring); tests/test_tiers.py checks that a module starting a
#: browser, a kernel, Sphinx or a virtual environment is one of them
INTEGRATION = frozenset(
    {
        "test_binder.py",
        "test_docs.py",
        "test_everyday_use.py",
        "test_explorer_lab.py",
        "test_guard.py",
        "test_lab.py",
        "test_lab_roundtrip.py",
        "test_notebooks.py",
        "test_report.py",
        "test_setup.py",
        "test_site.py",
        "test_stored_notebooks.py",
        "test_wheel.py",
    }
)


def pytest_collection_modifyitems(config, items):
    """Every test of an :data:`INTEGRATION` module is marked ``integration``."""
    for item in items:
        if item.path.name in INTEGRATION:
            item.add_marker(pytest.mark.integration)


@pytest.fixture(autouse=True)
def _outputs_to_tmp(tmp_path, monkeypatch):
    """Nothing a test writes lands in the repository's figures/ or data/derived/."""
    monkeypatch.setenv("OCPKIT_OUTPUT_DIR", str(tmp_path / "out"))
    yield


@pytest.fixture
def ipopt_iterations(monkeypatch):
    """The IPOPT iterations of every solve the test makes through the solve policy (``solve_nlp``), in order."""
    import ocpkit.program.solve as policy

    iterations = []
    original = policy.solve_nlp

    def counted(*args, **kwargs):
        result = original(*args, **kwargs)
        iterations.append(result.iterations)
        return result

    monkeypatch.setattr(policy, "solve_nlp", counted)
    return iterations
