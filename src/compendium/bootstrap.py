"""Make the compendium's environment (.venv) for `make setup`: all of it, or nothing half-made.

`make setup` first checks the interpreter (CHECK_PYTHON in the Makefile, written so that any Python prints its
message), then runs this file as a script with that interpreter::

    python -P src/compendium/bootstrap.py --venv .venv --stamp .venv/.installed --requirements environment.txt \\
        --kernel ocpkit --display-name "Python (ocpkit)" --root . --changed environment.txt

It runs before the environment exists, so it imports the standard library only, and never the ``compendium``
package it sits in (``-P`` keeps src/compendium/ off sys.path, so that none of its modules can shadow the standard
library's). It is a script rather than shell in the Makefile because what it guarantees needs clean-up after
whichever step fails, which a recipe can do only with traps:

* No half-made .venv. A setup that fails, or is interrupted (Ctrl-C, SIGTERM, SIGHUP), removes the .venv it was
  making: a half-made one would pass for a working one next time. The stamp (``--stamp``, make's target) is written
  last, once every step has worked, and only a .venv with the stamp counts as a working environment.
* A rebuild starts from scratch, and keeps the previous environment until it works. A .venv with the stamp is the
  working environment of an earlier setup; make runs this again when environment.txt or pyproject.toml changed
  since. Upgrading it in place would keep packages no longer pinned, and an upgrade that fails midway leaves
  neither the old environment nor the new. So the working one waits in .venv.previous meanwhile, and a rebuild that
  fails or is interrupted puts it back as it was: you keep the environment you had, and since its stamp is still
  older than environment.txt, the next make tries again. A .venv.previous found at the start is that of a rebuild
  that was killed outright (SIGKILL, a power cut): it comes back first; unless it has lost its stamp, which a setup
  that worked removes before the rest of it: then it is what is left of that removal, and goes.
* A .venv without the stamp was left by a setup that did not finish (or made by hand): it is replaced.
* The pins are installed by uv (:data:`INSTALLER`, pinned in environment.txt), three times faster than pip. Its log
  is folded by :class:`UvLog` to the resolution, the large downloads and a summary (on a terminal, a single line
  rewritten in place); warnings, errors and anything else unexpected pass through as uv prints them. pip's settings of where packages come from (``PIP_INDEX_URL``,
  ``PIP_EXTRA_INDEX_URL``, ``PIP_FIND_LINKS``, ``PIP_NO_INDEX``) are passed on to uv, which reads no pip
  configuration.

A signal does not abort the script where it stands: it ends the command that is running (SIGTERM; a second signal
kills it), no further step starts, and the clean-up runs to its end (a second Ctrl-C cannot cut it short). The
script then dies of that signal, as its caller expects.

The steps are numbered after the Makefile's own, the interpreter check ([1/5]):

    [2/5] python -m venv .venv
    [3/5] pip install uv==VERSION (its pin in environment.txt), then uv pip install -r environment.txt, leaving out
          what its line ``# left out:`` names (uv's --excludes, from .venv/left-out.txt, written in step 2)
    [4/5] pip install --no-deps -e . (the library, ocpkit) and compendium.pth, which puts src/ (the compendium
          package, not distributed) on the environment's path
    [5/5] the Jupyter kernel, in the environment (ipykernel install --sys-prefix)
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

#: the signals that end a setup early: Ctrl-C, kill (make passes its SIGTERM on), the terminal closing
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

#: the environment of the registered kernel (``ipykernel install --env``): one BLAS and one OpenMP thread, as the
#: Makefile exports them and ``compendium.provenance.ONE_THREAD`` requires of a run that publishes. A kernelspec's
#: environment wins over its caller's, so every kernel of the compendium computes the same way, whichever JupyterLab,
#: papermill or editor starts it (tests/test_setup.py checks the three agree)
KERNEL_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}

#: the .pth file, in the environment's site-packages, that puts <root>/src on its path
PTH_NAME = "compendium.pth"
#: `python -c WRITE_PTH NAME FOLDER`, by the environment's python: the .pth file NAME in its site-packages, FOLDER in it
WRITE_PTH = (
    "import pathlib, sys, sysconfig; "
    "pathlib.Path(sysconfig.get_paths()['purelib'], sys.argv[1]).write_text(sys.argv[2] + '\\n')"
)

#: writes its arguments after the first, one a line, to the file the first names
WRITE_LINES = "import pathlib, sys; pathlib.Path(sys.argv[1]).write_text(''.join(a + '\\n' for a in sys.argv[2:]))"


def say(text: str, stream: TextIO | None = None) -> None:
    """A line of the setup's own, at once (the commands it runs write to the same terminal or log)."""
    print(text, file=stream or sys.stdout, flush=True)


# -- the installer, and its output folded ---------------------------------------------------------------------------

#: the installer of the pins: uv, at its pin in environment.txt, put into the new environment by its own pip first.
#: From empty caches on the 2-core reference machine (2026-12-07), the 181 pins it had then took 18 s with uv
#: (downloads in parallel, bytecode compiled as pip compiles it, files copied) against pip's 54 s; the same packages
#: either way.
INSTALLER = "uv"

#: pip's settings from the environment that say where packages come from, and uv's options for them: uv reads no
#: pip configuration, and a setup told where to look (a mirror, a folder of wheels, offline) must look there
PIP_SOURCES = {
    "PIP_INDEX_URL": "--index-url",
    "PIP_EXTRA_INDEX_URL": "--extra-index-url",
    "PIP_FIND_LINKS": "--find-links",
    "PIP_NO_INDEX": "--no-index",
}


def installer_pin(requirements: Path) -> str:
    """``uv==0.13.10``: the installer's line of ``requirements``, which must pin it exactly."""
    for line in requirements.read_text().splitlines():
        if re.match(rf"{INSTALLER}\s*==", line):
            return re.sub(r"\s+", "", line.split("#", 1)[0])
    raise ValueError(f"{requirements} pins no {INSTALLER} (a line {INSTALLER}==VERSION): setup installs with it")


#: environment.txt's line naming what the environment leaves out of what the pins' dependencies ask for
LEFT_OUT = re.compile(r"^#\s*left out:([^#]*)", re.IGNORECASE)


def left_out(requirements: Path) -> list[str]:
    """The packages ``requirements`` leaves out (its line ``# left out: NAME ...``): asked for by a pin's
    dependencies, and not installed (uv's ``--excludes``): rfc3987-syntax and lark, its parser, as environment.txt
    says, with why."""
    names: list[str] = []
    for line in requirements.read_text().splitlines():
        match = LEFT_OUT.match(line)
        if match:
            names += match.group(1).split()
    return names


def pip_sources(environ: dict[str, str]) -> list[str]:
    """uv's options for the :data:`PIP_SOURCES` set in ``environ`` (each of a list that pip separates by spaces)."""
    options: list[str] = []
    for variable, option in PIP_SOURCES.items():
        value = environ.get(variable, "").strip()
        if option == "--no-index":
            options += [option] if value.lower() in ("1", "y", "yes", "t", "true", "on") else []
        else:
            options += [part for item in value.split() for part in (option, item)]
    if "--extra-index-url" in options:  # pip takes each pin from whichever index has it; uv, from the first by default
        options += ["--index-strategy", "unsafe-best-match"]
    return options


#: uv's lines: the resolution, a large download (uv names only those), a package installed or removed
RESOLVED = re.compile(r"^Resolved (\d+) packages? in ")
DOWNLOADING = re.compile(r"^Downloading (\S+) \(([\d.]+)(B|KiB|MiB|GiB)\)")
CHANGED = re.compile(r"^ ([+~-]) (\S+)")
#: uv's lines that say nothing a reader needs: dropped
QUIET = re.compile(
    r"^(Using Python |\s*Downloaded |Prepared |Installed |Uninstalled |Bytecode compiled |Audited |Checked )|^\s*$"
)
MEBIBYTES = {"B": 2.0**-20, "KiB": 2.0**-10, "MiB": 1.0, "GiB": 2.0**10}


class UvLog:
    """``uv pip install``'s output, fed line by line, written to ``out`` folded.

    What stays: how many packages uv resolved, each large download as uv announces it (with its size), anything
    that is not :data:`QUIET` (warnings, errors) as uv printed it, and at the end a summary: how many packages, how
    long, how many megabytes of large downloads. On a terminal (``tty``) the resolution and the downloads share one
    line rewritten in place, cut to ``width``; uv names the packages it installed at the end, each shown there in
    turn as ``[3/181] numpy==2.4.6``. ``total`` is the number of pins uv installs, for ``[3/181]``.
    """

    def __init__(
        self, total: int, out: TextIO | None = None, *, tty: bool | None = None, width: int | None = None, clock=None
    ):
        self.total, self.out = total, out or sys.stdout
        self.tty = self.out.isatty() if tty is None else tty
        self.width = shutil.get_terminal_size().columns - 1 if width is None else width
        self.clock = clock or time.monotonic
        self.start = self.clock()
        self.installed, self.downloads, self.mebibytes = 0, 0, 0.0
        self.status: str | None = None  # on a terminal: the line rewritten in place

    def feed(self, line: str) -> None:
        """One line of uv's output (stdout and stderr together), without its newline."""
        resolved, download, changed = RESOLVED.match(line), DOWNLOADING.match(line), CHANGED.match(line)
        if resolved:
            self._show(f"  resolved {resolved.group(1)} packages")
        elif download:
            self.downloads += 1
            self.mebibytes += float(download.group(2)) * MEBIBYTES[download.group(3)]
            self._show(f"  downloading {download.group(1)} ({download.group(2)} {download.group(3)})")
        elif changed:
            if changed.group(1) == "+":
                self.installed += 1
                counter = f"{self.installed}/{self.total}" if self.installed <= self.total else f"{self.installed}"
                if self.tty:
                    self._show(f"  [{counter}] {changed.group(2)}")
        elif not QUIET.match(line):
            self._emit(line)

    def close(self, status: int = 0) -> None:
        """uv is done (or stopped), with exit ``status``: the line in place, if any, ends; the summary, if uv
        installed anything and exited 0."""
        if self.tty and self.status:
            self._write("\r\033[K")
        self.status = None
        if self.installed and status == 0:
            elapsed = self.clock() - self.start
            self._write(
                f"  {self.installed} packages installed in {elapsed:.0f} s ({self.downloads} large downloads, "
                f"{self.mebibytes:.0f} MiB)\n"
            )

    def _write(self, text: str) -> None:
        self.out.write(text)
        self.out.flush()

    def _show(self, text: str) -> None:
        """Off a terminal, a line of its own; on one, the line in place becomes ``text``."""
        if self.tty:
            self.status = text
            self._write("\r\033[K" + text[: self.width])
        else:
            self._write(text + "\n")

    def _emit(self, text: str) -> None:
        """A line that stays, printed above the line in place."""
        if self.tty:
            self._write("\r\033[K")
        self._write(text + "\n")
        if self.tty and self.status:
            self._write(self.status[: self.width])


# -- the setup ----------------------------------------------------------------------------------------------------


class StepFailed(Exception):
    """A command of a step exited with ``status``."""

    def __init__(self, status: int):
        super().__init__(f"exit status {status}")
        self.status = status


class Interrupted(Exception):
    """A signal asked the setup to stop (raised once the command it ended has exited)."""


@dataclass
class Step:
    #: as the failure message names it: "[3/5] installing environment.txt"
    name: str
    #: the progress line that starts it
    announce: str
    commands: list[list[str]]
    #: the installer's output folded (:class:`UvLog`), this many pins expected; None: the commands write as they please
    fold: int | None = None


def exists(path: Path) -> bool:
    """Whether there is anything at ``path``, a dangling symlink included."""
    return path.exists() or path.is_symlink()


def remove(path: Path) -> None:
    """``path`` gone, whatever it is (a folder, a file, a symlink, dangling or not); nothing if it is not there."""
    if path.is_symlink() or path.is_file():
        path.unlink()
    elif path.is_dir():
        shutil.rmtree(path)


def count_pins(requirements: Path) -> int:
    """The requirement lines of ``requirements`` (not comments, blank lines or options)."""
    return sum(1 for line in requirements.read_text().splitlines() if re.match(r"[A-Za-z0-9]", line))


@dataclass
class Setup:
    """One `make setup`: the folders it works on, and the signal, if one came."""

    venv: Path
    #: in venv: written last, it says the environment is complete
    stamp: Path
    requirements: Path
    kernel: str
    display_name: str
    #: what make found newer than the stamp ($?), for the messages
    changed: str = ""
    signum: int | None = None
    running: subprocess.Popen | None = field(default=None, repr=False)

    @property
    def previous(self) -> Path:
        return self.venv.with_name(self.venv.name + ".previous")

    def stamp_of(self, folder: Path) -> Path:
        """Where the stamp of an environment in ``folder`` is (``.venv.previous/.installed``)."""
        return folder / self.stamp.relative_to(self.venv)

    def run(self) -> int:
        """The whole setup: the exit status (0 once the stamp is written), 128 + the signal's number if one came."""
        for signum in SIGNALS:
            signal.signal(signum, self._on_signal)
        started = time.monotonic()
        try:
            steps = self.steps()  # reads environment.txt and pyproject.toml: before anything is changed
        except ValueError as problem:
            say(f"setup: {problem}; nothing was changed", sys.stderr)
            return 1
        step = None
        try:
            self.set_aside()
            for step in steps:
                self.execute(step)
        except Exception as failure:
            return self.roll_back(step, failure)
        self.commit()
        say(f"setup: done in {time.monotonic() - started:.0f} s")
        return 0

    def steps(self) -> list[Step]:
        """Steps 2 to 5, from environment.txt (its pins, counted) and pyproject.toml (the library's name)."""
        python = str(self.venv / "bin" / "python")
        pip = [python, "-m", "pip", "install", "--disable-pip-version-check"]
        uv = [python, "-m", INSTALLER, "pip", "install", "--python", python, "--color", "never"]
        uv += pip_sources(dict(os.environ))
        pins = count_pins(self.requirements)
        excluded = self.venv / "left-out.txt"  # uv reads the names to leave out from a file
        left = left_out(self.requirements)
        excludes = ["--excludes", str(excluded)] if left else []
        installer = installer_pin(self.requirements)  # installed first, by pip: uv installs the others
        library = tomllib.loads(Path("pyproject.toml").read_text())["project"]["name"]
        kernel = [python, "-m", "ipykernel", "install", "--sys-prefix", "--name", self.kernel]
        kernel += [part for name, value in KERNEL_ENV.items() for part in ("--env", name, value)]
        registering = f"[5/5] registering the Jupyter kernel {self.kernel}"
        return [
            Step(
                f"[2/5] creating {self.venv}",
                f"setup [2/5] creating {self.venv} with {sys.executable}",
                [[sys.executable, "-m", "venv", str(self.venv)]]
                + ([[sys.executable, "-c", WRITE_LINES, str(excluded), *left]] if left else []),
            ),
            Step(
                f"[3/5] installing {self.requirements}",
                f"setup [3/5] installing the {pins} packages pinned in {self.requirements}",
                [
                    [*pip, "-q", installer],
                    [*uv, "--compile-bytecode", "--link-mode", "copy", *excludes, "-r", str(self.requirements)],
                ],
                fold=pins - 1,
            ),
            Step(
                f"[4/5] installing {library}",
                f"setup [4/5] installing {library} (editable, src/{library}) and putting src/ (the compendium package)"
                " on the path",
                [
                    [*pip, "-q", "--no-deps", "--no-build-isolation", "-e", "."],
                    [python, "-c", WRITE_PTH, PTH_NAME, str(Path.cwd() / "src")],
                ],
            ),
            Step(registering, f"setup {registering}", [[*kernel, "--display-name", self.display_name]]),
        ]

    def set_aside(self) -> None:
        """Before the first step: undo a rebuild that was killed, set a working .venv aside in .venv.previous, or
        remove a .venv that has no stamp."""
        if exists(self.previous):
            if self.stamp_of(self.previous).is_file():
                say(f"  {self.previous} is the environment of a rebuild that was killed: it becomes {self.venv} again")
                remove(self.venv)
                self.previous.rename(self.venv)
            else:  # commit() removes its stamp first
                say(f"  {self.previous} is what is left of an environment whose removal was cut short: removing it")
                remove(self.previous)
        if self.stamp.is_file():
            say(
                f"  {self.changed or 'what it is made from'} changed since the last setup: {self.venv} is rebuilt from"
                f" scratch; the current one waits in {self.previous} and comes back if the rebuild fails"
            )
            self.venv.rename(self.previous)
        elif exists(self.venv):
            say(f"  {self.venv} has no stamp ({self.stamp}): a setup that did not finish left it; removing it")
            remove(self.venv)
        self._stop_if_asked()

    def execute(self, step: Step) -> None:
        """Announces ``step`` and runs its commands; the first that fails raises StepFailed."""
        say(step.announce)
        for command in step.commands:
            folded = step.fold is not None and command[1:3] == ["-m", INSTALLER]
            status = self.command(command, UvLog(step.fold) if folded else None)
            if status:
                raise StepFailed(status)

    def command(self, command: Sequence[str], log: UvLog | None = None) -> int:
        """Runs ``command`` and returns its exit status; with ``log``, its output (stderr too) goes through it.
        A signal ends it, and raises Interrupted once it has exited."""
        self._stop_if_asked()
        streams = {}
        if log is not None:
            streams = dict(stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, errors="replace")
            streams["env"] = {**os.environ, "PYTHONUNBUFFERED": "1"}
        with subprocess.Popen(command, **streams) as proc:
            self.running = proc
            try:
                if self.signum is not None:  # came as it started
                    proc.terminate()
                if log is not None:
                    for line in proc.stdout:
                        log.feed(line.rstrip("\n"))
                status = proc.wait()
            except BaseException:
                proc.kill()
                raise
            finally:
                self.running = None
                if log is not None:
                    log.close(proc.returncode if proc.returncode is not None and self.signum is None else 1)
        self._stop_if_asked()
        return status

    def roll_back(self, step: Step | None, failure: Exception) -> int:
        """After a step failed, or a signal: the previous environment back as it was, or no .venv at all (a .venv
        with its stamp is whole: one that nothing had touched yet stays). Returns the exit status."""
        what = "interrupted" if self.signum is not None else "failed"
        if not isinstance(failure, StepFailed | Interrupted):  # not a command's failure: a message of its own
            say(f"setup: {type(failure).__name__}: {failure}", sys.stderr)
        happened = f"{step.name} {what}" if step else f"{what} before its first step"
        if self.stamp_of(self.previous).is_file():
            remove(self.venv)
            self.previous.rename(self.venv)
            older = self.changed or "what it is made from"
            outcome = (
                f"{self.venv} is the environment of the last setup again, unchanged (older than {older}, so the next"
                " make tries again)"
            )
        else:
            remove(self.previous)  # if there is one, what is left of a removal that was cut short
            if self.stamp.is_file():
                outcome = f"{self.venv} is as it was"
            else:
                remove(self.venv)
                outcome = f"{self.venv} removed, so that nothing half-made is left"
        say(f"setup: {happened}; {outcome}", sys.stderr)
        if self.signum is not None:
            return 128 + self.signum
        return failure.status if isinstance(failure, StepFailed) else 1

    def commit(self) -> None:
        """Every step worked: the stamp says so, and the previous environment goes. Its stamp goes first, so that a
        removal cut short (SIGKILL) leaves nothing that the next setup would take for an environment."""
        self.stamp.touch()
        if exists(self.previous):
            if not self.previous.is_symlink():
                self.stamp_of(self.previous).unlink(missing_ok=True)
            remove(self.previous)

    def _on_signal(self, signum: int, frame) -> None:
        """The signal handler: notes the first signal and ends the command running (kills it, on another signal);
        the setup stops before its next command (see the module's docstring)."""
        first = self.signum is None
        if first:
            self.signum = signum
        if self.running is not None and first:
            self.running.terminate()
        elif self.running is not None:
            self.running.kill()

    def _stop_if_asked(self) -> None:
        if self.signum is not None:
            raise Interrupted(signal.Signals(self.signum).name)


def parse_arguments(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line (the Makefile's setup rule gives every option)."""
    parser = argparse.ArgumentParser(
        prog="bootstrap.py",
        description="Make the compendium's environment for `make setup`: all of it, or nothing half-made.",
        epilog="Relative paths are taken from --root.",
    )
    parser.add_argument("--venv", type=Path, required=True, help="the environment's folder (.venv)")
    parser.add_argument(
        "--stamp", type=Path, required=True, help="the file in it that marks it complete (make's target)"
    )
    parser.add_argument("--requirements", type=Path, required=True, help="the exact pins (environment.txt)")
    parser.add_argument("--kernel", required=True, help="the Jupyter kernel's name")
    parser.add_argument("--display-name", required=True, help="the Jupyter kernel's display name")
    parser.add_argument("--root", type=Path, default=Path("."), help="the project (where pyproject.toml is)")
    parser.add_argument("--changed", default="", help="what changed since the last setup (make's $?), for messages")
    options = parser.parse_args(argv)
    if not options.stamp.is_relative_to(options.venv) or options.stamp == options.venv:
        parser.error(f"--stamp {options.stamp} is not inside --venv {options.venv}")
    return options


def main(argv: Sequence[str] | None = None) -> int:
    """`make setup` after the interpreter check: the exit status, or death by the signal that stopped it."""
    options = parse_arguments(argv)
    os.chdir(options.root)
    setup = Setup(
        options.venv, options.stamp, options.requirements, options.kernel, options.display_name, options.changed
    )
    status = setup.run()
    if status and setup.signum is not None:  # die of it, as the caller (make, a shell) expects
        signal.signal(setup.signum, signal.SIG_DFL)
        os.kill(os.getpid(), setup.signum)
    return status


if __name__ == "__main__":
    sys.exit(main())
