"""`python -m compendium.lab` (`make lab`): its command line, a real server, and JupyterLab in a headless browser.

The server tests start JupyterLab the way a user does (the module, extra arguments passed through) and talk to it
over its REST API and a kernel websocket; the browser tests load the Lab page in headless Chromium and read the DOM
it renders. Each part skips when what it needs (jupyterlab, the ``ocpkit`` kernel, websocket-client, a Chromium
binary) is absent, except that the browser tests fail without Chromium when OCPKIT_REQUIRE_BROWSER is set, as
`make unit` does. The whole module takes about 30 s.
"""

from __future__ import annotations

import base64
import contextlib
import importlib.util
import json
import os
import secrets
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.parse
import urllib.request
import uuid
from collections import Counter
from datetime import UTC, datetime
from html.parser import HTMLParser
from pathlib import Path

import pytest

from compendium import lab
from compendium.notebooks import KERNEL_NAME
from compendium.paths import notebooks_dir, repo_root

# -- lab_command ---------------------------------------------------------------------------------------------------


def _option(cmd: list[str], name: str) -> list[str]:
    """The values of ``--name=value`` options in ``cmd``."""
    return [arg.split("=", 1)[1] for arg in cmd if arg.startswith(f"{name}=")]


def test_lab_command_serves_the_repository_on_the_compendium_kernel(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)  # the working directory plays no part
    cmd = lab.lab_command()
    assert cmd[:3] == [sys.executable, "-m", "jupyterlab"]
    assert _option(cmd, "--ServerApp.root_dir") == [str(repo_root())]
    assert _option(cmd, "--LabApp.default_url") == ["/lab/tree/notebooks"]
    assert _option(cmd, "--MappingKernelManager.default_kernel_name") == [KERNEL_NAME] == ["ocpkit"]
    assert _option(cmd, "--KernelManager.transport") == ["ipc"]


@pytest.mark.parametrize(("euid", "allowed"), [(0, True), (1000, False)])
def test_allow_root_exactly_when_running_as_root(monkeypatch, euid, allowed):
    monkeypatch.setattr(lab.os, "geteuid", lambda: euid)
    assert ("--allow-root" in lab.lab_command()) is allowed
    assert lab.lab_command(["--allow-root"]).count("--allow-root") == 1


def test_extra_arguments_follow_and_replace_defaults_of_the_same_name(monkeypatch):
    monkeypatch.setattr(lab.os, "geteuid", lambda: 1000)
    extra = ["--no-browser", "--port", "8899", "--KernelManager.transport=tcp", "--LabApp.default_url=/lab"]
    cmd = lab.lab_command(extra)
    assert cmd[-len(extra) :] == extra  # passed through unchanged, in order, after the defaults
    assert _option(cmd, "--KernelManager.transport") == ["tcp"]
    assert _option(cmd, "--LabApp.default_url") == ["/lab"]
    # the defaults that were not overridden stay
    assert _option(cmd, "--ServerApp.root_dir") == [str(repo_root())]
    assert _option(cmd, "--MappingKernelManager.default_kernel_name") == [KERNEL_NAME]
    # the space-separated form names the option too
    spaced = lab.lab_command(["--KernelManager.transport", "tcp"])
    assert "--KernelManager.transport=ipc" not in spaced and spaced[-2:] == ["--KernelManager.transport", "tcp"]
    # Jupyter's alias of root_dir replaces it: two root_dir values stop the server ("only accepts one value")
    aliased = lab.lab_command(["--notebook-dir=/somewhere"])
    assert _option(aliased, "--ServerApp.root_dir") == [] and aliased[-1] == "--notebook-dir=/somewhere"


def test_lab_starts_with_the_news_off():
    """The "official Jupyter news" question is off (fetchNews "false"): a setting the installed JupyterLab has."""
    assert _option(lab.lab_command(), "--LabApp.app_settings_dir") == [str(lab.SETTINGS)]
    overrides = json.loads((lab.SETTINGS / "overrides.json").read_text())
    assert overrides == {
        "@jupyterlab/apputils-extension:notification": {"fetchNews": "false", "checkForUpdates": False}
    }
    schema = Path(sys.prefix, "share", "jupyter", "lab", "schemas", "@jupyterlab", "apputils-extension")
    properties = json.loads((schema / "notification.json").read_text())["properties"]
    assert "false" in [choice["const"] for choice in properties["fetchNews"]["oneOf"]]
    assert properties["checkForUpdates"]["type"] == "boolean"


class _Execd(Exception):
    pass


def test_main_execs_jupyterlab(monkeypatch):
    calls = []

    def execv(path, argv):  # the real one never returns: this one must not either
        calls.append((path, argv))
        raise _Execd

    monkeypatch.setattr(lab.os, "execv", execv)
    monkeypatch.setattr(lab.os, "name", "posix")
    monkeypatch.setattr(lab.subprocess, "call", lambda cmd: pytest.fail(f"JupyterLab started as a child: {cmd}"))
    with pytest.raises(_Execd):
        lab.main(["--no-browser"])
    assert calls == [(sys.executable, lab.lab_command(["--no-browser"]))]


# -- a real server -------------------------------------------------------------------------------------------------

HAVE_LAB = importlib.util.find_spec("jupyterlab") is not None


def _kernel_installed() -> bool:
    if not HAVE_LAB:
        return False
    from jupyter_client.kernelspec import KernelSpecManager

    return KERNEL_NAME in KernelSpecManager().find_kernel_specs()


needs_lab = pytest.mark.skipif(not HAVE_LAB, reason="jupyterlab is not installed")
needs_kernel = pytest.mark.skipif(not _kernel_installed(), reason=f"the {KERNEL_NAME!r} kernel (make setup) is absent")

STARTUP_TIMEOUT = 60.0


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class LabServer:
    def __init__(self, proc: subprocess.Popen, port: int, token: str, stderr: Path, runtime_dir: Path):
        self.proc, self.port, self.token, self.stderr_path, self.runtime_dir = proc, port, token, stderr, runtime_dir
        self.base = f"http://127.0.0.1:{port}"

    def url(self, path: str) -> str:
        """``path`` in a fresh workspace (``reset``: no tab of an earlier visit is restored), logged in."""
        return f"{self.base}{path}?reset&token={self.token}"

    def api(self, path: str, method: str = "GET", body: dict | None = None) -> dict | list:
        request = urllib.request.Request(
            f"{self.base}{path}",
            method=method,
            data=None if body is None else json.dumps(body).encode(),
            headers={"Authorization": f"token {self.token}", "Content-Type": "application/json"},
        )
        with urllib.request.urlopen(request, timeout=30) as response:
            return json.loads(response.read())

    def stderr(self) -> str:
        return self.stderr_path.read_text(errors="replace")


@contextlib.contextmanager
def _running_lab(workdir: Path, env_overrides: dict[str, str] | None = None):
    """`python -m compendium.lab` on a free port with a random token, stopped (SIGTERM, then SIGKILL) on exit."""
    port, token = _free_port(), secrets.token_hex(16)
    runtime_dir = workdir / "runtime"  # kept short: IPC socket paths are limited to ~107 characters
    runtime_dir.mkdir()
    env = {**os.environ, "JUPYTER_RUNTIME_DIR": str(runtime_dir), **(env_overrides or {})}
    cmd = [
        sys.executable,
        "-m",
        "compendium.lab",
        "--no-browser",
        f"--port={port}",
        f"--ServerApp.token={token}",
        "--ServerApp.open_browser=False",
        "--ServerApp.ip=127.0.0.1",
        "--ServerApp.port_retries=0",
        # Lab's state (open tabs, settings) stays out of the user's ~/.jupyter
        f"--LabApp.workspaces_dir={workdir / 'workspaces'}",
        f"--LabApp.user_settings_dir={workdir / 'settings'}",
    ]
    stdout_path, stderr_path = workdir / "server.out", workdir / "server.err"
    with open(stdout_path, "wb") as out, open(stderr_path, "wb") as err:
        # from a foreign working directory: the server finds the repository by itself
        proc = subprocess.Popen(cmd, cwd=workdir, env=env, stdout=out, stderr=err, stdin=subprocess.DEVNULL)
    server = LabServer(proc, port, token, stderr_path, runtime_dir)
    try:
        deadline = time.monotonic() + STARTUP_TIMEOUT
        while True:
            if proc.poll() is not None:
                pytest.fail(f"JupyterLab exited with {proc.returncode} while starting:\n{server.stderr()[-4000:]}")
            try:
                status = server.api("/api/status")
                break
            except (urllib.error.URLError, ConnectionError, OSError):
                if time.monotonic() > deadline:
                    pytest.fail(f"JupyterLab did not answer within {STARTUP_TIMEOUT} s:\n{server.stderr()[-4000:]}")
                time.sleep(0.25)
        assert "started" in status
        yield server
    finally:
        if proc.poll() is None:
            proc.terminate()  # SIGTERM: jupyter_server stops at once and shuts its kernels down
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=10)


@pytest.fixture(scope="module")
def lab_server():
    if not HAVE_LAB:
        pytest.skip("jupyterlab is not installed")
    workdir = Path(tempfile.mkdtemp(prefix="ocpkit-lab-"))
    try:
        with _running_lab(workdir) as server:
            yield server
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


@needs_lab
def test_server_serves_the_repository_root(lab_server):
    root = {item["name"]: item["type"] for item in lab_server.api("/api/contents/")["content"]}
    for folder in ("notebooks", "figures", "data"):
        assert root.get(folder) == "directory", sorted(root)
    notebooks = {item["name"] for item in lab_server.api("/api/contents/notebooks")["content"]}
    assert {p.name for p in notebooks_dir().glob("*.ipynb")} <= notebooks
    figures = [item for item in lab_server.api("/api/contents/figures")["content"] if item["name"].endswith(".png")]
    assert figures and len(figures) == len(list((repo_root() / "figures").glob("*.png")))
    assert all(item["mimetype"] == "image/png" for item in figures)


@needs_lab
def test_the_server_gives_lab_the_news_off(lab_server):
    settings = lab_server.api("/lab/api/settings/@jupyterlab/apputils-extension:notification")
    defaults = {name: p["default"] for name, p in settings["schema"]["properties"].items()}
    assert defaults["fetchNews"] == "false" and defaults["checkForUpdates"] is False


@needs_lab
@needs_kernel
def test_default_kernel_is_the_compendium_kernel(lab_server):
    specs = lab_server.api("/api/kernelspecs")
    assert specs["default"] == KERNEL_NAME
    assert specs["kernelspecs"][KERNEL_NAME]["spec"]["display_name"] == "Python (ocpkit)"


def _execute(server: LabServer, kernel_id: str, code: str, timeout: float = 60.0) -> tuple[str, dict]:
    """Run ``code`` on a kernel through the server's websocket (as Lab does); its stdout and execute_reply content."""
    import websocket  # websocket-client, pinned in environment.txt (jupyter_server's dependency)

    session = uuid.uuid4().hex
    ws = websocket.create_connection(
        f"ws://127.0.0.1:{server.port}/api/kernels/{kernel_id}/channels?session_id={session}",
        header=[f"Authorization: token {server.token}"],
        timeout=timeout,
    )
    try:
        msg_id = uuid.uuid4().hex
        header = {
            "msg_id": msg_id,
            "username": "test",
            "session": session,
            "msg_type": "execute_request",
            "version": "5.3",
            "date": datetime.now(UTC).isoformat(),
        }
        content = {"code": code, "silent": False, "store_history": False, "user_expressions": {}, "allow_stdin": False}
        ws.send(json.dumps({"header": header, "parent_header": {}, "metadata": {}, "content": content,
                            "channel": "shell", "buffers": []}))  # fmt: skip
        stdout, deadline = [], time.monotonic() + timeout
        while time.monotonic() < deadline:
            msg = json.loads(ws.recv())
            if msg.get("parent_header", {}).get("msg_id") != msg_id:
                continue
            if msg["msg_type"] == "stream" and msg["content"]["name"] == "stdout":
                stdout.append(msg["content"]["text"])
            elif msg["msg_type"] == "execute_reply":
                return "".join(stdout), msg["content"]
        raise TimeoutError(f"no execute_reply within {timeout} s")
    finally:
        ws.close()


@needs_lab
@needs_kernel
def test_notebook_session_starts_the_compendium_kernel_over_ipc(lab_server):
    pytest.importorskip("websocket", reason="websocket-client is not installed")
    session = lab_server.api(
        "/api/sessions",
        method="POST",
        body={"path": "notebooks/00_validation.ipynb", "type": "notebook", "name": "00_validation.ipynb", "kernel": {}},
    )
    kernel = session["kernel"]
    try:
        assert kernel["name"] == KERNEL_NAME  # no name given: the server's default
        # the kernel runs the compendium's environment, imports both packages and talks over Unix sockets
        code = "import json, sys, ocpkit, compendium; print(json.dumps([sys.prefix, ocpkit.__name__]))"
        stdout, reply = _execute(lab_server, kernel["id"], code)
        assert reply["status"] == "ok", reply
        prefix, name = json.loads(stdout)
        assert Path(prefix).resolve() == Path(sys.prefix).resolve() and name == "ocpkit"
        connection = json.loads((lab_server.runtime_dir / f"kernel-{kernel['id']}.json").read_text())
        assert connection["transport"] == "ipc"
        stderr = lab_server.stderr()
        assert "Running as root is not recommended" not in stderr
        assert "without encryption" not in stderr  # ipykernel's warning for a kernel on plain TCP
        assert lab_server.proc.poll() is None
    finally:
        request = urllib.request.Request(
            f"{lab_server.base}/api/sessions/{session['id']}",
            method="DELETE",
            headers={"Authorization": f"token {lab_server.token}"},
        )
        with contextlib.suppress(urllib.error.URLError):
            urllib.request.urlopen(request, timeout=30).close()


# -- JupyterLab in headless Chromium -------------------------------------------------------------------------------


def _chromium() -> str | None:
    found = shutil.which("chromium") or shutil.which("chromium-browser")
    if found:
        return found
    return "/usr/bin/chromium" if Path("/usr/bin/chromium").is_file() else None


NO_CHROMIUM = "no Chromium binary (chromium, chromium-browser)"
#: set by `make unit`: there a missing Chromium fails the browser tests, whose skip would pass CI unseen
REQUIRE_BROWSER = os.environ.get("OCPKIT_REQUIRE_BROWSER", "") not in {"", "0"}


def needs_chromium(test):
    """``test`` as it is with Chromium; without, skipped, or under OCPKIT_REQUIRE_BROWSER a test that fails at once."""
    if _chromium() is not None:
        return test
    if not REQUIRE_BROWSER:
        return pytest.mark.skip(reason=NO_CHROMIUM)(test)

    def fails():
        pytest.fail(f"{NO_CHROMIUM}, and OCPKIT_REQUIRE_BROWSER is set (make unit): `make chromium` installs it")

    fails.__name__, fails.__doc__ = test.__name__, test.__doc__
    return fails


#: the toast JupyterLab shows when its setting fetchNews is "none" (its default)
NEWS_QUESTION = "Would you like to get notified about official Jupyter news?"

#: virtual (not wall-clock) milliseconds Chromium lets the page run before dumping it; Lab renders in ~5 s of real time
VIRTUAL_TIME_BUDGET = 30000


class _Dom(HTMLParser):
    """Class counts, <img> sources inside rendered-image outputs, <h1> texts and the <title> of a dumped DOM."""

    def __init__(self, html: str):
        super().__init__()
        self.html = html
        self.classes: Counter[str] = Counter()
        self.output_images: list[str] = []
        self.h1: list[str] = []
        self.title = ""
        self._stack: list[tuple[str, set[str]]] = []
        self._text: list[str] | None = None
        self._in_title = False
        self.feed(html)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        classes = set((attrs.get("class") or "").split())
        self.classes.update(classes)
        if tag == "img" and any("jp-RenderedImage" in c for _, c in self._stack):
            self.output_images.append(attrs.get("src") or "")
        if tag == "h1":
            self._text = []
        self._in_title = tag == "title"
        if tag not in {"img", "br", "hr", "input", "meta", "link"}:
            self._stack.append((tag, classes))

    def handle_endtag(self, tag):
        if tag == "h1" and self._text is not None:
            self.h1.append("".join(self._text).strip().removesuffix("¶").strip())  # Lab's anchor link
            self._text = None
        self._in_title = False
        for i in range(len(self._stack) - 1, -1, -1):
            if self._stack[i][0] == tag:
                del self._stack[i:]
                break

    def handle_data(self, data):
        if self._text is not None:
            self._text.append(data)
        if self._in_title:
            self.title += data


#: Headless Chromium as every browser test starts it (test_lab_roundtrip too)
CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",  # root in a container
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def _dump_dom(url: str, profile: Path) -> _Dom:
    cmd = [
        _chromium(),
        *CHROMIUM_FLAGS,
        f"--user-data-dir={profile}",
        f"--virtual-time-budget={VIRTUAL_TIME_BUDGET}",
        "--dump-dom",
        url,
    ]
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    assert result.returncode == 0, result.stderr[-3000:]
    return _Dom(result.stdout)


def _stored(path: Path) -> dict:
    return json.loads(path.read_text())


def _png_outputs(nb: dict) -> int:
    return sum("image/png" in out.get("data", {}) for cell in nb["cells"] for out in cell.get("outputs", []))


def _first_heading(nb: dict) -> str:
    for cell in nb["cells"]:
        if cell["cell_type"] == "markdown":
            for line in "".join(cell["source"]).splitlines():
                if line.startswith("# "):
                    return line[2:].strip()
    raise AssertionError("the notebook has no level-1 heading")


def _assert_notebook_open(dom: _Dom, nb: dict) -> None:
    assert dom.classes["jp-LabShell"] == 1, "JupyterLab's shell did not render"
    assert dom.classes["jp-NotebookPanel"] >= 1, "no notebook panel opened"
    assert dom.classes["jp-Notebook-cell"] == len(nb["cells"]), (dom.classes["jp-Notebook-cell"], len(nb["cells"]))
    assert _first_heading(nb) in dom.h1, dom.h1


@needs_lab
@needs_chromium
def test_lab_opens_a_notebook_in_a_browser(lab_server, tmp_path):
    name = "02_two_timescale.ipynb"
    dom = _dump_dom(lab_server.url(f"/lab/tree/notebooks/{name}"), tmp_path / "profile")
    nb = _stored(notebooks_dir() / name)
    _assert_notebook_open(dom, nb)
    assert len(dom.output_images) == _png_outputs(nb)  # its stored figures, if it has any yet
    assert dom.title.startswith(name[:10]) and dom.title.endswith("JupyterLab"), dom.title
    assert dom.classes["jp-DirListing-item"] >= len(list(notebooks_dir().glob("*.ipynb")))  # the notebooks folder
    assert NEWS_QUESTION not in dom.html, "JupyterLab asks about its news feed (a toast over the notebook)"


@needs_lab
@needs_chromium
def test_lab_shows_the_stored_figures_of_the_notebooks(lab_server, tmp_path):
    with_images = [(p, _png_outputs(_stored(p))) for p in sorted(notebooks_dir().glob("*.ipynb"))]
    with_images = [(p, n) for p, n in with_images if n]
    if not with_images:
        pytest.skip("no stored notebook carries image/png outputs yet (see test_lab_renders_png_outputs)")
    path, count = min(with_images, key=lambda pn: pn[0].stat().st_size)  # the lightest page to render
    dom = _dump_dom(lab_server.url(f"/lab/tree/notebooks/{path.name}"), tmp_path / "profile")
    _assert_notebook_open(dom, _stored(path))
    assert len(dom.output_images) == count, (path.name, len(dom.output_images), count)
    assert all(src.startswith("data:image/png;base64,") for src in dom.output_images)


def _tiny_png() -> str:
    """A 4 x 3 PNG written by matplotlib (the way the notebooks' figures reach their outputs), base64-encoded."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(0.04, 0.03), dpi=100)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    plt.close(fig)
    return base64.b64encode(buffer.getvalue()).decode()


@needs_lab
@needs_chromium
def test_lab_renders_png_outputs(tmp_path):
    """Whatever the stored notebooks hold today: Lab started by compendium.lab shows a PNG output as an image.

    A throw-away compendium (``OCPKIT_ROOT``: a data/ folder and one notebook with two PNG outputs) is served.
    """
    import nbformat

    root = tmp_path / "compendium"
    (root / "data").mkdir(parents=True)
    (root / "notebooks").mkdir()
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": KERNEL_NAME, "display_name": "Python (ocpkit)", "language": "python"}
    nb.cells.append(nbformat.v4.new_markdown_cell("# PNG outputs"))
    for i in (1, 2):
        cell = nbformat.v4.new_code_cell(f"figure_{i}", execution_count=i)
        cell.outputs = [nbformat.v4.new_output("display_data", data={"image/png": _tiny_png(), "text/plain": "<Fig>"})]
        nb.cells.append(cell)
    nbformat.write(nb, str(root / "notebooks" / "images.ipynb"))
    workdir = Path(tempfile.mkdtemp(prefix="ocpkit-lab-"))
    try:
        with _running_lab(workdir, {"OCPKIT_ROOT": str(root)}) as server:
            listing = {item["name"] for item in server.api("/api/contents/")["content"]}
            assert listing == {"data", "notebooks"}  # OCPKIT_ROOT is the root served
            dom = _dump_dom(server.url("/lab/tree/notebooks/images.ipynb"), tmp_path / "profile")
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    _assert_notebook_open(dom, _stored(root / "notebooks" / "images.ipynb"))
    assert dom.classes["jp-RenderedImage"] == 2
    assert len(dom.output_images) == 2 and all(s.startswith("data:image/png;base64,") for s in dom.output_images)
