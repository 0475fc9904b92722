"""The table of what the library tells a user (docs/guide/messages.md): every row runs, and says what the page shows.

Each row's first cell is code, run after the page's setup (its first Python block); its second cell is
``Category: the beginning of the message``, where ``…`` stands for anything (the rest, or a number that depends on the
machine). The row holds when the code raises, or warns, a message of that category whose text matches.
"""

from __future__ import annotations

import re
import warnings

import pytest
from _examples import DOCS, examples

PAGE = DOCS / "guide" / "messages.md"
ROW = re.compile(r"^\|\s*`(?P<code>[^`]+)`\s*\|\s*`(?P<said>[^`]+)`\s*\|\s*$")


def rows() -> list[tuple[str, str]]:
    return [(m["code"], m["said"]) for line in PAGE.read_text().splitlines() if (m := ROW.match(line))]


def pattern(said: str) -> re.Pattern[str]:
    """The message's beginning, ``…`` standing for anything."""
    category, _, text = said.partition(": ")
    return re.compile(re.escape(category) + ": " + ".*?".join(re.escape(part) for part in text.split("…")), re.S)


@pytest.fixture(scope="module")
def setup() -> dict:
    code, _ = examples(PAGE.read_text())[0]
    namespace: dict = {}
    exec(compile(code, str(PAGE), "exec"), namespace)  # noqa: S102
    return namespace


def said_by(code: str, namespace: dict) -> list[str]:
    """Everything the code says: the error it raises and the warnings it gives, each ``Category: message``."""
    out = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            exec(compile(code, "row", "exec"), dict(namespace))  # noqa: S102
        except Exception as exc:  # noqa: BLE001 - the row's message is what is compared
            out.append(f"{type(exc).__name__}: {exc}")
    out += [f"{w.category.__name__}: {w.message}" for w in caught]
    return out


def test_the_page_has_its_rows():
    """Every line of the page's tables is a header or a row the test reads (a cell with a ``|`` or a backtick in
    its code would otherwise drop out of the check unseen)."""
    lines = [line for line in PAGE.read_text().splitlines() if line.startswith("|")]
    unread = [line for line in lines if not (ROW.match(line) or line.startswith(("| What you did", "|---")))]
    assert unread == [] and len(rows()) >= 100


@pytest.mark.parametrize(("code", "said"), rows(), ids=[f"row{k}" for k in range(len(rows()))])
def test_every_row_says_what_the_page_shows(code, said, setup):
    messages = said_by(code, setup)
    wanted = pattern(said)
    assert any(wanted.match(m) for m in messages), f"the page shows {said!r}; the code said {messages!r}"
