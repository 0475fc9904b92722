"""MathJax 2 for pages read offline: the files a page needs, copied next to it, with MathJax's TeX web fonts.

The report (:mod:`compendium.report`) and the documentation site call :func:`copy_mathjax` with the folder MathJax
goes to and link the URL it returns; that URL names the configuration :func:`copy_mathjax` writes into the copy
(``config/local/ocpkit.js``: :data:`CONFIG`), so a page needs nothing else to typeset in the TeX fonts and never
asks the network for a file (a page may add its own ``MathJax.Hub.Config``: the report, nbconvert's ``$`` delimiters
and equation numbers). The TeX fonts come from Debian's ``libjs-mathjax`` and ``fonts-mathjax`` (``make
mathjax`` installs them; :data:`TEX_FONT_ROOTS` are the folders looked in); without them, from the
``jupyter-server-mathjax`` package, whose only web fonts are STIX-Web (a note on standard error says so).
"""

from __future__ import annotations

import json
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

#: where the distributions put MathJax 2 (Debian and Fedora's libjs-mathjax, Arch's mathjax2)
TEX_FONT_ROOTS = (Path("/usr/share/javascript/mathjax"), Path("/usr/share/mathjax2"), Path("/usr/share/mathjax"))
#: the configuration a copy loads, under its ``config/`` folder
CONFIG_NAME = "local/ocpkit"
#: TeX and AMS macros, the TeX extensions loaded up front (the others load when a macro of theirs is met)
TEX_EXTENSIONS = ["AMSmath.js", "AMSsymbols.js", "noErrors.js", "noUndefined.js"]
#: MathJax's extensions loaded up front: finding the math in the page, ``Safe`` mode (no script in a formula)
EXTENSIONS = ["tex2jax.js", "Safe.js"]
#: those loaded when needed: mouse events, the math menu, its zoom, help and MathML view, font warnings
ON_DEMAND = ["MathEvents.js", "MathMenu.js", "MathZoom.js", "HelpDialog.js", "toMathML.js", "FontWarnings.js"]
#: ``MathJax.Hub.Config`` of a copy with the TeX fonts: TeX input, CommonHTML output in the TeX web fonts (HTML-CSS,
#: which the math menu offers, in the same fonts), no image fonts, no preview and no loading messages
CONFIG = {
    "jax": ["input/TeX", "output/CommonHTML"],
    "extensions": EXTENSIONS,
    "TeX": {"extensions": TEX_EXTENSIONS},
    "HTML-CSS": {"availableFonts": ["TeX"], "preferredFont": "TeX", "webFont": "TeX", "imageFont": None},
    "CommonHTML": {"linebreaks": {"automatic": True}},
    "fast-preview": {"disabled": True},
    "messageStyle": "none",
}


@dataclass(frozen=True)
class MathJax:
    """A MathJax 2 tree on this machine and the web font used from it. ``combined``: a combined configuration of the
    tree loaded first, for a tree whose jax come only in one (``jupyter-server-mathjax``'s)."""

    root: Path
    font: str
    combined: str | None = None

    @property
    def tex_fonts(self) -> bool:
        """Whether the equations are in MathJax's own TeX fonts."""
        return self.font == "TeX"

    def config(self) -> dict:
        """The ``MathJax.Hub.Config`` of a copy of this tree: :data:`CONFIG`, or over a combined configuration its
        fonts only (HTML-CSS output in this font)."""
        if self.combined is None:
            return CONFIG
        fonts = {"availableFonts": [], "preferredFont": None, "webFont": self.font, "imageFont": None}
        return {"HTML-CSS": fonts, "messageStyle": "none"}

    def files(self) -> list[str]:
        """The files of the tree a page needs, relative to its root: MathJax.js, the TeX input jax, the output jax
        (CommonHTML, and HTML-CSS with this font's data), the MathML element jax, the extensions (:data:`EXTENSIONS`,
        :data:`ON_DEMAND`, the TeX ones), the web fonts (woff) and the English messages; all of a tree with a
        combined configuration (which loads more on demand)."""
        if self.combined is not None:
            return sorted(str(p.relative_to(self.root)) for p in self.root.rglob("*") if p.is_file())
        wanted = ["MathJax.js", *(f"extensions/{name}" for name in EXTENSIONS + ON_DEMAND)]
        wanted += ["jax/output/HTML-CSS/config.js", "jax/output/HTML-CSS/jax.js"]
        folders = [
            "jax/input/TeX",
            "jax/element/mml",
            "jax/output/CommonHTML",
            f"jax/output/HTML-CSS/fonts/{self.font}",
            "jax/output/HTML-CSS/autoload",
            "extensions/TeX",
            "extensions/HTML-CSS",
            f"fonts/HTML-CSS/{self.font}/woff",
            "localization/en",
        ]
        for folder in folders:
            wanted += sorted(str(p.relative_to(self.root)) for p in (self.root / folder).rglob("*") if p.is_file())
        return wanted

    def url(self, folder: str) -> str:
        """The URL of MathJax.js in a copy of this tree in ``folder``, with its configuration."""
        configs = [self.combined, CONFIG_NAME] if self.combined else [CONFIG_NAME]
        return f"{folder}/MathJax.js?config={','.join(configs)}"


def _has_tex_fonts(root: Path) -> bool:
    return (root / "MathJax.js").is_file() and (root / "fonts/HTML-CSS/TeX/woff/MathJax_Main-Regular.woff").is_file()


def find_mathjax() -> MathJax:
    """The MathJax 2 with the TeX web fonts of :data:`TEX_FONT_ROOTS`, else ``jupyter-server-mathjax``'s (STIX-Web
    fonts, HTML-CSS output, from its combined configuration), with a note on standard error saying so."""
    root = tex_fonts_root()
    if root is not None:
        return MathJax(root, "TeX")
    import jupyter_server_mathjax

    print(
        "mathjax: no MathJax 2 with its TeX web fonts on this machine (looked in "
        f"{', '.join(map(str, TEX_FONT_ROOTS))}): the equations are set in jupyter-server-mathjax's STIX-Web fonts. "
        "For the TeX fonts: make mathjax (Debian: apt-get install libjs-mathjax fonts-mathjax)",
        file=sys.stderr,
    )
    static = Path(jupyter_server_mathjax.__file__).parent / "static"
    return MathJax(static, "STIX-Web", "TeX-AMS-MML_HTMLorMML-full")


def config_script(mathjax: MathJax) -> str:
    """The configuration file of a copy: :meth:`MathJax.config`, then MathJax's signal that the file has loaded."""
    config = json.dumps(mathjax.config(), indent=2)
    return f'MathJax.Hub.Config({config});\nMathJax.Ajax.loadComplete("[MathJax]/config/{CONFIG_NAME}.js");\n'


def copy_mathjax(target: str | Path, mathjax: MathJax | None = None) -> str:
    """Copy what pages need of MathJax 2 (:meth:`MathJax.files`, default :func:`find_mathjax`) into the folder
    ``target`` with its configuration (:func:`config_script`); the URL of MathJax.js to load, relative to
    ``target``'s parent folder (:meth:`MathJax.url`), e.g. ``mathjax/MathJax.js?config=local/ocpkit``.

    ``target`` is replaced whole: it must be missing, empty or an earlier copy (holding MathJax.js).
    """
    target = Path(target)
    mathjax = mathjax or find_mathjax()
    if target.exists():
        if any(target.iterdir()) and not (target / "MathJax.js").is_file():
            raise FileExistsError(f"{target} holds other files than a copy of MathJax: not replacing it")
        shutil.rmtree(target)
    for rel in mathjax.files():
        (target / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(mathjax.root / rel, target / rel)
    config = target / "config" / f"{CONFIG_NAME}.js"
    config.parent.mkdir(parents=True, exist_ok=True)
    config.write_text(config_script(mathjax), encoding="utf-8")
    return mathjax.url(target.name)


def tex_fonts_root() -> Path | None:
    """The first of :data:`TEX_FONT_ROOTS` that holds MathJax 2 with its TeX web fonts, or ``None``."""
    return next((root for root in TEX_FONT_ROOTS if _has_tex_fonts(root)), None)


#: ``python -m compendium.mathjax``'s exit status when it finds no TeX fonts (1 is Python's for an uncaught error)
NO_TEX_FONTS = 3


def main() -> int:
    """``python -m compendium.mathjax``: where the TeX fonts are (exit 0), or that there are none (exit
    :data:`NO_TEX_FONTS`); what ``make mathjax`` asks before it installs them."""
    root = tex_fonts_root()
    if root is None:
        print(f"no MathJax 2 with its TeX web fonts in {', '.join(map(str, TEX_FONT_ROOTS))}", file=sys.stderr)
        return NO_TEX_FONTS
    print(root)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
