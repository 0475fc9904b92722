"""A Sphinx extension: the figure a page's example draws, drawn by that example when the site is built.

``example_figures`` in ``conf.py`` maps a page (its path under ``docs/``) to an image file name: when the build
starts, the page's ``python`` blocks run in order in one namespace, as a reader would paste them (the tests run the
same blocks, ``tests/test_docs.py``), up to the first block that assigns ``fig``; that figure is written to
``docs/_generated/<image>``, where the page shows it. No picture is committed: it is always the shown code's.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import tempfile
from pathlib import Path

_BLOCK = re.compile(r"^```python\n(.*?)^```", flags=re.S | re.M)
_ASSIGNS_FIG = re.compile(r"^fig\s*=", flags=re.M)


def draw(page: Path, image: Path) -> None:
    """Run ``page``'s python blocks up to the first that assigns ``fig`` and save that figure as ``image``."""
    import matplotlib

    matplotlib.use("Agg")
    blocks = _BLOCK.findall(page.read_text())
    namespace: dict[str, object] = {"__name__": "__main__"}
    here = Path.cwd()
    with tempfile.TemporaryDirectory() as folder, contextlib.redirect_stdout(io.StringIO()):
        os.chdir(folder)  # an example that writes files writes them here
        try:
            for k, code in enumerate(blocks):
                exec(compile(code, f"<{page.name}, example {k}>", "exec"), namespace)
                if _ASSIGNS_FIG.search(code):
                    break
            else:
                raise ValueError(f"{page.name} has no python block that assigns fig (example_figures in conf.py)")
        finally:
            os.chdir(here)
    image.parent.mkdir(parents=True, exist_ok=True)
    namespace["fig"].savefig(image, dpi=110, metadata={"Software": None})  # type: ignore[attr-defined]


def _draw_all(app) -> None:
    docs = Path(app.srcdir)
    for page, image in app.config.example_figures.items():
        draw(docs / page, docs / "_generated" / image)


def setup(app):
    app.add_config_value("example_figures", {}, "env")
    app.connect("builder-inited", _draw_all)
    return {"parallel_read_safe": True}
