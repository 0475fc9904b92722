"""JupyterLab, as a reader uses it: Restart Kernel and Run All Cells, then Save, leaves a stored notebook unchanged.

A throw-away clone of the repository (its working tree as it is, uncommitted changes included, committed in the
clone) is served by `python -m compendium.lab` (``OCPKIT_ROOT`` = the clone), in the environment of a user's
``make lab`` (neither ``OCPKIT_OUTPUT_DIR`` nor ``OCPKIT_PROGRESS`` set). Headless Chromium, driven over the Chrome
DevTools Protocol (websocket-client, already a dependency of jupyter_server), opens the notebook and runs Lab's own
commands, the ones behind the Kernel and File menus (``notebook:restart-run-all``, its confirmation dialog
accepted, then ``docmanager:save``). Then ``git status`` of the clone must be empty (the notebook, figures/ and
data/); when it is not, the failure says which cells and outputs changed, and how.

``OCPKIT_LAB_ROUNDTRIP=00_validation.ipynb,04_shooting_validation.ipynb`` runs other notebooks than the default
(the fastest with figures and tables, about 20 s of cells; the whole test takes about 40 s).
``OCPKIT_LAB_ROUNDTRIP_STORE=1`` first re-stores the notebook in the clone (`python -m compendium.notebooks store`,
committed there): what then differs is what Lab does differently from papermill on this machine, not what changed
since the notebook was last stored.
"""

from __future__ import annotations

import contextlib
import difflib
import json
import os
import re
import shutil
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path

import pytest
from test_lab import CHROMIUM_FLAGS, HAVE_LAB, _chromium, _kernel_installed, _running_lab, needs_chromium

from compendium.notebooks import KERNEL_NAME
from compendium.provenance import ONE_THREAD

REPO = Path(__file__).resolve().parents[1]
DEFAULT_NOTEBOOK = "01_lunar_ascent.ipynb"
NOTEBOOKS = os.environ.get("OCPKIT_LAB_ROUNDTRIP", DEFAULT_NOTEBOOK).split(",")
STORE_FIRST = os.environ.get("OCPKIT_LAB_ROUNDTRIP_STORE", "") not in ("", "0")

# what the Makefile exports for `make lab` and `make store` (one BLAS thread)
MAKE_ENV = dict(ONE_THREAD)

PAGE_TIMEOUT = 60.0  # Lab's page loaded, the notebook open, its kernel idle
RUN_TIMEOUT = 120.0 if NOTEBOOKS == [DEFAULT_NOTEBOOK] else 900.0  # every cell run (the default: about 20 s)
SAVE_TIMEOUT = 30.0
WINDOW = "--window-size=1280,1024"

pytestmark = [
    pytest.mark.skipif(not HAVE_LAB, reason="jupyterlab is not installed"),
    pytest.mark.skipif(not _kernel_installed(), reason=f"the {KERNEL_NAME!r} kernel (make setup) is absent"),
]


# -- the throw-away compendium ---------------------------------------------------------------------------------------


def _git(cwd: Path, *args: str) -> str:
    identity = ["-c", "user.name=test", "-c", "user.email=test@localhost", "-c", "commit.gpgsign=false"]
    return subprocess.run(["git", *identity, *args], cwd=cwd, capture_output=True, text=True, check=True).stdout


def _clone_working_tree(clone: Path) -> None:
    """A clone of the repository whose HEAD is the repository's working tree (tracked files, as they are now)."""
    subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
    for rel in _git(REPO, "ls-files", "-z").split("\0"):
        source = REPO / rel
        if rel and source.is_file() and not source.is_symlink():
            shutil.copy2(source, clone / rel)
    if _git(clone, "status", "--porcelain"):
        _git(clone, "commit", "-q", "-a", "-m", "the working tree of the repository under test")
    (clone / ".venv").symlink_to(REPO / ".venv")  # what `make setup` would build, shared


def _store(clone: Path, name: str) -> None:
    """`make store` on the clone's notebook, committed in the clone."""
    env = {k: v for k, v in os.environ.items() if k != "OCPKIT_OUTPUT_DIR"} | {"OCPKIT_ROOT": str(clone), **MAKE_ENV}
    cmd = [str(clone / ".venv" / "bin" / "python"), "-m", "compendium.notebooks", "store", f"notebooks/{name}"]
    proc = subprocess.run(cmd, cwd=clone, env=env, capture_output=True, text=True, timeout=RUN_TIMEOUT + 60)
    assert proc.returncode == 0, proc.stderr[-3000:]
    _git(clone, "add", "-A", "notebooks", "figures", "data")
    if _git(clone, "status", "--porcelain", "--", "notebooks", "figures", "data"):
        _git(clone, "commit", "-q", "-m", f"{name} stored on this machine")


# -- Chromium over the DevTools protocol -----------------------------------------------------------------------------


class _Browser:
    """Headless Chromium on one page, driven over the Chrome DevTools Protocol."""

    def __init__(self, profile: Path, log: Path):
        import websocket  # websocket-client, pinned in environment.txt (jupyter_server's dependency)

        profile.mkdir(parents=True, exist_ok=True)
        cmd = [
            _chromium(),
            *CHROMIUM_FLAGS,
            WINDOW,
            f"--user-data-dir={profile}",
            "--remote-debugging-port=0",
            "about:blank",
        ]
        self._log = log
        with open(log, "wb") as err:
            self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err)
        try:
            port = self._devtools_port(profile / "DevToolsActivePort")
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as response:
                page = next(t for t in json.loads(response.read()) if t["type"] == "page")
            # no Origin header: Chromium accepts the connection without --remote-allow-origins
            self.ws = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=60, suppress_origin=True)
        except BaseException:
            self.close()
            raise
        self._id = 0
        # a headless page has no focus of its own: without it Lab tracks no current widget for its commands
        self.call("Emulation.setFocusEmulationEnabled", enabled=True)

    def _devtools_port(self, active_port: Path, timeout: float = 30.0) -> int:
        """The port Chromium chose (``--remote-debugging-port=0``), from the file it writes in its profile."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                pytest.fail(f"Chromium exited with {self.proc.returncode}:\n{self._log.read_text(errors='replace')}")
            lines = active_port.read_text().splitlines() if active_port.is_file() else []
            if lines and lines[0].isdigit():
                return int(lines[0])
            time.sleep(0.1)
        pytest.fail(f"Chromium opened no DevTools port within {timeout} s:\n{self._log.read_text(errors='replace')}")

    def call(self, method: str, **params) -> dict:
        self._id += 1
        self.ws.send(json.dumps({"id": self._id, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == self._id:  # events (no id) are not subscribed to but may come
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg["result"]

    def js(self, expression: str):
        """The value of a JavaScript expression in the page (promises awaited)."""
        result = self.call("Runtime.evaluate", expression=expression, awaitPromise=True, returnByValue=True)
        if "exceptionDetails" in result:
            details = result["exceptionDetails"]
            raise RuntimeError(details.get("exception", {}).get("description") or details.get("text"))
        return result["result"].get("value")

    def poll(self, expression: str, timeout: float, what: str, interval: float = 0.25):
        """Evaluate ``expression`` until it gives ``{done: true, ...}``; that value, or a failure saying ``what``."""
        deadline, value = time.monotonic() + timeout, None
        while time.monotonic() < deadline:
            value = self.js(expression)
            if value and value.get("error"):
                pytest.fail(f"{what}: {value['error']}")
            if value and value.get("done"):
                return value
            time.sleep(interval)
        pytest.fail(f"{what}: not done within {timeout:.0f} s; last state {json.dumps(value)}")

    def close(self) -> None:
        ws = getattr(self, "ws", None)
        if ws is not None:
            ws.close()
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=10)


# -- JupyterLab, through the application object it exposes (--LabApp.expose_app_in_browser) ------------------------

# the notebook open in the main area once Lab has restored its layout, and the state of its kernel
_PANEL = """(async () => {
  const app = window.jupyterapp;
  if (!app) return {done: false, state: 'no jupyterapp yet'};
  await app.restored;
  const panel = Array.from(app.shell.widgets('main')).find(w => w.context && w.context.path === PATH);
  if (!panel || !panel.sessionContext || !panel.content || !panel.content.widgets) {
    return {done: false, state: 'no notebook panel yet'};
  }
  window.__roundtrip = {panel, inputs: 0};
  app.shell.activateById(panel.id);  // the tab a user clicked: the commands below act on it
  await panel.context.ready;
  await panel.sessionContext.ready;
  const kernel = panel.sessionContext.session && panel.sessionContext.session.kernel;
  const status = kernel ? kernel.status : 'no kernel';
  return {done: status === 'idle' && app.shell.currentWidget === panel, state: status, kernel: kernel && kernel.name,
          current: app.shell.currentWidget === panel, cells: panel.content.widgets.length};
})()"""

# counts the code cells the kernel starts (execute_input on iopub) from now on
_WATCH = """(() => {
  const panel = window.__roundtrip.panel;
  panel.sessionContext.iopubMessage.connect((_, msg) => {
    if (msg.header.msg_type === 'execute_input') window.__roundtrip.inputs += 1;
  });
  return true;
})()"""

# the restart dialog, accepted as a user would click it
_ACCEPT_DIALOG = """(() => {
  const dialog = document.querySelector('.jp-Dialog');
  if (!dialog) return {done: false, state: 'no dialog yet'};
  const accept = dialog.querySelector('.jp-Dialog-footer .jp-mod-accept');
  if (!accept) return {error: 'a dialog without an accept button: ' + dialog.innerText};
  const text = dialog.innerText;
  accept.click();
  return {done: true, text};
})()"""

# done when the kernel has started every code cell, none is queued or running and the kernel is idle
_PROGRESS = """(() => {
  const panel = window.__roundtrip.panel;
  const code = panel.content.widgets.filter(c => c.model.type === 'code');
  const kernel = panel.sessionContext.session && panel.sessionContext.session.kernel;
  const status = kernel ? kernel.status : 'no kernel';
  const prompts = code.map(c => (c.promptNode ? c.promptNode.textContent : '').trim());
  const busy = code.map((c, i) => c.model.executionState === 'running' || prompts[i].includes('*'));
  for (const [i, c] of code.entries()) {
    for (let j = 0; j < c.model.outputs.length; j++) {
      const out = c.model.outputs.get(j).toJSON();
      if (out.output_type === 'error') {
        return {error: `code cell ${i} raised ${out.ename}: ${out.evalue}\\n` + (out.traceback || []).join('\\n')
                       .replace(/\\x1b\\[[0-9;]*m/g, '').slice(-3000)};
      }
    }
  }
  if (status === 'dead') return {error: 'the kernel died'};
  const inputs = window.__roundtrip.inputs;
  const counts = code.map(c => c.model.executionCount);
  const idle = status === 'idle' && !busy.some(b => b);
  if (idle && inputs > 0 && inputs < code.length && counts.some(n => n === null)) {
    return {error: `run-all stopped after ${inputs} of ${code.length} code cells; prompts ${JSON.stringify(prompts)}`};
  }
  return {done: idle && inputs === code.length && counts.every(n => n !== null), kernel: status, inputs,
          code_cells: code.length, running: busy.filter(b => b).length, prompts};
})()"""

# the time the server last wrote the file, as Lab knows it
_LAST_MODIFIED = "window.__roundtrip.panel.context.contentsModel.last_modified"

# done when the server has written the notebook again (a newer last_modified) and nothing is left unsaved
_SAVED = """(() => {
  const panel = window.__roundtrip.panel;
  const dialog = document.querySelector('.jp-Dialog');
  if (dialog) return {error: 'a dialog opened on saving: ' + dialog.innerText};
  const written = panel.context.contentsModel.last_modified;
  return {done: written !== BEFORE && !panel.context.model.dirty, dirty: panel.context.model.dirty, written};
})()"""


def _lab_config(workdir: Path) -> Path:
    """A private Jupyter config folder: the application object exposed to the page, nothing of ~/.jupyter."""
    config = workdir / "config"
    config.mkdir()
    (config / "jupyter_lab_config.json").write_text(json.dumps({"LabApp": {"expose_app_in_browser": True}}))
    return config


@contextlib.contextmanager
def _lab_on(clone: Path, tmp_path: Path):
    """``(server, browser)``: `python -m compendium.lab` serving ``clone`` as a reader's `make lab` does, and headless
    Chromium; both stopped on exit."""
    workdir = Path(tempfile.mkdtemp(prefix="ocpkit-lab-"))  # short: IPC socket paths are limited to ~107 characters
    try:
        env = {"OCPKIT_ROOT": str(clone), "JUPYTER_CONFIG_DIR": str(_lab_config(workdir)), **MAKE_ENV}
        with _running_lab(workdir, env) as server:
            browser = _Browser(tmp_path / "profile", tmp_path / "chromium.log")
            try:
                yield server, browser
            finally:
                browser.close()
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


def _run_all(server, browser: _Browser, name: str) -> dict:
    """Open ``notebooks/<name>``, Restart Kernel and Run All Cells; timings of the steps."""
    timings, start = {}, time.monotonic()
    browser.call("Page.navigate", url=server.url(f"/lab/tree/notebooks/{name}"))
    panel = browser.poll(_PANEL.replace("PATH", json.dumps(f"notebooks/{name}")), PAGE_TIMEOUT, f"opening {name}")
    assert panel["kernel"] == KERNEL_NAME, panel
    timings["open"] = time.monotonic() - start
    browser.js(_WATCH)
    start = time.monotonic()
    browser.js("void window.jupyterapp.commands.execute('notebook:restart-run-all')")  # not awaited: the dialog
    dialog = browser.poll(_ACCEPT_DIALOG, 30, "the Restart Kernel dialog")
    assert "Restart" in dialog["text"], dialog
    browser.poll(_PROGRESS, RUN_TIMEOUT, f"Restart Kernel and Run All Cells of {name}", interval=0.5)
    timings["run"] = time.monotonic() - start
    return timings


def _run_all_and_save(server, browser: _Browser, name: str) -> dict:
    """Open ``notebooks/<name>``, Restart Kernel and Run All Cells, Save; timings of the steps."""
    timings = _run_all(server, browser, name)
    start = time.monotonic()
    before = browser.js(_LAST_MODIFIED)
    browser.js("void window.jupyterapp.commands.execute('docmanager:save')")  # not awaited: a dialog would block
    browser.poll(_SAVED.replace("BEFORE", json.dumps(before)), SAVE_TIMEOUT, f"saving {name}")
    timings["save"] = time.monotonic() - start
    return timings


# -- what changed ----------------------------------------------------------------------------------------------------


def _short(value, width: int = 110) -> str:
    text = value if isinstance(value, str) else json.dumps(value, sort_keys=True)
    return text if len(text) <= width else text[: width - 3] + "..."


def _text(value) -> str:
    return "".join(value) if isinstance(value, list) else value if isinstance(value, str) else json.dumps(value)


# run-to-run noise that hides what else differs on a line: its first difference beyond these is shown too
_NOISE = [
    (re.compile(r"\bT_[0-9a-f]{5}(?=[_\"])"), "pandas Styler's random table ids"),
    (re.compile(r"\b0x[0-9a-f]{6,}\b"), "memory addresses"),
]


def _masked(line: str) -> str:
    for pattern, _ in _NOISE:
        line = pattern.sub("#", line)
    return line


def _pair(x: str, y: str, width: int = 100) -> str:
    """Two differing lines, each cut to a window around their first difference."""
    k = next((i for i, (p, q) in enumerate(zip(x, y)) if p != q), min(len(x), len(y)))
    start = max(0, min(k - width // 3, max(len(x), len(y)) - width))
    cut = ("..." if start else "") + "{}" + "{}"
    return " -> ".join(
        repr(cut.format(s[start : start + width], "..." if len(s) > start + width else "")) for s in (x, y)
    )


def _first_difference(old: str, new: str) -> str:
    a, b = old.splitlines(), new.splitlines()
    pairs = [(i, x, y) for i, (x, y) in enumerate(zip(a, b)) if x != y]
    parts = [f"{len(a)} -> {len(b)} lines"] if len(a) != len(b) else []
    if pairs:
        i, x, y = pairs[0]
        parts.append(f"{len(pairs)} line(s) differ, first line {i + 1}: {_pair(x, y)}")
        beyond = [(i, x, y) for i, x, y in pairs if _masked(x) != _masked(y)]
        if not beyond:
            noise = sorted({label for p, label in _NOISE for _, x, _ in pairs if p.search(x)})
            parts.append(f"only {' and '.join(noise)}" if noise else "")
        elif beyond[0] != pairs[0]:
            i, x, y = beyond[0]
            parts.append(f"beyond ids and addresses first line {i + 1}: {_pair(x, y)}")
    elif len(a) != len(b):
        parts.append(f"first extra line: {_short((a[len(b) :] or b[len(a) :])[0])!r}")
    else:
        parts.append(f"line endings or trailing whitespace: {_short(old)!r} -> {_short(new)!r}")
    return "; ".join(p for p in parts if p)


def _dict_changes(old: dict, new: dict) -> list[str]:
    out = [f"+{k} = {_short(new[k], 80)}" for k in sorted(set(new) - set(old))]
    out += [f"-{k}" for k in sorted(set(old) - set(new))]
    out += [
        f"~{k}: {_short(old[k], 50)} -> {_short(new[k], 50)}" for k in sorted(set(old) & set(new)) if old[k] != new[k]
    ]
    return out


def _signature(out: dict) -> str:
    kind = out["output_type"]
    return f"stream:{out['name']}" if kind == "stream" else f"{kind}[{','.join(sorted(out.get('data', {})))}]"


def _merged_streams(outputs: list[dict]) -> list[dict]:
    """``outputs`` with each run of consecutive stream outputs of one name made one, as Lab's output model does."""
    merged: list[dict] = []
    for out in outputs:
        last = merged[-1] if merged else None
        if out["output_type"] == "stream" and last and last["output_type"] == "stream" and last["name"] == out["name"]:
            merged[-1] = {**last, "text": _text(last["text"]) + _text(out["text"])}
        else:
            merged.append(out)
    return merged


def _summary(out: dict) -> str:
    text = _text(out.get("text", out.get("data", {}).get("text/plain", "")))
    residue = out.get("name") == "stderr" and (not text.strip() or "\x1b[A" in text or re.search(r"\d+%\|", text))
    return f"{_signature(out)} {_short(text, 80)!r}" + (" (what a progress bar left)" if residue else "")


def _same_output_changes(i: int, a: dict, b: dict) -> list[str]:
    where, lines = f"output {i} {_signature(a)}", []
    if a["output_type"] == "stream" and _text(a["text"]) != _text(b["text"]):
        lines.append(f"{where}: {_first_difference(_text(a['text']), _text(b['text']))}")
    for mime in sorted(a.get("data", {})):
        x, y = a["data"][mime], b["data"][mime]
        if x == y:
            continue
        if mime.startswith("image/"):
            lines.append(f"{where} {mime}: the image differs ({len(_text(x))} -> {len(_text(y))} base64 chars)")
        else:
            lines.append(f"{where} {mime}: {_first_difference(_text(x), _text(y))}")
    for key in ("metadata", "execution_count"):
        if a.get(key) != b.get(key):
            lines.append(f"{where} {key}: {_short(a.get(key), 50)} -> {_short(b.get(key), 50)}")
    return lines


def _output_changes(old: list[dict], new: list[dict]) -> list[str]:
    lines = []
    merged = _merged_streams(old)
    if len(merged) < len(old) and len(merged) <= len(new) < len(old):
        lines.append(
            f"{len(old)} outputs -> {len(new)}: consecutive stream outputs merged into one (as Lab always does)"
        )
        old = merged
    matcher = difflib.SequenceMatcher(a=[_signature(o) for o in old], b=[_signature(o) for o in new], autojunk=False)
    for tag, i1, i2, j1, j2 in matcher.get_opcodes():
        if tag == "equal":
            for k in range(i2 - i1):
                lines += _same_output_changes(j1 + k, old[i1 + k], new[j1 + k])
            continue
        lines += [f"output {i1 + k} removed: {_summary(o)}" for k, o in enumerate(old[i1:i2])]
        lines += [f"output {j1 + k} added: {_summary(o)}" for k, o in enumerate(new[j1:j2])]
    return lines


def describe_changes(old_text: str, new_text: str) -> str:
    """Which cells and outputs of a notebook changed between two versions of its file, and how (concise)."""
    old, new = json.loads(old_text), json.loads(new_text)
    lines = []
    if old == new:
        diff = difflib.unified_diff(old_text.splitlines(), new_text.splitlines(), "stored", "saved", n=0, lineterm="")
        return "the same notebook, formatted differently:\n" + "\n".join(list(diff)[:12])
    for key in ("nbformat", "nbformat_minor"):
        if old.get(key) != new.get(key):
            lines.append(f"{key}: {old.get(key)} -> {new.get(key)}")
    lines += [f"notebook metadata {c}" for c in _dict_changes(old.get("metadata", {}), new.get("metadata", {}))]
    extra = _dict_changes(
        {k: v for k, v in old.items() if k not in ("cells", "metadata", "nbformat", "nbformat_minor")},
        {k: v for k, v in new.items() if k not in ("cells", "metadata", "nbformat", "nbformat_minor")},
    )
    lines += [f"notebook {c}" for c in extra]
    a_cells, b_cells = old.get("cells", []), new.get("cells", [])
    if len(a_cells) != len(b_cells):
        lines.append(f"{len(a_cells)} -> {len(b_cells)} cells")
    for i, (a, b) in enumerate(zip(a_cells, b_cells)):
        if a == b:
            continue
        first = _text(a.get("source", "")).strip().splitlines()
        label = f"cell {i} ({a['cell_type']}, {_short(first[0] if first else '', 50)!r})"
        changes = _dict_changes({k: v for k, v in a.items() if k not in ("outputs", "metadata")},
                                {k: v for k, v in b.items() if k not in ("outputs", "metadata")})  # fmt: skip
        changes += [f"metadata {c}" for c in _dict_changes(a.get("metadata", {}), b.get("metadata", {}))]
        changes += _output_changes(a.get("outputs", []), b.get("outputs", []))
        lines += [f"{label}:"] + [f"    {c}" for c in changes]
    return "\n".join(lines)


# -- the test --------------------------------------------------------------------------------------------------------


@needs_chromium  # under make test, a missing Chromium fails (OCPKIT_REQUIRE_BROWSER)
@pytest.mark.parametrize("name", NOTEBOOKS)
def test_restart_run_all_and_save_in_lab_leaves_the_stored_notebook_unchanged(name, tmp_path, monkeypatch):
    # a reader's `make lab`: outputs go to the run's own folder, progress bars to the server's terminal
    monkeypatch.delenv("OCPKIT_OUTPUT_DIR", raising=False)
    monkeypatch.delenv("OCPKIT_PROGRESS", raising=False)
    clone = tmp_path / "clone"
    _clone_working_tree(clone)
    path = clone / "notebooks" / name
    assert path.is_file(), f"no notebook {name} in the repository"
    if STORE_FIRST:
        _store(clone, name)
    stored = path.read_text()
    with _lab_on(clone, tmp_path) as (server, browser):
        timings = _run_all_and_save(server, browser, name)
    print(f"{name}: " + ", ".join(f"{step} {seconds:.1f} s" for step, seconds in timings.items()))
    status = _git(clone, "status", "--porcelain")  # the notebook and the published record; build/ is ignored
    if status:
        saved = path.read_text()
        shutil.copy(path, tmp_path / f"saved-{name}")  # kept by pytest's tmp_path for a closer look
        notebook = describe_changes(stored, saved) if saved != stored else f"{name} itself is unchanged"
        pytest.fail(
            f"Restart Kernel and Run All Cells, then Save, left `git status` not clean:\n{status}"
            f"{notebook}\n(saved copy: {tmp_path / f'saved-{name}'})",
            pytrace=False,
        )
