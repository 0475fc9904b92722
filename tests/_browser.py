"""Headless Chromium for the tests of the HTML pages the compendium writes (the report, the documentation site):
driven over the DevTools Protocol (test_lab_roundtrip's client), every request it makes recorded, pages served from
127.0.0.1 only, and the system's MathJax fonts hidden from it, so that a page's own web fonts must do the work."""

from __future__ import annotations

import contextlib
import functools
import http.server
import json
import threading
from pathlib import Path

#: fontconfig without the system's MathJax fonts (Debian's fonts-mathjax installs them system-wide too): a page
#: whose @font-face failed would otherwise still look right
FONTCONFIG = """<?xml version="1.0"?>
<!DOCTYPE fontconfig SYSTEM "urn:fontconfig:fonts.dtd">
<fontconfig>
  <include ignore_missing="yes">/etc/fonts/fonts.conf</include>
  <cachedir>{cache}</cachedir>
  <selectfont><rejectfont><glob>*/mathjax/*</glob><glob>*MathJax*</glob></rejectfont></selectfont>
</fontconfig>
"""


class Recorder:
    """Headless Chromium over the DevTools Protocol (test_lab_roundtrip's), keeping the events it sends."""

    def __init__(self, profile: Path, log: Path):
        from test_lab_roundtrip import _Browser

        events = self.events = []

        class Browser(_Browser):
            def call(self, method: str, **params) -> dict:
                self._id += 1
                self.ws.send(json.dumps({"id": self._id, "method": method, "params": params}))
                while True:
                    msg = json.loads(self.ws.recv())
                    if msg.get("id") == self._id:
                        if "error" in msg:
                            raise RuntimeError(f"{method}: {msg['error']}")
                        return msg["result"]
                    events.append(msg)

        self.browser = Browser(profile, log)

    def requests(self) -> list[str]:
        return [e["params"]["request"]["url"] for e in self._sent()]

    def failures(self) -> list[tuple[str, str]]:
        """The requests that failed, or whose answer was neither 200 nor 304: URL and why."""
        urls = {e["params"]["requestId"]: e["params"]["request"]["url"] for e in self._sent()}
        failed = [(urls.get(e["requestId"], "?"), e["errorText"]) for e in self._params("Network.loadingFailed")]
        failed = [(url, why) for url, why in failed if url != "about:blank"]  # HTML-CSS's MathJax_Blank font
        answers = [e["response"] for e in self._params("Network.responseReceived")]
        return failed + [
            (r["url"], r["status"]) for r in answers if r["url"].startswith("http") and r["status"] not in (200, 304)
        ]

    def _params(self, method: str) -> list[dict]:
        return [e["params"] for e in self.events if e.get("method") == method]

    def _sent(self) -> list[dict]:
        return [e for e in self.events if e.get("method") == "Network.requestWillBeSent"]


@contextlib.contextmanager
def served(folder: Path):
    """``folder`` over HTTP on 127.0.0.1 (a free port), quietly; its base URL."""

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=str(folder)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_port}/"
    finally:
        server.shutdown()
        server.server_close()
