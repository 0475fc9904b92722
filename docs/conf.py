"""Sphinx configuration of the documentation site (``make docs``: build/docs/index.html).

The notebooks are rendered from their stored outputs (myst-nb, never executed here): they are copied from
``notebooks/`` into ``docs/_notebooks/`` (not tracked) when the build starts. The API reference is autodoc with
NumPy-style docstrings (napoleon). Warnings are errors (``make docs`` passes ``-W``).
"""

from __future__ import annotations

import shutil
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

project = "ocpkit"
author = "the ocpkit compendium authors"
copyright = "2026, the ocpkit compendium authors"
release = version = "0.3.0.dev0"

extensions = ["myst_nb", "sphinx.ext.autodoc", "sphinx.ext.napoleon"]
source_suffix = {".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "ocpkit.md", "**/.ipynb_checkpoints"]

myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 3
nb_execution_mode = "off"  # the notebooks' stored outputs, as nbval checks them
nb_merge_streams = True

napoleon_numpy_docstring = True
napoleon_google_docstring = False
autodoc_member_order = "bysource"
autodoc_typehints = "description"

html_theme = "pydata_sphinx_theme"
html_title = "ocpkit"
html_theme_options = {"navigation_with_keys": False, "show_toc_level": 2}
html_show_sourcelink = False


def _copy_notebooks(app) -> None:
    target = HERE / "_notebooks"
    target.mkdir(exist_ok=True)
    for stale in target.glob("*.ipynb"):
        stale.unlink()
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        shutil.copy2(notebook, target / notebook.name)


def setup(app):
    app.connect("builder-inited", _copy_notebooks)
