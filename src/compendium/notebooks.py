"""Run the compendium's notebooks headless (papermill), refresh their stored outputs, build the report.

Command line::

    python -m compendium.notebooks run notebooks/01_lunar_ascent.ipynb -p segments 40
    python -m compendium.notebooks reproduce notebooks/*.ipynb   # the published runs (notebooks/published.toml)
    python -m compendium.notebooks store notebooks/*.ipynb       # re-execute in place (nbval reference)
    python -m compendium.notebooks report build/notebooks --output build/report

Unlike plain papermill, which only warns, an unknown parameter is an error. Kernels talk
over IPC sockets (no unencrypted TCP), and long work reports its progress in the terminal
(``OCPKIT_PROGRESS=terminal``, see :mod:`compendium.progress`), not in the stored notebooks.
"""

from __future__ import annotations

import argparse
import ast
import html
import json
import sys
from pathlib import Path

KERNEL_NAME = "ocpkit"

# metadata written by papermill/nbclient that changes on every run
_VOLATILE_CELL_METADATA = ("papermill", "execution")
_VOLATILE_NB_METADATA = ("papermill",)


def parameters_cell(path: str | Path):
    """The single cell tagged ``parameters`` of a notebook."""
    import nbformat

    nb = nbformat.read(str(path), as_version=4)
    cells = [c for c in nb.cells if "parameters" in c.metadata.get("tags", [])]
    if len(cells) != 1:
        raise ValueError(f"{Path(path).name} must have exactly one cell tagged 'parameters', found {len(cells)}")
    return cells[0]


def notebook_parameters(path: str | Path) -> dict:
    """Parameters declared in the notebook's ``parameters`` cell: name -> default (source text).

    Every assignment in the cell must be one papermill can parse (it silently
    skips, for instance, a line whose comment contains ``=``); otherwise the
    parameter could not be set from the command line, and this raises.
    """
    import papermill as pm

    cell = parameters_cell(path)
    assigned = [
        t.id
        for node in ast.parse(cell.source).body
        if isinstance(node, ast.Assign)
        for t in node.targets
        if isinstance(t, ast.Name)
    ]
    params = pm.inspect_notebook(str(path))
    missed = [name for name in assigned if name not in params]
    if missed:
        raise ValueError(f"papermill cannot parse the parameter line(s) of {missed} in {Path(path).name}")
    return {name: spec["default"] for name, spec in params.items()}


def literal_parameters(path: str | Path) -> dict:
    """The defaults of :func:`notebook_parameters` as Python values (every default must be a literal)."""
    out = {}
    for name, text in notebook_parameters(path).items():
        try:
            out[name] = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            raise ValueError(f"the default of {name!r} in {Path(path).name} is not a Python literal: {text}") from None
    return out


def published_overrides(path: str | Path) -> dict:
    """The parameters ``notebooks/published.toml`` sets for the notebook's published run (values as Python)."""
    import tomllib

    table = tomllib.loads((Path(path).parent / "published.toml").read_text()).get(Path(path).stem, {})
    return {k: ast.literal_eval(v) for k, v in table.items()}


def _kernel_manager_class(progress: bool = False):
    """jupyter_client's kernel manager over IPC sockets: local, and without ipykernel's TCP warning.

    ``progress``: the kernel leaves its stderr file descriptor alone (ipykernel otherwise captures it
    into the notebook), so that the progress bars :mod:`compendium.progress` writes to it reach the
    terminal of the run and never the stored notebook.
    """
    from jupyter_client import AsyncKernelManager

    class IPCKernelManager(AsyncKernelManager):
        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.transport = "ipc"

        def format_kernel_cmd(self, extra_arguments=None):
            cmd = super().format_kernel_cmd(extra_arguments)
            if progress and any("ipykernel" in part for part in cmd):
                cmd.append("--IPKernelApp.capture_fd_output=False")
            return cmd

    return IPCKernelManager


def check_parameters(path: str | Path, parameters: dict) -> None:
    """Raise ``ValueError`` naming any parameter the notebook does not declare."""
    known = notebook_parameters(path)
    unknown = sorted(set(parameters) - set(known))
    if unknown:
        raise ValueError(f"unknown parameter(s) {unknown} for {Path(path).name}; its parameters are {sorted(known)}")


def execute(
    path: str | Path,
    output: str | Path,
    parameters: dict | None = None,
    *,
    kernel: str = KERNEL_NAME,
    cwd: str | Path | None = None,
    timeout: int = 3600,
    progress: bool = False,
) -> Path:
    """Execute a notebook with papermill into ``output``; unknown parameters are rejected first.

    The kernel starts in ``cwd`` (default: the output's folder), not in the
    notebook's folder: the notebooks find the repository through
    :mod:`compendium.paths`, whatever folder they run in. ``progress``: a bar over the
    notebook's cells, and the notebook's own bars, in this process's terminal.
    """
    import os

    import papermill as pm

    path, output = Path(path), Path(output)
    parameters = dict(parameters or {})
    check_parameters(path, parameters)
    output.parent.mkdir(parents=True, exist_ok=True)
    previous = os.environ.get("OCPKIT_PROGRESS")
    os.environ["OCPKIT_PROGRESS"] = "terminal" if progress else "off"  # inherited by the kernel
    try:
        pm.execute_notebook(
            str(path),
            str(output),
            parameters=parameters,
            kernel_name=kernel,
            cwd=str(cwd or output.parent),
            execution_timeout=timeout,
            progress_bar={"desc": path.stem, "leave": False} if progress else False,
            kernel_manager_class=_kernel_manager_class(progress),
        )
    finally:
        if previous is None:
            os.environ.pop("OCPKIT_PROGRESS", None)
        else:
            os.environ["OCPKIT_PROGRESS"] = previous
    return output


def strip_volatile_metadata(path: str | Path) -> None:
    """Remove timings and timestamps so that a stored notebook changes only when its results do."""
    import nbformat

    nb = nbformat.read(str(path), as_version=4)
    for key in _VOLATILE_NB_METADATA:
        nb.metadata.pop(key, None)
    for cell in nb.cells:
        for key in _VOLATILE_CELL_METADATA:
            cell.metadata.pop(key, None)
    nbformat.write(nb, str(path))


def store(path: str | Path, *, kernel: str = KERNEL_NAME, progress: bool = False) -> Path:
    """Re-execute a notebook in place with its default parameters (the nbval reference outputs)."""
    path = Path(path)
    execute(path, path, {}, kernel=kernel, cwd=path.parent, progress=progress)
    strip_volatile_metadata(path)
    return path


def _title(nb) -> str:
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            for line in cell.source.splitlines():
                if line.startswith("#"):
                    return line.lstrip("#").strip()
    return "untitled"


def install_mathjax(output: Path) -> str:
    """Copy MathJax (the ``jupyter-server-mathjax`` package's files) into ``output/mathjax``; its URL, relative.

    The report's equations then render offline, without the CDN nbconvert links by default.
    """
    import shutil

    import jupyter_server_mathjax

    source = Path(jupyter_server_mathjax.__file__).parent / "static"
    target = output / "mathjax"
    if not (target / "MathJax.js").is_file():
        shutil.copytree(source, target, dirs_exist_ok=True)
    return "mathjax/MathJax.js?config=TeX-AMS-MML_HTMLorMML-full,Safe"


def build_report(executed: str | Path, output: str | Path) -> Path:
    """Convert every executed notebook in ``executed`` to HTML (figures inline, MathJax served from the report's
    own folder) and write an index linking them."""
    import nbformat
    from nbconvert import HTMLExporter

    executed, output = Path(executed), Path(output)
    notebooks = sorted(executed.glob("*.ipynb"))
    if not notebooks:
        raise FileNotFoundError(f"no executed notebooks in {executed}")
    output.mkdir(parents=True, exist_ok=True)
    exporter = HTMLExporter(mathjax_url=install_mathjax(output))
    rows = []
    for nb_path in notebooks:
        nb = nbformat.read(str(nb_path), as_version=4)
        body, _ = exporter.from_notebook_node(nb)
        target = output / f"{nb_path.stem}.html"
        target.write_text(body, encoding="utf-8")
        failed = any(
            o.get("output_type") == "error" for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
        )
        params = nb.metadata.get("papermill", {}).get("parameters", {})
        rows.append((target.name, _title(nb), nb_path.name, "failed" if failed else "ok", params))
    items = "\n".join(
        f'<tr><td><a href="{html.escape(href)}">{html.escape(title)}</a></td>'
        f"<td><code>{html.escape(src)}</code></td><td>{status}</td>"
        f"<td><code>{html.escape(json.dumps(params))}</code></td></tr>"
        for href, title, src, status, params in rows
    )
    index = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>ocpkit compendium report</title>
<style>body{{font-family:sans-serif;max-width:60em;margin:2em auto}}td,th{{padding:.3em .8em;text-align:left}}</style>
</head><body>
<h1>Optimal-control compendium: executed notebooks</h1>
<p>Every notebook below was executed headless by papermill (<code>make reproduce</code>).
Figures are in <code>figures/</code>, derived tables in <code>data/derived/</code>.</p>
<table><tr><th>notebook</th><th>source</th><th>status</th><th>parameters</th></tr>
{items}
</table></body></html>
"""
    (output / "index.html").write_text(index, encoding="utf-8")
    return output / "index.html"


def _parse_value(text: str):
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def _each(notebooks, verb: str):
    """The notebooks with a bar over them (one line per finished notebook stays)."""
    from tqdm import tqdm

    bar = tqdm(notebooks, desc=verb, unit="notebook", file=sys.stderr)
    for nb in bar:
        bar.set_postfix_str(nb.name)
        yield nb


def _say(line: str) -> None:
    from tqdm import tqdm

    tqdm.write(line, file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m compendium.notebooks", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="execute notebooks headless into an output folder")
    run.add_argument("notebooks", nargs="+", type=Path)
    run.add_argument("--output", type=Path, default=Path("build/notebooks"))
    run.add_argument("-p", "--parameter", nargs=2, action="append", default=[], metavar=("NAME", "VALUE"))
    run.add_argument("--kernel", default=KERNEL_NAME)
    rp = sub.add_parser(
        "reproduce",
        help="the published runs: each notebook with the parameters of "
        "notebooks/published.toml, executed into an output folder",
    )
    rp.add_argument("notebooks", nargs="+", type=Path)
    rp.add_argument("--output", type=Path, default=Path("build/notebooks"))
    rp.add_argument("--kernel", default=KERNEL_NAME)
    st = sub.add_parser("store", help="re-execute notebooks in place with default parameters")
    st.add_argument("notebooks", nargs="+", type=Path)
    st.add_argument("--kernel", default=KERNEL_NAME)
    rep = sub.add_parser("report", help="HTML report of executed notebooks")
    rep.add_argument("executed", type=Path)
    rep.add_argument("--output", type=Path, default=Path("build/report"))
    args = parser.parse_args(argv)

    try:
        if args.command in ("run", "reproduce"):
            given = {k: _parse_value(v) for k, v in args.parameter} if args.command == "run" else {}
            for nb in _each(args.notebooks, args.command):
                params = given if args.command == "run" else published_overrides(nb)
                out = execute(nb, args.output / nb.name, params, kernel=args.kernel, progress=True)
                _say(f"executed {nb} -> {out}")
        elif args.command == "store":
            for nb in _each(args.notebooks, "store"):
                store(nb, kernel=args.kernel, progress=True)
                _say(f"stored outputs of {nb}")
        else:
            print(f"report: {build_report(args.executed, args.output)}")
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
