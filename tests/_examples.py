"""Code examples in Markdown (the README, the documentation site): found, run as printed, compared with what the
page shows by the reproducibility contract's classes."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"

# a fence's info string: a language (``python``), nothing, or a directive and its argument (``{figure} path``)
_BLOCK = re.compile(r"^```(\S*)[^\n]*\n(.*?)^```", flags=re.S | re.M)


#: the longest line a code block on a user page may have: the sources' line length, which a block shows whole in a
#: window 1440 px wide (docs/_static/site.css; tests/test_site.py measures it)
CODE_WIDTH = 120
#: tracker language ("Issue 26's goals", "issues 12 and 22", "issue #7"), which user pages leave to the changelog
TRACKER = re.compile(r"\bissues? #?\d+", flags=re.I)


def code_blocks(text: str) -> list[tuple[str, str]]:
    """Every fenced code block of ``text`` that is shown as code: its language and code (not a directive's body:
    ``{figure}``, ``{toctree}``, ``{eval-rst}``)."""
    return [(m.group(1), m.group(2)) for m in _BLOCK.finditer(text) if not m.group(1).startswith("{")]


def examples(text: str) -> list[tuple[str, str | None]]:
    """Each ``python`` block of ``text`` with what the page says it prints: the next block if it has no language
    and only "prints" (or nothing) stands between them, else None."""
    blocks = [(m.group(1), m.group(2), m.start(), m.end()) for m in _BLOCK.finditer(text)]
    out = []
    for k, (language, code, _, end) in enumerate(blocks):
        if language != "python":
            continue
        printed = None
        if k + 1 < len(blocks) and blocks[k + 1][0] == "":
            between = text[end : blocks[k + 1][2]].strip()
            if between in ("", "prints"):
                printed = blocks[k + 1][1]
        out.append((code, printed))
    return out


def section(path: Path, title: str) -> str:
    """The text of the section headed ``title`` (any level) in ``path``, up to the next heading of its level or
    above; lines inside code blocks (a ``#`` comment) are not headings."""
    lines = path.read_text().splitlines(keepends=True)
    fenced, start, level = False, None, 0
    for k, line in enumerate(lines):
        if line.startswith("```"):
            fenced = not fenced
        heading = re.match(r"(#+) (.*)\n?$", line) if not fenced else None
        if heading and start is None and heading.group(2) == title:
            start, level = k, len(heading.group(1))
        elif heading and start is not None and len(heading.group(1)) <= level:
            return "".join(lines[start:k])
    assert start is not None, f"{path.relative_to(REPO)} has no section {title!r}"
    return "".join(lines[start:])


#: a number in scientific notation: on these pages always an error, an estimate, a residual or a tolerance
_SCIENTIFIC = re.compile(r"[-+]?\d+(?:\.\d+)?[eE][-+]?\d+")


def same_print(printed: str, shown: str) -> list[str]:
    """Differences of what an example printed from what the page shows, by the contract's classes: the words
    exactly, a number in scientific notation (an error, an estimate, a residual, a tolerance) by its magnitude
    (within a factor 2; rounding noise below 1e-12), every other number converged."""
    from compendium.contract import Converged, Error, text_differences

    out = []
    a, b = printed.strip().splitlines(), shown.strip().splitlines()
    if len(a) != len(b):
        return [f"{len(a)} lines printed, {len(b)} shown"]
    for x, y in zip(a, b):
        words_x, words_y = (" ".join(_SCIENTIFIC.sub("<e>", line).split()) for line in (x, y))
        out += text_differences(words_x, words_y, Converged())
        out += text_differences(" ".join(_SCIENTIFIC.findall(x)), " ".join(_SCIENTIFIC.findall(y)), Error(floor=1e-12))
    return out


_SESSION = """
import contextlib, io, json, sys
blocks = json.loads(sys.stdin.read())
namespace, printed = {"__name__": "__main__"}, []
for k, code in enumerate(blocks):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, f"<example {k}>", "exec"), namespace)
    printed.append(out.getvalue())
    sys.stderr.write(f"example {k} done\\n")
sys.stdout.write(json.dumps(printed))
"""


def run_session(
    blocks: list[str], folder: Path, python: Path | str = sys.executable, env: dict[str, str] | None = None
) -> tuple[list[str] | None, str]:
    """A page's examples run in order in one namespace (a later example may use an earlier one's names), by
    ``python`` (this one unless given; in ``env``, this process's unless given) in ``folder`` (outside the
    repository), as a reader would paste them: what each printed (None if one failed) and the process's stderr."""
    import json

    proc = subprocess.run(
        [str(python), "-c", _SESSION],
        input=json.dumps(blocks),
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    return (json.loads(proc.stdout) if proc.returncode == 0 else None), proc.stderr
