"""Sphinx configuration of the documentation site (``make docs``: build/docs/index.html).

The notebooks are rendered from their stored outputs (myst-nb, never executed here): they are copied from
``notebooks/`` into ``docs/_notebooks/`` (not tracked) when the build starts. The API reference is autodoc with
NumPy-style docstrings (napoleon). Warnings are errors (``make docs`` passes ``-W``).
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

project = "ocpkit"
author = "the ocpkit compendium authors"
copyright = "2026, the ocpkit compendium authors"
release = version = "0.3.0.dev0"

# viewcode: a [source] link beside every documented name, to its module's highlighted code on the site itself
extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
    "sphinx_copybutton",
    "_example_figures",
    "_gallery",
]
source_suffix = {".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "_generated", "ocpkit.md", "**/.ipynb_checkpoints"]

myst_enable_extensions = ["dollarmath", "amsmath", "substitution"]
# the numbers the pages' prose quotes ({{ name }}), computed from data/ as the tables are (docs/_tables.py)
sys.path.insert(0, str(HERE))
from _tables import values  # noqa: E402

myst_substitutions = values()
# the pictures that pages' examples draw, drawn by those examples at build time (docs/_example_figures.py)
example_figures = {
    "getting-started.md": "getting-started-plot.png",
    "guide/how-do-i.md": ["how-do-i-plot.png", "how-do-i-refinement.png"],
}
myst_heading_anchors = 3
nb_execution_mode = "off"  # the notebooks' stored outputs, as nbval checks them
nb_merge_streams = True

napoleon_numpy_docstring = True
napoleon_google_docstring = False
autodoc_member_order = "groupwise"  # classes, then functions, then data: the user-facing names first
autodoc_typehints = "description"

# Every cross-reference must resolve (make docs passes -n, nitpicky, with -W). Names of the libraries ocpkit builds
# on are not documented here (no network for intersphinx at build time), so references to them are not checked.
nitpick_ignore_regex = [
    (
        "py:.*",
        r"(numpy|np|casadi|ca|scipy|pandas|pd|matplotlib|collections|typing|abc|enum|warnings|pathlib|os)(\..*)?",
    ),
    ("py:.*", r"(ndarray|callable|optional|Path|ArrayLike|NDArray|Callable|Sequence|Mapping|Iterable|Figure)"),
]

html_theme = "pydata_sphinx_theme"
html_title = "ocpkit"
html_theme_options = {"navigation_with_keys": False, "show_toc_level": 2}
html_show_sourcelink = False
html_static_path = ["_static"]
# the copy button copies a block's code without the prompts of a console session (">>> ", "$ ")
copybutton_prompt_text = r">>> |\.\.\. |\$ "
copybutton_prompt_is_regexp = True

# MathJax 2 served from the site itself with its TeX web fonts (compendium.mathjax, the report's too; Debian's
# libjs-mathjax and fonts-mathjax, which `make mathjax` installs): no request leaves the machine. The tree is copied
# into _static/mathjax when the build finishes; the URL is relative to _static.
from compendium.mathjax import find_mathjax  # noqa: E402  (src/ is on the environment's path)

MATHJAX = find_mathjax()  # Debian's with the TeX fonts, else jupyter-server-mathjax's STIX fonts (and it says so)
mathjax_path = MATHJAX.url("mathjax")
# myst-nb marks a notebook's sections tex2jax_ignore and its math (and outputs) as classes to process again
mathjax2_config = {"tex2jax": {"processClass": "tex2jax_process|mathjax_process|math|output_area"}}
html_css_files = ["site.css"]
html_favicon = "_static/favicon.svg"  # also spares the browser a request for /favicon.ico


def _copy_notebooks(app) -> None:
    target = HERE / "_notebooks"
    target.mkdir(exist_ok=True)
    for stale in target.glob("*.ipynb"):
        stale.unlink()
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        shutil.copy2(notebook, target / notebook.name)


def _write_tables(app) -> None:
    from _tables import write_tables

    write_tables(HERE / "_generated")


def _public_alias(app, env, node, contnode):
    """Resolve a reference to a name by where ocpkit exports it (``ocpkit.Solution``, ``ocpkit.shooting.Shooting``,
    ``ocpkit.Solution.linear_solver``) to where it is documented (``ocpkit.solution.Solution...``); a bare name
    (``Solution``, ``Transcription.solve``) likewise, from the module whose docstring names it."""
    import importlib
    from types import ModuleType

    def _annotations(cls: type) -> set[str]:
        return {name for klass in cls.__mro__ for name in getattr(klass, "__annotations__", {})}

    def _defining_module(module: ModuleType, name: str, value: object, domain) -> str:
        for documented, *_ in domain.get_objects():
            where, _, last = documented.rpartition(".")
            if last == name and where.startswith(module.__name__ + "."):
                try:
                    if getattr(importlib.import_module(where), name, None) is value:
                        return where
                except ImportError:  # a class's attribute
                    continue
        return module.__name__

    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"]
    starts = [target] if target.startswith("ocpkit") else [f"{m}.{target}" for m in (node.get("py:module"), "ocpkit")]
    domain = env.get_domain("py")
    for dotted in filter(None, starts):
        parts = dotted.split(".")
        for split in range(len(parts) - 1, 0, -1):
            try:
                obj = importlib.import_module(".".join(parts[:split]))
            except ImportError:
                continue
            path = [".".join(parts[:split])]
            try:
                for k, part in enumerate(parts[split:], split):
                    owner = obj
                    try:
                        obj = getattr(obj, part)
                    except AttributeError:
                        # an attribute a class declares but holds no value of (a dataclass field without a
                        # default, an annotation the constructor sets): documented by that name all the same
                        if k == len(parts) - 1 and isinstance(owner, type) and part in _annotations(owner):
                            path = [owner.__module__, owner.__qualname__, part]
                            break
                        raise
                    if isinstance(obj, ModuleType):
                        path = [obj.__name__]
                    elif isinstance(obj, type) or callable(obj) and hasattr(obj, "__qualname__"):
                        path = [obj.__module__, obj.__qualname__]
                    elif isinstance(owner, ModuleType):
                        # a constant a package re-exports (ocpkit.shooting.SWITCHING_MODES): where it is defined
                        path = [_defining_module(owner, part, obj, domain), part]
                    else:
                        path = [getattr(owner, "__module__", path[0]), getattr(owner, "__qualname__", ""), part]
            except AttributeError:
                break
            if isinstance(obj, ModuleType) and node.get("reftype") not in ("mod", "obj"):
                break  # (:attr:`problem` is no reference to the module ocpkit.problem)
            real = ".".join(p for p in path if p)
            for role in ("class", "func", "meth", "attr", "obj", "data", "mod"):
                found = domain.resolve_xref(env, node["refdoc"], app.builder, role, real, node, contnode)
                if found is not None:
                    return found
            break
    return None


def _copy_mathjax(app, exception) -> None:
    if exception is None and app.builder.format == "html":
        from compendium.mathjax import copy_mathjax

        copy_mathjax(Path(app.outdir) / "_static" / "mathjax", MATHJAX)


def setup(app):
    app.connect("build-finished", _copy_mathjax)
    app.connect("missing-reference", _public_alias)
    app.connect("builder-inited", _copy_notebooks)
    app.connect("builder-inited", _write_tables)
