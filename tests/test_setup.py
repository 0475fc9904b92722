"""`make setup` and `make chromium`, run for real on copies of the Makefile in temporary folders, and
src/compendium/bootstrap.py (the steps of `make setup`) imported from its file.

The interpreter check meets fake interpreters (scripts that report another version, or no ensurepip), and real old
ones where installed; the steps after it meet a fake interpreter whose `-m venv` makes a fake .venv whose python
answers each step (and fails the one a test names), and once a real venv whose pip finds no uv offline; this
environment's uv fails for real on a pin it cannot find. uv's output folding is fed samples of uv's output directly.
Nothing here uses the network except the pin resolution test, which runs only with OCPKIT_NETWORK_TESTS=1. About
15 s in all, most of it the real venv.
"""

from __future__ import annotations

import ast
import importlib.metadata
import importlib.util
import io
import json
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from packaging.specifiers import SpecifierSet
from packaging.utils import canonicalize_name
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]
BOOTSTRAP = ROOT / "src" / "compendium" / "bootstrap.py"
MAKE = shutil.which("make")
PYTHON_MIN = re.search(r"^PYTHON_MIN := (\S+)$", (ROOT / "Makefile").read_text(), flags=re.M).group(1)
RUNNING = ".".join(str(part) for part in sys.version_info[:3])


def _script(path: Path, body: str) -> Path:
    """An executable ``path`` that runs the Python ``body`` (kept beside it) with this interpreter."""
    path.with_suffix(".py").write_text(body)
    path.write_text(f'#!/bin/sh\nexec {shlex.quote(sys.executable)} {shlex.quote(str(path.with_suffix(".py")))} "$@"\n')
    path.chmod(0o755)
    return path


#: the installer's pin, as environment.txt gives it (make setup installs it first, then the pins with it)
UV_PIN = next(
    line.split()[0] for line in (ROOT / "environment.txt").read_text().splitlines() if line.startswith("uv==")
)


def _project(
    tmp_path: Path, pins: str = f"# left out: rfc3987-syntax lark\nnumpy==2.4.6\nscipy==1.17.1\n{UV_PIN}\n"
) -> Path:
    """A folder with the Makefile and what its setup rule reads and runs."""
    project = tmp_path / "project"
    (project / BOOTSTRAP.parent.relative_to(ROOT)).mkdir(parents=True)
    shutil.copy(ROOT / "Makefile", project)
    shutil.copy(ROOT / "pyproject.toml", project)
    shutil.copy(BOOTSTRAP, project / BOOTSTRAP.relative_to(ROOT))
    (project / "environment.txt").write_text(pins)
    return project


def _env(tmp_path: Path, **extra: str) -> dict[str, str]:
    """This environment without what an enclosing make passes down, with a pip that looks at nothing but an empty
    folder (no configuration files, no index)."""
    drop = {"MAKEFLAGS", "MFLAGS", "MAKELEVEL", "MAKEOVERRIDES", "OCPKIT_REQUIRE_BROWSER"}
    env = {k: v for k, v in os.environ.items() if k not in drop and not k.startswith("PIP_")}
    (tmp_path / "no-wheels").mkdir(exist_ok=True)
    env |= {"PIP_CONFIG_FILE": os.devnull, "PIP_NO_INDEX": "1", "PIP_FIND_LINKS": str(tmp_path / "no-wheels")}
    return env | extra


def _make(project: Path, *args: str, env: dict[str, str], timeout: float = 120) -> subprocess.CompletedProcess:
    if MAKE is None:
        pytest.skip("no make")
    return subprocess.run(
        [MAKE, *args], cwd=project, env=env, capture_output=True, text=True, timeout=timeout, stdin=subprocess.DEVNULL
    )


def _listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


# -- the interpreter check ------------------------------------------------------------------------------------------


def _fake_python(tmp_path: Path, version: str, ensurepip: bool = True) -> Path:
    """A `python` that says it is ``version`` (and lacks ensurepip, if so asked) to the code it is given with -c."""
    parts = tuple(int(p) for p in version.split("."))
    folder = tmp_path / "fakes"
    folder.mkdir(exist_ok=True)
    path = folder / f"python{parts[0]}.{parts[1]}"
    return _script(
        path,
        f"""import sys
sys.version_info = {(*parts, "final", 0)!r}
sys.executable = {str(path)!r}
if not {ensurepip!r}:
    sys.modules["ensurepip"] = None  # as on Debian without python3-venv: import ensurepip fails
if sys.argv[1:2] != ["-c"]:
    sys.exit("fake python {version}: only -c was expected before the check passes, not %r" % sys.argv[1:])
code, sys.argv = sys.argv[2], ["-c", *sys.argv[3:]]
exec(compile(code, "<string>", "exec"), {{"__name__": "__main__"}})
""",
    )


def _older_and_newer() -> list[str]:
    major, minor, micro = (int(p) for p in PYTHON_MIN.split("."))
    versions = ["2.7.18", f"{major}.{minor - 1}.14", f"{major}.{minor + 1}.1"]
    return versions + ([f"{major}.{minor}.{micro - 1}"] if micro else [])


@pytest.mark.parametrize("version", _older_and_newer())
def test_setup_refuses_another_python_before_creating_anything(tmp_path, version):
    project = _project(tmp_path)
    before = _listing(project)
    fake = _fake_python(tmp_path, version)
    result = _make(project, "setup", f"PYTHON={fake}", env=_env(tmp_path))
    assert result.returncode != 0
    message = result.stderr
    series = PYTHON_MIN.rsplit(".", 1)[0]
    assert f"PYTHON={fake} is Python {version} ({fake})" in message, message  # what was found, and where
    assert f"needs Python {series} ({PYTHON_MIN} or a later {series} release)" in message, message
    assert f"make setup PYTHON=python{series}" in message, message  # how to name another
    assert "setup [2/5]" not in result.stdout
    assert _listing(project) == before  # nothing created, .venv least of all


def test_setup_refuses_a_python_that_cannot_make_a_venv_with_pip(tmp_path):
    project = _project(tmp_path)
    fake = _fake_python(tmp_path, RUNNING, ensurepip=False)
    result = _make(project, "setup", f"PYTHON={fake}", env=_env(tmp_path))
    assert result.returncode != 0
    assert f"PYTHON={fake} is Python {RUNNING} ({fake})" in result.stderr, result.stderr
    assert "cannot create a virtual environment with pip" in result.stderr
    assert "apt-get install python3-venv" in result.stderr  # the Debian package that brings ensurepip
    assert not (project / ".venv").exists()


def test_setup_names_an_interpreter_that_is_not_there(tmp_path):
    project = _project(tmp_path)
    result = _make(project, "setup", "PYTHON=python3.11-not-installed-here", env=_env(tmp_path))
    assert result.returncode != 0
    assert "PYTHON=python3.11-not-installed-here is neither a command on PATH nor an executable file" in result.stderr
    assert "make setup PYTHON=python3.11" in result.stderr
    assert not (project / ".venv").exists()


def _real_python(series: str) -> str | None:
    """An installed python``series`` that runs (on PATH, else a pyenv version), or None."""
    pyenv = Path(os.environ.get("PYENV_ROOT", Path.home() / ".pyenv"))
    candidates = [shutil.which(f"python{series}"), *sorted(pyenv.glob(f"versions/{series}.*/bin/python{series}"))]
    for candidate in filter(None, candidates):
        if subprocess.run([candidate, "-c", "pass"], capture_output=True, timeout=30).returncode == 0:  # no idle shim
            return str(candidate)
    return None


@pytest.mark.parametrize("series", ["2.7", "3.10"])
def test_setup_tells_a_real_old_python_so(tmp_path, series):
    """CHECK_PYTHON is parsed and run by the old interpreter itself: its message, not a SyntaxError."""
    python = _real_python(series)
    if python is None:
        pytest.skip(f"no python{series} installed")
    project = _project(tmp_path)
    result = _make(project, "setup", f"PYTHON={python}", env=_env(tmp_path))
    assert result.returncode != 0
    assert re.search(rf"PYTHON={re.escape(python)} is Python {series}\.\d+ \(", result.stderr), result.stderr
    assert f"needs Python {PYTHON_MIN.rsplit('.', 1)[0]} ({PYTHON_MIN} or a later" in result.stderr
    assert "SyntaxError" not in result.stderr and "could not run the interpreter check" not in result.stderr
    assert not (project / ".venv").exists()


def test_setup_takes_the_running_python_and_a_failed_install_leaves_no_venv(tmp_path):
    """The real thing up to the installer: the check passes this interpreter, venv makes .venv, and its pip (offline)
    finds no uv to install the pins with."""
    project = _project(tmp_path, pins=f"ocpkit-no-such-package==0.0.0\n{UV_PIN}\n")
    result = _make(project, "setup", f"PYTHON={sys.executable}", env=_env(tmp_path))
    assert f"PYTHON={sys.executable} is Python {RUNNING} (" in result.stdout, result.stdout + result.stderr
    assert "setup [2/5] creating .venv" in result.stdout and "setup [3/5] installing the 2 packages" in result.stdout
    assert result.returncode != 0
    assert f"No matching distribution found for {UV_PIN}" in result.stdout + result.stderr  # pip's own words
    assert "setup: [3/5] installing environment.txt failed; .venv removed" in result.stderr, result.stderr
    assert not (project / ".venv").exists()
    assert "setup [4/5]" not in result.stdout


def test_uv_s_own_failure_reaches_the_reader_through_the_fold(bootstrap, tmp_path):
    """The installer for real (this environment's uv), offline and told where to look as pip would be: a pin it
    cannot find is named in uv's own words, and nothing is said to be installed."""
    target = tmp_path / "target"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(target)], check=True)
    pins = tmp_path / "environment.txt"
    pins.write_text("ocpkit-no-such-package==0.0.0\n")
    sources = bootstrap.pip_sources(_env(tmp_path))
    assert sources == ["--find-links", str(tmp_path / "no-wheels"), "--no-index"]
    command = [sys.executable, "-m", "uv", "pip", "install", "--python", str(target / "bin" / "python"), *sources]
    done = subprocess.run([*command, "-r", str(pins)], capture_output=True, text=True, timeout=60, env=_env(tmp_path))
    assert done.returncode != 0
    out = io.StringIO()
    log = bootstrap.UvLog(1, out, tty=False)
    for line in (done.stdout + done.stderr).splitlines():
        log.feed(line)
    log.close()
    assert "ocpkit-no-such-package" in out.getvalue() and "error" in out.getvalue(), out.getvalue()
    assert "installed in" not in out.getvalue()


def test_setup_names_an_environment_txt_without_the_installer_s_pin(tmp_path):
    project = _project(tmp_path, pins="numpy==2.4.6\n")
    result = _make(project, "setup", f"PYTHON={sys.executable}", env=_env(tmp_path))
    assert result.returncode != 0 and not (project / ".venv").exists()
    assert "environment.txt pins no uv (a line uv==VERSION): setup installs with it" in result.stderr, result.stderr


# -- the steps after it, on a fake venv -----------------------------------------------------------------------------

#: what each step the fake venv can fail is called in setup's message (the .pth is written in step 4)
STEPS = {
    "uv": "[3/5] installing environment.txt",
    "pins": "[3/5] installing environment.txt",
    "ocpkit": "[4/5] installing ocpkit",
    "pth": "[4/5] installing ocpkit",
    "kernel": "[5/5] registering the Jupyter kernel ocpkit",
}

FAKE_VENV_PYTHON = """import json, os, sys, time
args = sys.argv[1:]
with open(os.path.join(os.environ["FAKE_PROJECT"], "calls.jsonl"), "a") as log:
    log.write(json.dumps(args if args[:1] != ["-c"] else ["-c", "..."]) + "\\n")
if args[:3] == ["-m", "pip", "install"]:
    step = "uv" if any(a.startswith("uv==") for a in args) else "ocpkit"
elif args[:4] == ["-m", "uv", "pip", "install"]:
    step = "pins"
else:
    step = "kernel" if args[:3] == ["-m", "ipykernel", "install"] else "pth" if args[:1] == ["-c"] else "unknown"
if step == "pins":  # what uv 0.13 prints, shortened
    pins = [line.split()[0] for line in open("environment.txt") if line[:1].isalnum()]
    print("Using Python 3.11.7 environment at: .venv")
    print("Resolved %d packages in 12ms" % len(pins), flush=True)
    for pin in pins:
        print("Downloading %s (12.5MiB)" % pin.split("==")[0], flush=True)
        if os.environ.get("FAKE_HANG") == "pins":
            time.sleep(60)
    for pin in pins:
        print(" Downloaded %s" % pin.split("==")[0])
    print("Prepared %d packages in 1.2s" % len(pins))
    print("Installed %d packages in 8ms" % len(pins))
    print("Bytecode compiled 12 files in 1.0s")
    for pin in pins:
        print(" + %s" % pin, flush=True)
if step == os.environ.get("FAKE_FAIL") or step == "unknown":
    sys.exit("ERROR: fake %s step failed (%r)" % (step, args))
"""

#: `-m venv` makes a fake .venv; `-c` (the check) and `-P bootstrap.py` run on this interpreter, the latter with
#: sys.executable this fake, so that bootstrap.py's `sys.executable -m venv` comes back here
FAKE_BASE_PYTHON = """import os, runpy, sys
args = sys.argv[1:]
if args[:2] == ["-m", "venv"]:
    venv = os.path.abspath(args[2])
    os.makedirs(os.path.join(venv, "bin"))
    open(os.path.join(venv, "pyvenv.cfg"), "w").write("home = fake\\n")
    python = os.path.join(venv, "bin", "python")
    open(python + ".py", "w").write("REAL = %r\\n" % REAL + os.environ["FAKE_VENV_PYTHON"])
    open(python, "w").write("#!/bin/sh\\nexec %s %s \\"$@\\"\\n" % (REAL, python + ".py"))
    os.chmod(python, 0o755)
elif args[:1] == ["-c"]:
    os.execv(REAL, [REAL, *args])  # the interpreter check: this one passes
elif args[:1] == ["-P"] and args[1].endswith("bootstrap.py"):
    sys.executable, sys.argv = FAKE, args[1:]
    runpy.run_path(args[1], run_name="__main__")
else:
    sys.exit("fake base python: unexpected %r" % args)
"""


@pytest.fixture
def fake_setup(tmp_path):
    """(project, run): run(fail=step, **env) runs `make setup` on a fake base python; returns the result.
    run.popen(**env) starts it in a process group of its own, as a terminal's foreground job."""
    project = _project(tmp_path)
    (tmp_path / "fakes").mkdir()
    base = tmp_path / "fakes" / "python3.11"
    _script(base, f"REAL = {sys.executable!r}\nFAKE = {str(base)!r}\n" + FAKE_BASE_PYTHON)

    def env(fail: str = "", **extra: str) -> dict[str, str]:
        (project / "calls.jsonl").unlink(missing_ok=True)
        return _env(tmp_path, FAKE_PROJECT=str(project), FAKE_VENV_PYTHON=FAKE_VENV_PYTHON, FAKE_FAIL=fail, **extra)

    def run(fail: str = "", **extra: str) -> subprocess.CompletedProcess:
        return _make(project, "setup", f"PYTHON={base}", env=env(fail, **extra))

    def popen(**extra: str) -> subprocess.Popen:
        if MAKE is None:
            pytest.skip("no make")
        return subprocess.Popen(
            [MAKE, "setup", f"PYTHON={base}"],
            cwd=project,
            env=env(**extra),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            start_new_session=True,
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        )

    run.popen = popen
    return project, run


def _calls(project: Path) -> list[list[str]]:
    return [json.loads(line) for line in (project / "calls.jsonl").read_text().splitlines()]


def _make_older(path: Path, than: Path) -> None:
    past = than.stat().st_mtime - 100
    os.utime(path, (past, past))


def _working_venv(project: Path) -> Path:
    """A .venv as an earlier setup left it (the stamp is all the setup looks at), with a file of the user's in it;
    environment.txt changed since."""
    venv = project / ".venv"
    venv.mkdir()
    (venv / ".installed").write_text("")
    (venv / "mine").write_text("a working environment")
    _make_older(venv / ".installed", than=project / "environment.txt")  # environment.txt changed since
    _make_older(project / "pyproject.toml", than=venv / ".installed")  # pyproject.toml did not
    return venv


def test_setup_runs_its_steps_in_order_with_progress_and_stamps_the_venv(fake_setup):
    project, run = fake_setup
    result = run()
    assert result.returncode == 0, result.stdout + result.stderr
    out = result.stdout
    lines = [line for line in out.splitlines() if line.startswith("setup [")]
    assert [line[:11] for line in lines] == [f"setup [{i}/5]" for i in range(1, 6)], out
    # uv's log folded to the resolution, the large downloads and a summary; its other lines gone
    assert "  resolved 3 packages\n  downloading numpy (12.5 MiB)\n  downloading scipy (12.5 MiB)\n" in out, out
    assert re.search(r"  3 packages installed in \d+ s \(3 large downloads, 38 MiB\)", out), out
    assert "Using Python" not in out and " + numpy" not in out and "Bytecode" not in out
    assert re.search(r"setup: done in \d+ s", out)
    calls = _calls(project)
    assert calls[0][:3] == ["-m", "pip", "install"] and calls[0][-1] == UV_PIN  # the installer, at its pin
    assert calls[1][:4] == ["-m", "uv", "pip", "install"] and calls[1][-2:] == ["-r", "environment.txt"]
    assert {"--compile-bytecode", "--no-index"} <= set(calls[1]), calls[1]  # as pip compiles; pip's offline, kept
    assert calls[1][calls[1].index("--python") + 1] == ".venv/bin/python"  # the new environment, not uv's own
    excludes = project / calls[1][calls[1].index("--excludes") + 1]  # environment.txt's line "# left out:"
    assert excludes == project / ".venv" / "left-out.txt" and excludes.read_text() == "rfc3987-syntax\nlark\n"
    assert calls[2][:3] == ["-m", "pip", "install"] and calls[2][-2:] == ["-e", "."] and "--no-deps" in calls[2]
    assert calls[3] == ["-c", "..."]  # compendium.pth
    assert calls[4][:4] == ["-m", "ipykernel", "install", "--sys-prefix"] and "ocpkit" in calls[4]
    assert calls[4][-2:] == ["--display-name", "Python (ocpkit)"]
    env = {calls[4][i + 1]: calls[4][i + 2] for i, a in enumerate(calls[4]) if a == "--env"}
    assert env == {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}, calls[4]  # the kernel's threads
    assert (project / ".venv" / ".installed").is_file()
    assert not (project / ".venv.previous").exists()
    again = run()  # up to date: nothing to do
    assert again.returncode == 0 and "setup [" not in again.stdout and not (project / "calls.jsonl").exists()


@pytest.mark.parametrize("step", STEPS)
def test_a_failed_step_leaves_no_venv(fake_setup, step):
    project, run = fake_setup
    result = run(fail=step)
    assert result.returncode != 0
    assert f"setup: {STEPS[step]} failed; .venv removed, so that nothing half-made is left" in result.stderr, (
        result.stdout + result.stderr
    )
    assert not (project / ".venv").exists() and not (project / ".venv.previous").exists()


def test_a_failed_rebuild_gives_back_the_previous_environment_unchanged(fake_setup):
    project, run = fake_setup
    venv = _working_venv(project)
    result = run(fail="ocpkit")
    assert result.returncode != 0
    assert "environment.txt changed since the last setup: .venv is rebuilt from scratch" in result.stdout
    assert (
        "setup: [4/5] installing ocpkit failed; .venv is the environment of the last setup again, unchanged "
        "(older than environment.txt, so the next make tries again)"
    ) in result.stderr, result.stderr
    assert (venv / "mine").read_text() == "a working environment" and not (project / ".venv.previous").exists()
    # its stamp is still older than environment.txt: the next make tries again, and a rebuild that works replaces it
    assert (venv / ".installed").stat().st_mtime < (project / "environment.txt").stat().st_mtime
    assert run().returncode == 0
    assert not (venv / "mine").exists() and not (project / ".venv.previous").exists()
    assert (venv / ".installed").stat().st_mtime >= (project / "environment.txt").stat().st_mtime


def test_a_venv_without_the_stamp_is_not_reused(fake_setup):
    project, run = fake_setup
    (project / ".venv" / "bin").mkdir(parents=True)
    (project / ".venv" / "half-made").write_text("")
    result = run()
    assert result.returncode == 0, result.stderr
    assert ".venv has no stamp (.venv/.installed): a setup that did not finish left it; removing it" in result.stdout
    assert not (project / ".venv" / "half-made").exists()


def test_a_rebuild_killed_outright_is_undone_first(fake_setup):
    project, run = fake_setup
    previous = project / ".venv.previous"
    previous.mkdir()
    (previous / ".installed").write_text("")
    (previous / "mine").write_text("a working environment")
    _make_older(previous / ".installed", than=project / "environment.txt")
    (project / ".venv").mkdir()  # what the killed rebuild had made
    result = run(fail="pins")
    assert ".venv.previous is the environment of a rebuild that was killed: it becomes .venv again" in result.stdout
    assert result.returncode != 0
    assert (project / ".venv" / "mine").is_file() and not previous.exists()


def test_a_previous_venv_without_its_stamp_is_what_is_left_of_a_removal(fake_setup):
    """A setup that worked removes .venv.previous's stamp, then the rest: killed in between, it leaves no
    environment to restore, only files to remove."""
    project, run = fake_setup
    venv = _working_venv(project)
    previous = project / ".venv.previous"
    (previous / "lib").mkdir(parents=True)
    result = run()
    assert result.returncode == 0, result.stdout + result.stderr
    assert ".venv.previous is what is left of an environment whose removal was cut short: removing it" in result.stdout
    assert not previous.exists() and not (venv / "mine").exists() and (venv / ".installed").is_file()


def _interrupt(proc: subprocess.Popen, how: str) -> str:
    """Once uv is at its first download (where the fake sleeps), Ctrl-C as a terminal sends it (SIGINT to make and
    everything under it), or `kill` of make alone (SIGTERM, which make passes on to its recipe): make's output."""
    try:
        seen = ""
        while "downloading numpy" not in seen:  # where the fake uv sleeps
            line = proc.stdout.readline()
            assert line, seen
            seen += line
        time.sleep(0.1)
        if how == "ctrl-c":
            os.killpg(proc.pid, signal.SIGINT)
        else:
            os.kill(proc.pid, signal.SIGTERM)
        rest, _ = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    return seen + rest


def test_an_interrupted_setup_leaves_no_venv(fake_setup):
    """Ctrl-C during uv, on a first setup."""
    project, run = fake_setup
    proc = run.popen(FAKE_HANG="pins")
    out = _interrupt(proc, "ctrl-c")
    assert proc.returncode != 0
    assert "setup: [3/5] installing environment.txt interrupted; .venv removed" in out, out
    assert not (project / ".venv").exists() and not (project / ".venv.previous").exists()


@pytest.mark.parametrize("how", ["ctrl-c", "kill"])
def test_an_interrupted_rebuild_gives_back_the_previous_environment(fake_setup, how):
    """Ctrl-C, or kill, during uv, on a rebuild: the environment set aside comes back."""
    project, run = fake_setup
    venv = _working_venv(project)
    stamped = (venv / ".installed").stat().st_mtime
    proc = run.popen(FAKE_HANG="pins")
    out = _interrupt(proc, how)
    assert proc.returncode != 0
    assert (
        "setup: [3/5] installing environment.txt interrupted; .venv is the environment of the last setup again"
    ) in out, out
    assert (venv / "mine").read_text() == "a working environment" and not (project / ".venv.previous").exists()
    assert (venv / ".installed").stat().st_mtime == stamped  # so the next make tries again


# -- bootstrap.py, imported from its file ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def bootstrap():
    """The module, from its file (as `make setup` runs it: not as part of the compendium package)."""
    spec = importlib.util.spec_from_file_location("bootstrap_under_test", BOOTSTRAP)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # for its dataclasses
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        del sys.modules[spec.name]


def test_bootstrap_imports_the_standard_library_only():
    """It runs before the environment exists: nothing from it, and not the compendium package it sits in."""
    imported = set()
    for node in ast.walk(ast.parse(BOOTSTRAP.read_text())):
        if isinstance(node, ast.Import):
            imported |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, "a relative import"
            imported.add(node.module.split(".")[0])
    assert imported <= sys.stdlib_module_names, imported - sys.stdlib_module_names  # compendium is none of them


def test_a_stamped_venv_that_could_not_be_set_aside_is_left_as_it_was(bootstrap, tmp_path, monkeypatch, capsys):
    """A failure before the first step (here the rename to .venv.previous) touches no working environment."""
    project = _project(tmp_path)
    (project / ".venv").mkdir()
    (project / ".venv" / ".installed").write_text("")
    monkeypatch.chdir(project)

    def refuse(self, target):
        raise PermissionError(f"cannot rename {self}")

    monkeypatch.setattr(Path, "rename", refuse)
    handlers = {signum: signal.getsignal(signum) for signum in bootstrap.SIGNALS}
    try:
        setup = bootstrap.Setup(Path(".venv"), Path(".venv/.installed"), Path("environment.txt"), "k", "K")
        assert setup.run() == 1
    finally:
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
    assert (project / ".venv" / ".installed").is_file()
    err = capsys.readouterr().err
    assert "setup: PermissionError: cannot rename .venv\nsetup: failed before its first step; .venv is as it was" in err


#: uv 0.13.10, as it printed installing environment.txt into a new venv (shortened: 4 of its 181 packages)
UV_0_13 = """Using Python 3.11.7 environment at: .venv
Resolved 181 packages in 478ms
Downloading scipy (33.7MiB)
Downloading casadi (88.9MiB)
Downloading ast-serialize (1.3MiB)
 Downloaded ast-serialize
 Downloaded scipy
 Downloaded casadi
Prepared 181 packages in 8.05s
Uninstalled 1 package in 13ms
Installed 181 packages in 993ms
Bytecode compiled 9143 files in 9.24s
 + ast-serialize==0.2.1
 + casadi==3.8.2
 - setuptools==65.5.0
 + setuptools==84.2.1
 + scipy==1.17.1
"""

#: a warning uv prints among its lines (what any unexpected line stands for)
UV_WARNS = "warning: Failed to hardlink files; falling back to full copy."

CLEAR = "\r\033[K"


def _fold(bootstrap, text: str, total: int, tty: bool, width: int = 200) -> str:
    out = io.StringIO()
    clock = iter([100.0, 142.4]).__next__  # at the start, and at the end
    log = bootstrap.UvLog(total, out, tty=tty, width=width, clock=clock)
    for line in text.splitlines():
        log.feed(line)
    log.close()
    return out.getvalue()


def _screen(output: str) -> list[str]:
    """The lines a terminal shows of ``output``, whose only controls are newlines and CLEAR (back to the start of the
    line, and clear it)."""
    assert "\r" not in output.replace(CLEAR, "")
    return [line.split(CLEAR)[-1] for line in output.split("\n")]


def test_uv_s_log_folds_to_its_resolution_large_downloads_and_a_summary(bootstrap):
    text = UV_0_13.replace(" Downloaded scipy", UV_WARNS + "\n Downloaded scipy")
    assert _fold(bootstrap, text, total=181, tty=False) == "\n".join(
        [
            "  resolved 181 packages",
            "  downloading scipy (33.7 MiB)",
            "  downloading casadi (88.9 MiB)",
            "  downloading ast-serialize (1.3 MiB)",
            UV_WARNS,  # passes through, as uv printed it
            "  4 packages installed in 42 s (3 large downloads, 124 MiB)",  # the removed setuptools is none of them
            "",
        ]
    )


def test_no_summary_where_uv_failed_after_installing(bootstrap):
    out = io.StringIO()
    log = bootstrap.UvLog(181, out, tty=False, clock=iter([100.0, 142.4]).__next__)
    for line in UV_0_13.splitlines():
        log.feed(line)
    log.close(status=2)
    assert "installed in" not in out.getvalue() and out.getvalue().startswith("  resolved 181 packages\n")


def test_uv_s_errors_pass_through_and_nothing_is_said_installed(bootstrap):
    fails = (
        "Using Python 3.11.7 environment at: .venv\nerror: No solution found when resolving dependencies\n  cause: "
        "Because ocpkit-no-such-package was not found in the provided package locations and you require "
        "ocpkit-no-such-package==0.0.0, we can conclude that your requirements are unsatisfiable."
    )
    assert _fold(bootstrap, fails, total=1, tty=False) == "\n".join([*fails.splitlines()[1:], ""])
    assert _screen(_fold(bootstrap, fails, total=1, tty=True)) == [*fails.splitlines()[1:], ""]


def test_on_a_terminal_one_line_is_rewritten_in_place(bootstrap):
    text = UV_0_13.replace(" Downloaded scipy", UV_WARNS + "\n Downloaded scipy")
    out = _fold(bootstrap, text, total=181, tty=True, width=28)
    # what stays on the screen: the warning and the summary; every other line was written over the one before
    assert _screen(out) == [UV_WARNS, "  4 packages installed in 42 s (3 large downloads, 124 MiB)", ""]
    shown = [piece.split("\n")[0] for piece in out.split(CLEAR) if piece.startswith("  ")]
    assert shown[:3] == ["  resolved 181 packages", "  downloading scipy (33.7 Mi", "  downloading casadi (88.9 M"]
    assert "  [2/181] casadi==3.8.2" in shown and "  [4/181] scipy==1.17.1" in shown
    assert all(len(line) <= 28 for line in shown[:-1]), shown  # cut to the terminal's width (not the summary)


def test_pip_s_sources_reach_uv_as_its_options(bootstrap):
    environ = {
        "PIP_INDEX_URL": "https://mirror.example/simple",
        "PIP_EXTRA_INDEX_URL": "https://a.example/simple https://b.example/simple",
        "PIP_FIND_LINKS": "/opt/wheels",
        "PIP_NO_INDEX": "0",
    }
    assert bootstrap.pip_sources(environ) == [
        "--index-url", "https://mirror.example/simple",
        "--extra-index-url", "https://a.example/simple", "--extra-index-url", "https://b.example/simple",
        "--find-links", "/opt/wheels",
        "--index-strategy", "unsafe-best-match",  # each pin from whichever index has it, as pip takes it
    ]  # fmt: skip
    assert bootstrap.pip_sources({"PIP_NO_INDEX": "true"}) == ["--no-index"] and bootstrap.pip_sources({}) == []


def test_the_threads_of_make_the_kernel_and_a_published_run_are_one_setting(bootstrap):
    """The Makefile's exports (nbval, make reproduce, make lab), the registered kernel's environment and what a run
    must have had to publish (compendium.provenance.ONE_THREAD) are the same."""
    from compendium.provenance import ONE_THREAD

    exported = dict(re.findall(r"^export (\w+_NUM_THREADS) := (\S+)$", (ROOT / "Makefile").read_text(), flags=re.M))
    assert exported == bootstrap.KERNEL_ENV == ONE_THREAD


# -- the pins and the minimum Python --------------------------------------------------------------------------------


def _pins() -> dict[str, str]:
    pins = {}
    for raw in (ROOT / "environment.txt").read_text().splitlines():
        line = re.sub(r"(^|\s)#.*$", "", raw).strip()
        if line:
            name, version = line.split("==")
            pins[name] = version
    return pins


def test_left_out_names_every_package_of_its_lines_and_nothing_else(bootstrap, tmp_path):
    requirements = tmp_path / "environment.txt"
    requirements.write_text(
        "# left out: a-b c\nnumpy==2.4.6  # left out: not this\n#Left out:  d  # why\n# not left out\n"
    )
    assert bootstrap.left_out(requirements) == ["a-b", "c", "d"]
    requirements.write_text("numpy==2.4.6\n")
    assert bootstrap.left_out(requirements) == []


def test_what_environment_txt_leaves_out_is_neither_pinned_nor_installed_and_no_process_builds_its_parsers(bootstrap):
    """rfc3987-syntax built 39 Lark parsers in every process that imported nbformat (2.9 s: papermill, each
    notebook's kernel, Jupyter's server); jsonschema checks the IRI formats without it no more."""
    left = bootstrap.left_out(ROOT / "environment.txt")
    assert "rfc3987-syntax" in left
    pinned = {canonicalize_name(name) for name in _pins()}
    assert not {canonicalize_name(name) for name in left} & pinned, "a package is either pinned or left out"
    installed = []
    for name in left:
        try:
            installed.append(f"{name} {importlib.metadata.distribution(name).version}")
        except importlib.metadata.PackageNotFoundError:
            pass
    assert installed == [], (
        f"left out, yet installed: {installed} (`make setup`; after pip: pip uninstall -y {' '.join(left)})"
    )
    code = "import json, sys, nbformat, papermill, jupyter_events.validators; print(json.dumps(sorted(sys.modules)))"
    loaded = {m.split(".")[0] for m in json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True,
                                                                 text=True, check=True).stdout)}  # fmt: skip
    assert "jsonschema" in loaded and not {"lark", "rfc3987_syntax"} & loaded


def test_python_min_is_the_series_environment_txt_is_resolved_for():
    text = (ROOT / "environment.txt").read_text()
    series = re.search(r"\(Python (\d+\.\d+)\)", text).group(1)
    assert PYTHON_MIN.startswith(series + ".")
    assert f"Every pin supports Python {PYTHON_MIN}" in text
    assert Version(RUNNING) >= Version(PYTHON_MIN)  # the tests run on what setup accepts


def test_every_pin_is_installed_and_admits_the_minimum_python():
    """From the metadata pip installed (offline): each pin's Requires-Python admits PYTHON_MIN.

    The bug this guards against: soupsieve 4.1.2 (Requires-Python >=3.11.5) made setup fail on Debian 12's 3.11.2.
    """
    problems = []
    for name, pinned in _pins().items():
        try:
            dist = importlib.metadata.distribution(name)
        except importlib.metadata.PackageNotFoundError:
            problems.append(f"{name}=={pinned}: not installed in {sys.prefix} (make setup)")
            continue
        if Version(dist.version) != Version(pinned):
            problems.append(f"{name}=={pinned}: {dist.version} is installed (make setup)")
        requires = dist.metadata.get("Requires-Python")
        if requires and not SpecifierSet(requires).contains(PYTHON_MIN, prereleases=True):
            problems.append(f"{name}=={pinned}: Requires-Python {requires} excludes Python {PYTHON_MIN}")
    assert not problems, "\n".join(problems)


@pytest.mark.skipif(os.environ.get("OCPKIT_NETWORK_TESTS") != "1", reason="uses the network: OCPKIT_NETWORK_TESTS=1")
def test_every_pin_resolves_on_the_index_for_the_minimum_python(tmp_path):
    """What pip would pick for Python PYTHON_MIN (index metadata, every file of each pin), without installing."""
    cmd = [sys.executable, "-m", "pip", "install", "--disable-pip-version-check", "--dry-run", "--ignore-installed"]
    cmd += ["--no-deps", "--python-version", PYTHON_MIN, "--target", str(tmp_path / "target"), "--progress-bar", "off"]
    result = subprocess.run([*cmd, "-r", str(ROOT / "environment.txt")], capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, (result.stdout + result.stderr)[-4000:]
    assert "Would install" in result.stdout


# -- make chromium --------------------------------------------------------------------------------------------------


@pytest.fixture
def no_chromium(tmp_path):
    """(run, log): run(uid, sudo, apt_get, *make args) runs `make chromium` on a PATH of fakes, with no Chromium on it
    (CHROMIUM_BIN points into tmp_path); log() lists the commands apt-get and sudo were given."""
    project = _project(tmp_path)
    fakes = tmp_path / "bin"
    fakes.mkdir()
    target = tmp_path / "usr-bin-chromium"
    calls = tmp_path / "calls"
    os.symlink(shutil.which("env"), fakes / "env")

    def fake(name: str, body: str) -> None:
        (fakes / name).write_text(f"#!/bin/sh\n{body}\n")
        (fakes / name).chmod(0o755)

    def run(uid: int = 0, sudo: bool = False, apt_get: bool = True, *args: str) -> subprocess.CompletedProcess:
        for name in ("sudo", "apt-get"):
            (fakes / name).unlink(missing_ok=True)
        fake("id", f'case "$1" in -u) echo {uid};; -un) echo researcher;; esac')
        if sudo:
            fake("sudo", f'echo "sudo $*" >> {calls}; exec "$@"')
        if apt_get:
            install = f'[ "$1" = install ] && printf "#!/bin/sh\\n" > {target} && {shutil.which("chmod")} +x {target}'
            fake(
                "apt-get",
                f'echo "apt-get $* (uid $(id -u), DEBIAN_FRONTEND=$DEBIAN_FRONTEND)" >> {calls}; {install}; :',
            )
        env = {k: v for k, v in _env(tmp_path).items() if k != "DEBIAN_FRONTEND"} | {"PATH": str(fakes)}
        return _make(project, "chromium", f"CHROMIUM_BIN={target}", *args, env=env)

    def log() -> list[str]:
        return calls.read_text().splitlines() if calls.exists() else []

    run.target = target
    return run, log


def test_chromium_does_nothing_when_chromium_is_installed(no_chromium):
    run, log = no_chromium
    run.target.write_text("#!/bin/sh\n")
    run.target.chmod(0o755)
    result = run()
    assert result.returncode == 0 and result.stdout == "" and log() == []


def test_chromium_installs_debians_packages_as_root(no_chromium):
    run, log = no_chromium
    result = run(uid=0)
    assert result.returncode == 0, result.stderr
    assert "apt-get installs Debian's chromium and chromium-driver" in result.stdout
    install = (
        "apt-get install -y -q --no-install-recommends chromium chromium-driver (uid 0, DEBIAN_FRONTEND=noninteractive)"
    )
    assert log() == ["apt-get update -q (uid 0, DEBIAN_FRONTEND=)", install]
    assert run().returncode == 0 and len(log()) == 2  # installed now: nothing more


def test_chromium_uses_sudo_when_not_root(no_chromium):
    run, log = no_chromium
    result = run(uid=1000, sudo=True)
    assert result.returncode == 0, result.stderr
    assert "(with sudo)" in result.stdout
    assert log()[0] == "sudo apt-get update -q" and log()[2].startswith("sudo env DEBIAN_FRONTEND=noninteractive")


@pytest.mark.parametrize(
    ("uid", "apt_get", "says"),
    [(1000, True, "this is user researcher and there is no sudo"), (0, False, "there is no apt-get here")],
)
def test_chromium_says_why_it_cannot_install(no_chromium, uid, apt_get, says):
    run, log = no_chromium
    result = run(uid, False, apt_get)
    assert result.returncode != 0
    assert says in result.stderr and "OCPKIT_REQUIRE_BROWSER=0" in result.stderr, result.stderr
    assert log() == []


def test_chromium_installs_nothing_when_the_browser_tests_may_skip(no_chromium):
    run, log = no_chromium
    result = run(0, False, True, "OCPKIT_REQUIRE_BROWSER=0")
    assert result.returncode == 0 and "the browser tests of tests/test_lab.py will skip" in result.stdout
    assert log() == []


def test_unit_gets_chromium_first_and_requires_the_browser_tests(tmp_path):
    """`make unit` on an up-to-date .venv: chromium's recipe runs, then pytest with OCPKIT_REQUIRE_BROWSER=1."""
    project = _project(tmp_path)
    stamp = project / ".venv" / ".installed"
    stamp.parent.mkdir()
    stamp.write_text("")
    for prerequisite in ("environment.txt", "pyproject.toml"):
        _make_older(project / prerequisite, than=stamp)
    report = tmp_path / "pytest-saw"
    py = _script(
        tmp_path / "py", f"import os\nopen({str(report)!r}, 'w').write(os.environ['OCPKIT_REQUIRE_BROWSER'])\n"
    )
    chromium = tmp_path / "chromium"
    chromium.write_text("#!/bin/sh\n")
    chromium.chmod(0o755)
    mathjax = tmp_path / "mathjax"  # installed, as far as make mathjax looks: its recipe does nothing
    (mathjax / "fonts" / "HTML-CSS" / "TeX" / "woff").mkdir(parents=True)
    (mathjax / "MathJax.js").write_text("")
    (mathjax / "fonts" / "HTML-CSS" / "TeX" / "woff" / "MathJax_Main-Regular.woff").write_text("")
    for args, expected in (((), "1"), (("OCPKIT_REQUIRE_BROWSER=0",), "0")):
        made = (f"PY={py}", f"CHROMIUM_BIN={chromium}", f"MATHJAX_DIR={mathjax}")
        result = _make(project, "unit", *made, *args, env=_env(tmp_path))
        assert result.returncode == 0, result.stderr
        assert report.read_text() == expected
    dry = _make(project, "-n", "unit", f"PY={py}", "CHROMIUM_BIN=/nonexistent", env=_env(tmp_path)).stdout
    assert dry.index("apt-get install") < dry.index(f"{py} -m pytest tests/")


@pytest.mark.parametrize("made_as", ["folder", "symlink", "file"])
@pytest.mark.parametrize("name", [".venv", ".venv.previous"])
def test_environment_folders_are_ignored_by_git_however_they_are_made(tmp_path, name, made_as):
    # a CI runner or a user may share one environment between clones with a symlink; git status must stay clean
    clone = tmp_path / "clone"
    clone.mkdir()
    shutil.copy(ROOT / ".gitignore", clone / ".gitignore")
    subprocess.run(["git", "init", "-q", str(clone)], check=True)
    target = clone / name
    if made_as == "folder":
        (target / "bin").mkdir(parents=True)
        (target / "bin" / "python").write_text("")
    elif made_as == "symlink":
        target.symlink_to(tmp_path)
    else:
        target.write_text("")
    status = subprocess.run(["git", "status", "--porcelain", "--", name], cwd=clone, capture_output=True, text=True)
    assert status.returncode == 0 and status.stdout == "", f"{name} as a {made_as} is not ignored: {status.stdout!r}"
