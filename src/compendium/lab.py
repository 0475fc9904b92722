"""Start JupyterLab on the whole compendium, the way a user works with it.

Command line::

    python -m compendium.lab                          # what `make lab` means
    python -m compendium.lab --no-browser --port 8899 # extra arguments go to JupyterLab

Compared with a bare ``jupyter lab notebooks/``, the server

* serves the repository root, so ``figures/`` and ``data/`` can be browsed next
  to ``notebooks/``, and opens on the notebooks folder;
* starts the compendium's kernel (``ocpkit``) by default;
* talks to its kernels over IPC (Unix sockets beside the connection file in
  Jupyter's runtime folder) instead of unencrypted TCP on localhost, which is
  what ipykernel warns about ("Kernel is running over TCP without encryption");
* passes ``--allow-root`` when run as root (containers), where JupyterLab
  otherwise refuses to start;
* saves a notebook without the views of live widgets that come with a picture
  (:func:`compendium.notebooks.pre_save_hook`: the explorer's sliders), so a
  notebook run and saved in Lab stays as stored;
* starts with the settings defaults of :data:`SETTINGS` (JupyterLab's
  ``overrides.json``): no "official Jupyter news" question over the figures, and
  no request for news or updates leaves the machine. A user's own settings
  (Settings menu) still win over them.

JupyterLab is the one installed next to the running interpreter.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from compendium.notebooks import KERNEL_NAME
from compendium.paths import repo_root

# Jupyter's short options that set one of the defaults below: given one, the default must go, as for the long name
# (``--notebook-dir=DIR`` next to ``--ServerApp.root_dir=...`` would stop the server: "root_dir only accepts one value").
_OPTION_ALIASES = {"--notebook-dir": "--ServerApp.root_dir"}

#: JupyterLab's application settings folder the compendium's Lab uses: its ``overrides.json`` turns the news feed
#: and the update check of ``@jupyterlab/apputils-extension:notification`` off (``fetchNews`` ``"false"``). It
#: takes the place of the environment's own (``share/jupyter/lab/settings``, empty in the compendium's ``.venv``): an
#: ``overrides.json`` an extension installed there would not be read; give ``--LabApp.app_settings_dir`` to use it.
SETTINGS = Path(__file__).with_name("lab_settings")


def lab_command(extra_args: list[str] | tuple[str, ...] = ()) -> list[str]:
    """The command line that starts JupyterLab on the repository, followed by ``extra_args``.

    An option of ``extra_args`` such as ``--KernelManager.transport=tcp`` (or ``--notebook-dir=DIR``, Jupyter's
    alias of ``--ServerApp.root_dir``) replaces the default of the same name (traitlets rejects an option given twice).
    """
    defaults = [
        f"--ServerApp.root_dir={repo_root()}",
        "--LabApp.default_url=/lab/tree/notebooks",
        f"--MappingKernelManager.default_kernel_name={KERNEL_NAME}",
        "--KernelManager.transport=ipc",
        # a live widget's view is not saved where a picture comes with it (compendium.explorer): a notebook run and
        # saved in Lab stays as stored
        "--ContentsManager.pre_save_hook=compendium.notebooks.pre_save_hook",
        f"--LabApp.app_settings_dir={SETTINGS}",
    ]
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        defaults.append("--allow-root")
    given = {_OPTION_ALIASES.get(name, name) for name in (arg.split("=", 1)[0] for arg in extra_args)}
    return [sys.executable, "-m", "jupyterlab", *(d for d in defaults if d.split("=", 1)[0] not in given), *extra_args]


def main(argv: list[str] | None = None) -> int:
    cmd = lab_command(sys.argv[1:] if argv is None else argv)
    if os.name == "posix":
        os.execv(cmd[0], cmd)  # JupyterLab takes over this process: Ctrl-C and signals reach it directly
    return subprocess.call(cmd)


if __name__ == "__main__":
    raise SystemExit(main())
