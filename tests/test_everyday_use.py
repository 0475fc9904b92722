"""Everyday use never rewrites the published record nor loses a run: a copied notebook, a Lab-style run, two runs at
once, a misspelt papermill parameter, a killed run. Each runs real kernels on a throw-away compendium
(``OCPKIT_ROOT``) holding one small notebook, so the repository's record is never touched (about 40 s)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import nbformat
import pandas as pd
import pytest

from compendium.notebooks import KERNEL_NAME
from compendium.provenance import ONE_THREAD

NOTEBOOK = "10_tiny"


def _kernel_available() -> bool:
    from jupyter_client.kernelspec import KernelSpecManager

    return KERNEL_NAME in KernelSpecManager().find_kernel_specs()


pytestmark = pytest.mark.skipif(not _kernel_available(), reason="the 'ocpkit' kernel is registered by `make setup`")


def _cell(source: str, tags=()):
    cell = nbformat.v4.new_code_cell(source)
    if tags:
        cell.metadata["tags"] = list(tags)
    return cell


@pytest.fixture
def compendium(tmp_path, monkeypatch):
    """A compendium of one notebook: a figure and a table, a parameter to pause in the middle of the run."""
    root = tmp_path / "compendium"
    (root / "data").mkdir(parents=True)
    (root / "notebooks").mkdir()
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": KERNEL_NAME, "display_name": "Python (ocpkit)", "language": "python"}
    nb.cells = [
        nbformat.v4.new_markdown_cell("# A small notebook"),
        _cell(
            'n = 3  # points\nresume = ""  # a file: the run waits between the table and the figure until it exists',
            ["parameters"],
        ),
        _cell(
            "import os\nimport time\n\nimport matplotlib.pyplot as plt\nimport numpy as np\nimport pandas as pd\n\n"
            "from compendium.outputs import Outputs\n\n"
            f'outputs = Outputs.start("{NOTEBOOK}", globals())'
        ),
        _cell(
            'x = np.linspace(0, 1, n)\noutputs.table(pd.DataFrame({"x": x, "y": x**2}), "tiny")\n'
            "while resume and not os.path.exists(resume):\n    time.sleep(0.05)"
        ),
        _cell('fig, ax = plt.subplots()\nax.plot(x, x**2)\nax.set_title("y = x^2")\noutputs.figure(fig, "tiny")'),
        _cell("outputs.publish()"),
    ]
    nbformat.write(nb, str(root / "notebooks" / f"{NOTEBOOK}.ipynb"))
    (root / "notebooks" / "published.toml").write_text("")
    (root / "notebooks" / "contract.toml").write_text(
        f'["{NOTEBOOK}".tables.tiny]\nconverged = ["x", "y"]\n["{NOTEBOOK}".figures.tiny]\n'
    )
    monkeypatch.setenv("OCPKIT_ROOT", str(root))
    for name in ("OCPKIT_OUTPUT_DIR", "OCPKIT_RUNS_DIR"):
        monkeypatch.delenv(name, raising=False)
    return root


def _env(root: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("OCPKIT_OUTPUT_DIR", "OCPKIT_RUNS_DIR")}
    return env | {"OCPKIT_ROOT": str(root), "OCPKIT_PROGRESS": "off"}


def _run(args, root: Path, cwd: Path | None = None, timeout: int = 180) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, *args], cwd=cwd or root, env=_env(root), capture_output=True, text=True, timeout=timeout
    )


def _record(folder: Path) -> dict:
    return json.loads((folder / "data" / "derived" / "runs" / f"{NOTEBOOK}.json").read_text())


def _published(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for d in ("figures", "data/derived") for p in (root / d).rglob("*"))


def test_a_copied_and_edited_notebook_run_with_papermill_never_publishes(compendium):
    scratch = compendium / "build" / "scratch"
    scratch.mkdir(parents=True)
    nb = nbformat.read(str(compendium / "notebooks" / f"{NOTEBOOK}.ipynb"), as_version=4)
    nb.cells[4].source = nb.cells[4].source.replace('"y = x^2"', '"my own title"')
    nbformat.write(nb, str(scratch / "my_try.ipynb"))
    proc = _run(["-m", "papermill", "-k", KERNEL_NAME, "my_try.ipynb", "my_try_out.ipynb"], compendium, cwd=scratch)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert _published(compendium) == [], "the published record is untouched"
    folder = compendium / "build" / "runs" / NOTEBOOK / "defaults"
    assert (folder / "figures" / "tiny.png").is_file()
    executed = nbformat.read(str(scratch / "my_try_out.ipynb"), as_version=4)
    first_line = executed.cells[2].outputs[0]["text"].splitlines()[0]
    assert first_line.startswith(f"This run writes its figures and tables to build/runs/{NOTEBOOK}/defaults/")
    refused = _run(["-m", "compendium.notebooks", "publish", str(folder)], compendium)
    assert refused.returncode == 2 and f"is not that of notebooks/{NOTEBOOK}.ipynb" in refused.stderr
    assert _published(compendium) == []


def test_a_lab_style_run_writes_its_own_folder_and_publishes_only_on_request(compendium, monkeypatch):
    """Cells executed one by one on a kernel, as JupyterLab's Run All does (no papermill), in a Lab started without
    make's environment: the registered kernel has make's one BLAS and one OpenMP thread all the same."""
    from nbclient import NotebookClient

    path = compendium / "notebooks" / f"{NOTEBOOK}.ipynb"
    folder = compendium / "build" / "runs" / NOTEBOOK / "defaults"
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    nb = nbformat.read(str(path), as_version=4)
    NotebookClient(nb, kernel_name=KERNEL_NAME, resources={"metadata": {"path": str(compendium)}}).execute()
    assert _record(folder)["threads"] == ONE_THREAD, "the kernelspec's environment wins over its caller's"
    assert _published(compendium) == []
    assert nb.cells[2].outputs[0]["text"].startswith(f"This run writes its figures and tables to build/runs/{NOTEBOOK}")
    assert _record(folder)["published_parameters"] is True
    proc = _run(["-m", "compendium.notebooks", "publish", str(folder)], compendium)
    assert proc.returncode == 0, proc.stderr
    assert "figures/tiny.png" in _published(compendium) and "figures/data/tiny.json" in _published(compendium)


def test_two_runs_at_once_with_other_parameters_both_survive(compendium, tmp_path):
    out = tmp_path / "custom"
    procs = [
        subprocess.Popen(
            [
                sys.executable,
                "-m",
                "compendium.notebooks",
                "run",
                f"notebooks/{NOTEBOOK}.ipynb",
                "-p",
                "n",
                str(n),
                "--output",
                str(out),
            ],
            cwd=compendium,
            env=_env(compendium),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )  # fmt: skip
        for n in (30, 50)
    ]
    results = [p.communicate(timeout=180) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], [r[1][-2000:] for r in results]
    for n, (_, stderr) in zip((30, 50), results):
        folder = out / NOTEBOOK / f"n-{n}"
        assert _record(folder)["parameters"]["n"] == n and (folder / "figures" / "tiny.png").is_file()
        assert (folder / f"{NOTEBOOK}.ipynb").is_file(), "the executed notebook sits beside its figures"
        assert f"{NOTEBOOK}/n-{n}/" in stderr, "the terminal says where the figures and tables went"
    assert _published(compendium) == []


def test_a_misspelt_parameter_is_an_error_with_papermill_too(compendium, tmp_path):
    proc = _run(
        [
            "-m",
            "papermill",
            "-k",
            KERNEL_NAME,
            f"notebooks/{NOTEBOOK}.ipynb",
            str(tmp_path / "o.ipynb"),
            "-p",
            "nn",
            "4",
        ],
        compendium,
    )
    assert proc.returncode != 0 and "unknown parameter(s) ['nn']" in proc.stderr
    assert not (compendium / "build" / "runs").exists() and _published(compendium) == []
    runner = _run(["-m", "compendium.notebooks", "run", f"notebooks/{NOTEBOOK}.ipynb", "-p", "nn", "4"], compendium)
    assert runner.returncode == 2 and "unknown parameter(s) ['nn']" in runner.stderr


def test_a_killed_run_leaves_no_sockets_and_its_staging_goes_with_the_next_run(compendium):
    resume = compendium.parent / "resume"  # not there: the run waits, until it is killed
    args = ["-m", "compendium.notebooks", "run", f"notebooks/{NOTEBOOK}.ipynb", "-p", "resume", str(resume)]
    proc = subprocess.Popen(
        [sys.executable, *args], cwd=compendium, env=_env(compendium), start_new_session=True,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    runs = compendium / "build" / "runs" / NOTEBOOK
    deadline = time.monotonic() + 120
    while not any((p / "data").exists() for p in runs.glob("*/.staging/*")):
        assert proc.poll() is None and time.monotonic() < deadline, "the run did not reach its pause"
        time.sleep(0.2)
    (folder,) = [p for p in runs.iterdir() if p.is_dir()]
    staging = folder / ".staging"
    (entry,) = list(staging.iterdir())
    kernel_pid = int(entry.name.split("-")[-2])
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    deadline = time.monotonic() + 30
    while True:  # the kernel notices its parent is gone and exits without cleaning up
        try:
            os.kill(kernel_pid, 0)
        except ProcessLookupError:
            break
        if time.monotonic() > deadline:
            os.kill(kernel_pid, signal.SIGKILL)
        time.sleep(0.2)
    assert entry.is_dir(), "a killed run leaves its staging folder"
    leftovers = [p.name for d in (compendium, folder) for p in d.iterdir() if p.name.startswith("kernel")]
    assert leftovers == [], "no IPC sockets in the user's folders"
    resume.touch()
    again = _run(args, compendium)  # the same run, in full
    assert again.returncode == 0, again.stderr[-2000:]
    assert not entry.exists() and not staging.exists(), "the next run into the folder removed the leftovers"
    assert (folder / "figures" / "tiny.png").is_file()


def _commit(root: Path) -> None:
    identity = ["-c", "user.name=test", "-c", "user.email=test@localhost", "-c", "commit.gpgsign=false"]
    for args in (["init", "-q"], ["add", "-A"], [*identity, "commit", "-q", "-m", "the compendium"]):
        subprocess.run(["git", *args], cwd=root, check=True, capture_output=True)


def _lab_style_run(compendium: Path, nb) -> None:
    from nbclient import NotebookClient

    NotebookClient(nb, kernel_name=KERNEL_NAME, resources={"metadata": {"path": str(compendium)}}).execute()


def test_the_tracked_notebook_edited_and_saved_is_not_the_committed_one(compendium):
    """In a git checkout, the committed notebook is HEAD's: an edit saved over the tracked file does not publish."""
    _commit(compendium)
    path = compendium / "notebooks" / f"{NOTEBOOK}.ipynb"
    nb = nbformat.read(str(path), as_version=4)
    nb.cells[3].source = nb.cells[3].source.replace("x**2", "x**3")
    nbformat.write(nb, str(path))  # saved, not committed
    _lab_style_run(compendium, nb)
    folder = compendium / "build" / "runs" / NOTEBOOK / "defaults"
    refused = _run(["-m", "compendium.notebooks", "publish", str(folder)], compendium)
    assert refused.returncode == 2 and f"notebooks/{NOTEBOOK}.ipynb as committed (HEAD)" in refused.stderr
    assert _published(compendium) == []


def test_a_cell_made_to_look_like_papermill_s_does_not_slip_past_the_digests(compendium):
    _commit(compendium)
    nb = nbformat.read(str(compendium / "notebooks" / f"{NOTEBOOK}.ipynb"), as_version=4)
    nb.cells.insert(3, _cell("# Parameters\nn = 50"))  # run in the session, never saved
    _lab_style_run(compendium, nb)
    folder = compendium / "build" / "runs" / NOTEBOOK / "defaults"
    refused = _run(["-m", "compendium.notebooks", "publish", str(folder)], compendium)
    assert refused.returncode == 2 and "is not that of" in refused.stderr and _published(compendium) == []


def test_the_runner_says_where_a_copy_s_figures_went(compendium):
    copy = compendium / "notebooks" / "11_copy.ipynb"
    copy.write_bytes((compendium / "notebooks" / f"{NOTEBOOK}.ipynb").read_bytes())
    proc = _run(["-m", "compendium.notebooks", "run", "notebooks/11_copy.ipynb"], compendium)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert f"into build/runs/11_copy/defaults/; its figures and tables are in build/runs/{NOTEBOOK}/defaults/" in (
        proc.stderr
    )
    assert (compendium / "build" / "runs" / NOTEBOOK / "defaults" / "figures" / "tiny.png").is_file()


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_failing_notebook_stops_neither_the_others_nor_the_report(compendium, jobs):
    """make reproduce's runner: a notebook that raises publishes nothing; the next one still runs and publishes, the
    report is built with the failure on its page, the runner fails naming it, and no executed notebook of an earlier
    run is left in the report; the same with two notebooks at once, each in its own process."""
    broken = nbformat.read(str(compendium / "notebooks" / f"{NOTEBOOK}.ipynb"), as_version=4)
    broken.cells.insert(4, _cell('raise RuntimeError("the solver said no")'))
    broken.cells[2].source = broken.cells[2].source.replace(f'"{NOTEBOOK}"', '"09_broken"')
    for cell in broken.cells[3:]:
        cell.source = cell.source.replace('"tiny"', '"broken"')
    nbformat.write(broken, str(compendium / "notebooks" / "09_broken.ipynb"))
    (compendium / "notebooks" / "contract.toml").write_text(
        (compendium / "notebooks" / "contract.toml").read_text() + '["09_broken".figures.broken]\n'
    )
    executed = compendium / "build" / "notebooks"
    executed.mkdir(parents=True)
    earlier = nbformat.read(str(compendium / "notebooks" / f"{NOTEBOOK}.ipynb"), as_version=4)
    earlier.metadata["papermill"] = {"parameters": {}}  # an executed notebook of an earlier run
    nbformat.write(earlier, str(executed / "08_earlier.ipynb"))
    args = ["notebooks/09_broken.ipynb", f"notebooks/{NOTEBOOK}.ipynb", "--output", "build/notebooks", "--jobs", jobs]
    proc = _run(["-m", "compendium.notebooks", "reproduce", *args, "--report", "build/report"], compendium)
    assert proc.returncode == 1, proc.stderr[-2000:]
    assert "error: notebooks/09_broken.ipynb did not complete, nothing of it was published" in proc.stderr
    assert "RuntimeError: the solver said no" in proc.stderr
    assert sorted(p.name for p in executed.glob("*.ipynb")) == ["09_broken.ipynb", f"{NOTEBOOK}.ipynb"]
    recorded = json.loads((executed / "unfinished-runs.json").read_text())
    assert list(recorded) == ["09_broken.ipynb"] and recorded["09_broken.ipynb"][0] == "stopped"
    published = _published(compendium)
    assert "figures/tiny.png" in published and not [p for p in published if "broken" in p]
    report = compendium / "build" / "report"
    assert sorted(p.name for p in report.glob("*.html")) == ["09_broken.html", f"{NOTEBOOK}.html", "index.html"]
    assert "the solver said no" in (report / "09_broken.html").read_text()
    assert "1 of 2 notebooks failed" in proc.stderr
    assert "1 notebook stopped before the end" in (report / "index.html").read_text()
    (report / "09_broken.html").unlink()
    again = _run(["-m", "compendium.notebooks", "report", "build/notebooks", "--output", "build/report"], compendium)
    assert again.returncode == 0, again.stderr[-2000:]
    assert "1 notebook stopped before the end" in (report / "index.html").read_text(), "make report says the same"


def test_notebooks_run_at_once_and_one_that_reads_anothers_record_reads_this_runs(compendium):
    """make reproduce --jobs 2: notebook 10 reads notebook 05's published record (READS_PUBLISHED), so it starts
    once 05's run is published and reads that run's table, not an earlier one; the others run beside them."""
    notebooks = compendium / "notebooks"
    source = nbformat.read(str(notebooks / f"{NOTEBOOK}.ipynb"), as_version=4)

    def variant(name: str, body: str) -> None:
        nb = nbformat.read(str(notebooks / f"{NOTEBOOK}.ipynb"), as_version=4)
        nb.cells[2].source = source.cells[2].source.replace(f'"{NOTEBOOK}"', f'"{name}"')
        nb.cells[3:] = [_cell(body), _cell("outputs.publish()")]
        nbformat.write(nb, str(notebooks / f"{name}.ipynb"))

    variant(
        "05_orbit_transfer",
        'time.sleep(3)\noutputs.table(pd.DataFrame({"token": [time.time_ns()]}), "token")',
    )
    variant(
        "10_direct_to_indirect",
        "from compendium.paths import published_derived_dir\n\n"
        'seen = pd.read_csv(published_derived_dir() / "token.csv")\n'
        'outputs.table(pd.DataFrame({"seen": seen.token}), "seen")',
    )
    (compendium / "data" / "derived").mkdir(parents=True, exist_ok=True)
    pd.DataFrame({"token": [0]}).to_csv(compendium / "data" / "derived" / "token.csv", index=False)  # an earlier run's
    (notebooks / "contract.toml").write_text(
        (notebooks / "contract.toml").read_text()
        + '["05_orbit_transfer".tables.token]\nconverged = ["token"]\n'
        + '["10_direct_to_indirect".tables.seen]\nconverged = ["seen"]\n'
    )
    order = [
        "notebooks/10_direct_to_indirect.ipynb",
        "notebooks/05_orbit_transfer.ipynb",
        f"notebooks/{NOTEBOOK}.ipynb",
    ]
    proc = _run(
        ["-m", "compendium.notebooks", "reproduce", *order, "--output", "build/notebooks", "--jobs", "2"], compendium
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "3 notebooks, 2 at once" in proc.stderr
    derived = compendium / "data" / "derived"
    token = pd.read_csv(derived / "token.csv").token.iloc[0]
    assert token > 0 and pd.read_csv(derived / "seen.csv").seen.iloc[0] == token
    assert "figures/tiny.png" in _published(compendium)


def test_a_notebook_whose_process_dies_stops_only_its_own_run(compendium):
    """make reproduce --jobs 2: a run whose process is killed (its kernel kills it, once the notebook that waited has
    started beside it) is reported as stopped; the runs beside it run to their end and publish. (In one shared pool
    of processes the death failed the run beside it, and crashed the runner when the next run was submitted after
    the death but before it was reported.)"""
    notebooks = compendium / "notebooks"
    beside = compendium / "build" / "notebooks" / "10_after.ipynb"  # written as its run starts
    killer = (  # dies while the notebook that waited runs beside it: the kernel kills its parent, the run's process
        f"import os, pathlib, signal, time\n\nfor _ in range(600):\n    if pathlib.Path({str(beside)!r}).exists():\n"
        "        break\n    time.sleep(0.1)\nelse:\n    raise RuntimeError('the notebook that waited never started')\n"
        "os.kill(os.getppid(), signal.SIGKILL)"
    )
    for name, body in (("08_killer", killer), ("10_after", 'outputs.table(pd.DataFrame({"x": [1.0]}), "after")')):
        nb = nbformat.read(str(notebooks / f"{NOTEBOOK}.ipynb"), as_version=4)
        nb.cells[2].source = nb.cells[2].source.replace(f'"{NOTEBOOK}"', f'"{name}"')
        nb.cells[3:] = [_cell(body), _cell("outputs.publish()")]
        nbformat.write(nb, str(notebooks / f"{name}.ipynb"))
    (notebooks / "contract.toml").write_text(
        (notebooks / "contract.toml").read_text() + '["10_after".tables.after]\nconverged = ["x"]\n'
    )
    given = ["notebooks/08_killer.ipynb", f"notebooks/{NOTEBOOK}.ipynb", "notebooks/10_after.ipynb"]
    proc = _run(
        ["-m", "compendium.notebooks", "reproduce", *given, "--output", "build/notebooks", "--jobs", "2"], compendium
    )
    assert proc.returncode == 1, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    failed = [line.split()[1] for line in proc.stderr.splitlines() if line.startswith("error: notebooks/")]
    assert failed == ["notebooks/08_killer.ipynb"], proc.stderr[-3000:]
    assert "its process ended abruptly" in proc.stderr
    published = _published(compendium)
    assert {"data/derived/after.csv", "figures/tiny.png"} <= set(published), proc.stderr[-3000:]


def test_reproduce_checks_every_notebook_and_its_output_before_it_removes_or_runs_anything(compendium):
    """A wrong notebook name, a notebook outside notebooks/, published parameters it cannot use, an output folder
    that is the notebooks' own, a report folder that is a file: all named at once, exit status 2, and nothing removed
    nor run."""
    notebooks = compendium / "notebooks"
    (notebooks / "published.toml").write_text(f'[{NOTEBOOK}]\nsize = "not python("\n')
    (compendium / "elsewhere.ipynb").write_bytes((notebooks / f"{NOTEBOOK}.ipynb").read_bytes())
    (compendium / "report.html").write_text("")
    before = sorted(p.name for p in notebooks.iterdir())
    args = [f"notebooks/{NOTEBOOK}.ipynb", "notebooks/09_missing.ipynb", "elsewhere.ipynb"]
    args += ["--output", "notebooks", "--report", "report.html"]
    proc = _run(["-m", "compendium.notebooks", "reproduce", *args], compendium)
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert "error: nothing was run:" in proc.stderr
    assert "notebooks/09_missing.ipynb: no such notebook" in proc.stderr
    assert "elsewhere.ipynb: not one of the compendium's notebooks" in proc.stderr
    assert "--output notebooks is the notebooks' own folder" in proc.stderr
    assert "--report report.html is a file, not a folder" in proc.stderr
    assert f"notebooks/{NOTEBOOK}.ipynb: its published parameters (notebooks/published.toml)" in proc.stderr
    assert sorted(p.name for p in notebooks.iterdir()) == before
    assert not (compendium / "figures").exists() or not any((compendium / "figures").iterdir())


def test_reproduce_with_a_kernel_that_does_not_exist_says_so_and_publishes_nothing(compendium):
    proc = _run(
        ["-m", "compendium.notebooks", "reproduce", f"notebooks/{NOTEBOOK}.ipynb", "--kernel", "no-such-kernel"],
        compendium,
    )
    assert proc.returncode == 1, proc.stderr[-2000:]
    assert f"error: notebooks/{NOTEBOOK}.ipynb " in proc.stderr and "NoSuchKernel" in proc.stderr
    assert "Traceback" in proc.stderr, "a stop the notebook does not explain shows where it came from"
    assert _published(compendium) == [] or not [p for p in _published(compendium) if "tiny" in p]
