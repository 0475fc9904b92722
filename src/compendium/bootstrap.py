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
* Progress one line per package. ``pip -q`` shows nothing for minutes and pip's own log is some 350 lines, so
  :class:`PipLog` folds it to a line per package with the size of its download (on a terminal, a single line
  rewritten in place); warnings, errors and anything else unexpected pass through as pip prints them.

A signal does not abort the script where it stands: it ends the command that is running (SIGTERM; a second signal
kills it), no further step starts, and the clean-up runs to its end (a second Ctrl-C cannot cut it short). The
script then dies of that signal, as its caller expects.

The steps are numbered after the Makefile's own, the interpreter check ([1/5]):

    [2/5] python -m venv .venv
    [3/5] pip install -r environment.txt
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

#: the .pth file, in the environment's site-packages, that puts <root>/src on its path
PTH_NAME = "compendium.pth"
#: `python -c WRITE_PTH NAME FOLDER`, by the environment's python: the .pth file NAME in its site-packages, FOLDER in it
WRITE_PTH = (
    "import pathlib, sys, sysconfig; "
    "pathlib.Path(sysconfig.get_paths()['purelib'], sys.argv[1]).write_text(sys.argv[2] + '\\n')"
)


def say(text: str, stream: TextIO | None = None) -> None:
    """A line of the setup's own, at once (the commands it runs write to the same terminal or log)."""
    print(text, file=stream or sys.stdout, flush=True)


# -- pip's output, folded -----------------------------------------------------------------------------------------

PACKAGE = re.compile(r"^(?:Collecting|Processing) (\S+)")
#: indented under its package; at the start of the line when pip fetches it after resolving every pin (pip 23.2)
DOWNLOAD = re.compile(r"^\s*Downloading (\S+) \(([\d.]+) (bytes|kB|MB|GB)\)")
#: pip's lines that say nothing a reader needs: dropped
QUIET = re.compile(
    r"^(Looking in |Requirement already satisfied|\s*(Using cached|Obtaining dependency information"
    r"|Attempting uninstall|Found existing installation|Uninstalling|Successfully uninstalled)\b|\s*$)"
)
MEGABYTES = {"bytes": 1e-6, "kB": 1e-3, "MB": 1.0, "GB": 1e3}


def requirement(found: str) -> tuple[str, str]:
    """(project, shown) for what pip names on a Collecting, Processing or Downloading line: the project's normalized
    name, and ``casadi==3.8.2`` from a pin or from the path or file name of a wheel or sdist; any other requirement
    (``tzdata``, ``soupsieve>=1.6.1``) is shown as pip gives it."""
    if "==" in found:
        project, version = found.split("==", 1)
    elif re.search(r"(\.tar\.gz|\.zip|\.whl)$", found):
        base = re.sub(r"(\.tar\.gz|\.zip|\.whl)$", "", os.path.basename(found))
        project, _, rest = base.partition("-")
        project, version = project.replace("_", "-"), rest.split("-")[0]  # wheel names spell - as _
    else:
        return _normalized(re.split(r"[\s<>=!~;\[@(]", found, maxsplit=1)[0]), found
    return _normalized(project), f"{project}=={version}"


def _normalized(project: str) -> str:
    return re.sub(r"[-_.]+", "-", project).lower()


class PipLog:
    """pip install's output, fed line by line, written to ``out`` folded to one line per package.

    Off a terminal each package line is printed once the next one starts (with its download by then); on one
    (``tty``) a single line is rewritten in place, cut to ``width``. Lines that are neither a package nor a download
    nor :data:`QUIET` (warnings, errors, tracebacks) stay, printed above the package line. pip's closing
    ``Successfully installed`` becomes a summary: how many packages, how long, how many downloads of how many MB.
    ``total`` is the number of pins, for ``[3/120]``; past it (a package pulled in unpinned) the count stands alone.
    """

    def __init__(
        self, total: int, out: TextIO | None = None, *, tty: bool | None = None, width: int | None = None, clock=None
    ):
        self.total, self.out = total, out or sys.stdout
        self.tty = self.out.isatty() if tty is None else tty
        self.width = shutil.get_terminal_size().columns - 1 if width is None else width
        self.clock = clock or time.monotonic
        self.start = self.clock()
        self.count, self.downloads, self.megabytes = 0, 0, 0.0
        self.status: str | None = None  # the package line (off a terminal: not yet printed)
        self.current: str | None = None  # its project, until its download is seen

    def feed(self, line: str) -> None:
        """One line of pip's output (stdout and stderr together), without its newline."""
        package, download = PACKAGE.match(line), DOWNLOAD.match(line)
        if package:
            self.count += 1
            self.current, text = requirement(package.group(1))
            counter = f"{self.count}/{self.total}" if self.count <= self.total else f"{self.count}"
            self._show(f"  [{counter}] {text}", new=True)
        elif download and download.group(1).endswith(".metadata"):
            pass  # the wheel's metadata, ahead of the wheel (pip 23.2)
        elif download:
            self.downloads += 1
            self.megabytes += float(download.group(2)) * MEGABYTES[download.group(3)]
            size = f"{download.group(2)} {download.group(3)}"
            project, text = requirement(download.group(1))
            if project == self.current and self.status:
                self._show(f"{self.status}, downloading {size}")
            else:  # pip fetches some wheels only once it has resolved every pin
                self._show(f"  downloading {text} ({size})", new=True)
            self.current = None
        elif line.startswith("Installing collected packages:"):
            self._show(f"  installing {len(line.split(':', 1)[1].split(','))} packages", new=True)
            if not self.tty:  # nothing more comes for it
                self._write(self.status + "\n")
                self.status = None
        elif line.startswith("Successfully installed "):
            self.status = None
            elapsed = self.clock() - self.start
            self._emit(
                f"  {len(line.split()) - 2} packages installed in {elapsed:.0f} s"
                f" ({self.downloads} downloaded, {self.megabytes:.0f} MB)"
            )
        elif not QUIET.match(line):
            self._emit(line)

    def close(self) -> None:
        """pip is done (or stopped): the package line, if one is pending, ends."""
        if self.status:
            self._write("\n" if self.tty else self.status + "\n")
        self.status = None

    def _write(self, text: str) -> None:
        self.out.write(text)
        self.out.flush()

    def _show(self, text: str, new: bool = False) -> None:
        """The package line becomes ``text``; off a terminal, a ``new`` one prints the one before."""
        if not self.tty and new and self.status:
            self._write(self.status + "\n")
        self.status = text
        if self.tty:
            self._write("\r\033[K" + text[: self.width])

    def _emit(self, text: str) -> None:
        """A line that stays, printed above the package line."""
        if self.tty:
            self._write("\r\033[K")
        elif self.status:
            self._write(self.status + "\n")
            self.status = None
        self._write(text + "\n")
        if self.tty and self.status:
            self._show(self.status)


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
    #: pip's output folded (PipLog), this many pins expected; None: the commands write as they please
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
        steps = self.steps()  # reads environment.txt and pyproject.toml: before anything is changed
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
        pins = count_pins(self.requirements)
        library = tomllib.loads(Path("pyproject.toml").read_text())["project"]["name"]
        kernel = [python, "-m", "ipykernel", "install", "--sys-prefix", "--name", self.kernel]
        registering = f"[5/5] registering the Jupyter kernel {self.kernel}"
        return [
            Step(
                f"[2/5] creating {self.venv}",
                f"setup [2/5] creating {self.venv} with {sys.executable}",
                [[sys.executable, "-m", "venv", str(self.venv)]],
            ),
            Step(
                f"[3/5] installing {self.requirements}",
                f"setup [3/5] installing the {pins} packages pinned in {self.requirements}",
                [[*pip, "--progress-bar", "off", "-r", str(self.requirements)]],
                fold=pins,
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
            status = self.command(command, PipLog(step.fold) if step.fold is not None else None)
            if status:
                raise StepFailed(status)

    def command(self, command: Sequence[str], log: PipLog | None = None) -> int:
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
                    log.close()
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
