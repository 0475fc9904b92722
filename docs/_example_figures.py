"""A Sphinx extension: the figure a page's example draws, drawn by that example when the site is built.

``example_figures`` in ``conf.py`` maps a page (its path under ``docs/``) to an image file name, or to a list of
them: when the build starts, the page's ``python`` blocks run in order in one namespace, as a reader would paste them
(the tests run the same blocks, ``tests/test_docs.py``); the figure the k-th block that assigns ``fig`` draws is
written to ``docs/_generated/<k-th image>``, where the page shows it. No picture is committed: it is always the shown
code's.
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


def draw(page: Path, images: list[Path]) -> None:
    """Run ``page``'s python blocks until as many have assigned ``fig`` as there are ``images``, saving each such
    block's figure as the next image."""
    import matplotlib

    matplotlib.use("Agg")
    blocks = _BLOCK.findall(page.read_text())
    namespace: dict[str, object] = {"__name__": "__main__"}
    here = Path.cwd()
    left = list(images)
    with tempfile.TemporaryDirectory() as folder, contextlib.redirect_stdout(io.StringIO()):
        os.chdir(folder)  # an example that writes files writes them here
        try:
            for k, code in enumerate(blocks):
                if not left:
                    break
                exec(compile(code, f"<{page.name}, example {k}>", "exec"), namespace)
                if _ASSIGNS_FIG.search(code):
                    image = left.pop(0)
                    image.parent.mkdir(parents=True, exist_ok=True)
                    namespace["fig"].savefig(image, dpi=110, metadata={"Software": None})  # type: ignore[attr-defined]
        finally:
            os.chdir(here)
    if left:
        raise ValueError(
            f"{page.name} has {len(images) - len(left)} python blocks that assign fig, and example_figures in conf.py "
            f"names {len(images)} images for it"
        )


def _draw_all(app) -> None:
    docs = Path(app.srcdir)
    for page, images in app.config.example_figures.items():
        names = [images] if isinstance(images, str) else list(images)
        draw(docs / page, [docs / "_generated" / name for name in names])


def setup(app):
    app.add_config_value("example_figures", {}, "env")
    app.connect("builder-inited", _draw_all)
    return {"parallel_read_safe": True}
