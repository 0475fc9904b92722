"""ocpkit stands alone: its sdist and wheel, built as `make dist` builds them, hold the library and nothing of the
compendium, with metadata twine accepts; the wheel, installed with its [plot] extra in one fresh environment with no
repository around it, runs the Getting-started page's examples and draws their results, and solves an HLGL problem,
a Radau problem and a shooting problem with switching correction, each from an empty folder."""

import email
import re
import subprocess
import sys
import sysconfig
import tarfile
import textwrap
import zipfile
from pathlib import Path

import pytest
from _examples import DOCS, examples, run_session, same_print, section

REPO = Path(__file__).resolve().parents[1]
LIBRARY = sorted(p.relative_to(REPO / "src").as_posix() for p in (REPO / "src" / "ocpkit").rglob("*.py"))

SCRIPT = textwrap.dedent(
    """
    import pathlib, sys

    import casadi as ca
    import numpy as np

    import ocpkit
    from ocpkit import HLGL, Control, FreeFinalTime, OptimalControlProblem, Radau, State
    from ocpkit.shooting import Shooting, control_law
    from ocpkit.shooting.compiled import cache_dir

    here = pathlib.Path.cwd()
    assert pathlib.Path(ocpkit.__file__).is_relative_to(pathlib.Path(sys.prefix)), ocpkit.__file__
    try:
        import compendium  # noqa: F401
    except ImportError:
        pass
    else:
        raise AssertionError("the compendium package must not be reachable from the wheel's environment")

    # minimum time to travel 1 at rest to rest with |u| <= 1: t_f = 2, bang-bang
    problem = OptimalControlProblem(
        "rest_to_rest", [State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        [Control("u", -1.0, 1.0)], lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=FreeFinalTime(0.5, 5.0, 1.0), mayer=lambda x0, xf, t0, tf: tf)
    hlgl = HLGL(problem, intervals=20).solve()
    radau = Radau(problem, nodes=4, intervals=10).solve()
    print("hlgl", hlgl.tf, "radau", radau.tf)
    assert abs(hlgl.tf - 2.0) < 1e-2 and abs(radau.tf - 2.0) < 1e-2

    # minimum fuel, double integrator from (1, 0) to the origin in 3: u = -1, 0, +1, fuel 3 - sqrt(5)
    fuel = OptimalControlProblem(
        "fuel", [State("x1", initial=1.0, final=0.0), State("x2", initial=0.0, final=0.0)],
        [Control("u", -1.0, 1.0)], lambda x, u, t: ca.vertcat(x[1], u[0]), tf=3.0,
        lagrange=lambda x, u, t: ca.fabs(u[0]))
    s = Shooting(fuel, control_law(fuel, "box"), switching="correction", jacobian="variational",
                 rtol=1e-12, atol=1e-12)
    r = s.solve(np.array([0.9, 1.5]))
    print("shooting", r.objective, r.integration.switchings)
    assert abs(r.objective - (3 - np.sqrt(5))) < 1e-9 and r.integration.switchings == 2
    assert cache_dir().is_relative_to(here), cache_dir()
    assert list(cache_dir().glob("ocp_*.so")), "the compiled integrator is cached in the user cache"
    print("ok")
    """
)


#: run after the Getting-started page's examples, in their namespace: every result they made, drawn and saved
PLOT = textwrap.dedent(
    """
    import matplotlib
    import matplotlib.figure

    import ocpkit

    for name, value in list(globals().items()):
        if isinstance(value, ocpkit.Trajectory):
            figure = value.plot()
            assert isinstance(figure, matplotlib.figure.Figure), f"{name}.plot() returned {type(figure)}"
            assert any(axes.lines for axes in figure.axes), f"{name}.plot() drew no curve"
            figure.savefig(f"{name}.png")
            print(name)
    print("backend", matplotlib.get_backend().lower())
    """
)


def _bare_env(home: Path) -> dict[str, str]:
    """A user's environment, none of the repository's: no PYTHONPATH (src/ would shadow the installed ocpkit), a
    home and a cache of its own, no display."""
    return {"PATH": "/usr/bin:/bin", "HOME": str(home), "XDG_CACHE_HOME": str(home / ".cache")}


@pytest.fixture(scope="module")
def dist(tmp_path_factory) -> Path:
    """What `make dist` builds: the sdist, then the wheel built from it (python -m build unpacks the sdist and builds
    from that alone, so a file the sdist lacks fails the build)."""
    out = tmp_path_factory.mktemp("dist")
    cmd = [sys.executable, "-m", "build", "--quiet", "--no-isolation", "--outdir", str(out), str(REPO)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, (proc.stdout + proc.stderr)[-4000:]
    return out


@pytest.fixture(scope="module")
def wheel(dist) -> Path:
    (whl,) = dist.glob("ocpkit-*.whl")
    return whl


@pytest.fixture(scope="module")
def sdist(dist) -> Path:
    (archive,) = dist.glob("ocpkit-*.tar.gz")
    return archive


def _declared_closure(wheel: Path, extra: str) -> set[str]:
    """The entries of this environment's site-packages (packages, modules, .dist-info, .libs folders) of the
    distributions ``wheel`` requires with ``extra``, and of those they require, recursively."""
    from importlib import metadata

    from packaging.requirements import Requirement
    from packaging.utils import canonicalize_name

    with zipfile.ZipFile(wheel) as archive:
        (meta,) = [n for n in archive.namelist() if n.endswith(".dist-info/METADATA")]
        text = archive.read(meta).decode()
    todo = [(line.split(":", 1)[1].strip(), extra) for line in text.splitlines() if line.startswith("Requires-Dist:")]
    seen: set[str] = set()
    entries: set[str] = set()
    while todo:
        requirement, with_extra = todo.pop()
        req = Requirement(requirement)
        name = canonicalize_name(req.name)
        if name in seen or (req.marker is not None and not req.marker.evaluate({"extra": with_extra})):
            continue
        seen.add(name)
        dist = metadata.distribution(name)
        entries |= {f.parts[0] for f in dist.files or [] if f.parts[0] != ".." and not f.parts[0].endswith(".pth")}
        todo += [(r, "") for r in dist.requires or []]
    assert {"casadi", "numpy", "scipy", "pandas", "matplotlib"} <= seen, seen
    return entries


@pytest.fixture(scope="module")
def fresh_python(wheel, tmp_path_factory) -> Path:
    """The Python of a fresh virtual environment with `pip install "<wheel>[plot]"` done in it, offline: the
    dependencies (casadi, numpy, scipy, pandas, and matplotlib for the extra) are this environment's, seen through a
    folder of links to the files of exactly the distributions the wheel declares, and theirs (so an import of
    anything undeclared fails), without ocpkit, the compendium or any .pth file (this repository's src/, the
    editable install): pip finds them installed and installs the wheel alone."""
    root = tmp_path_factory.mktemp("fresh")
    env_dir = root / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(env_dir)], check=True)
    python = env_dir / "bin" / "python"
    view = root / "dependencies"
    view.mkdir()
    site = Path(sysconfig.get_paths()["purelib"])
    for name in sorted(_declared_closure(wheel, extra="plot")):
        (view / name).symlink_to(site / name)
    purelib = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    (Path(purelib) / "dependencies.pth").write_text(f"{view}\n")
    home = root / "home"
    home.mkdir()
    pip = [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-index", "--disable-pip-version-check"]
    proc = subprocess.run([*pip, f"{wheel}[plot]"], env=_bare_env(home), capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert re.search(r"Requirement already satisfied: matplotlib .*\(from ocpkit", proc.stdout), proc.stdout
    assert "Successfully installed ocpkit-" in proc.stdout, proc.stdout
    return python


def test_twine_accepts_the_metadata(dist):
    files = sorted(str(p) for p in dist.iterdir())
    proc = subprocess.run([sys.executable, "-m", "twine", "check", "--strict", *files], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.count("PASSED") == 2, proc.stdout


def test_sdist_holds_what_a_build_needs_and_not_the_compendium(sdist):
    with tarfile.open(sdist) as archive:
        top = sdist.name.removesuffix(".tar.gz")
        names = {m.name.removeprefix(top + "/") for m in archive.getmembers() if m.isfile()}
    needed = {"pyproject.toml", "LICENSE", "docs/ocpkit.md", "src/ocpkit/py.typed", "src/ocpkit/shooting/dopri5.c"}
    assert needed - names == set(), "the build reads these"
    assert {f"src/{module}" for module in LIBRARY} - names == set(), "every module of the library"
    compendium = [n for n in names if n.startswith(("src/compendium/", "tests/", "notebooks/", "data/", "figures/"))]
    assert compendium == [] and "README.md" not in names, "the compendium is not part of the library"


def test_wheel_holds_the_library_alone(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    assert "ocpkit/shooting/dopri5.c" in names, "the integrator's C source ships with the package"
    assert set(LIBRARY) - set(names) == set(), "every module of the library"
    assert not [n for n in names if n.startswith("compendium/")], "the compendium is not part of the library"
    # pure Python: dopri5.c is compiled on the user's machine at run time, so one wheel serves every platform
    assert wheel.name.endswith("-py3-none-any.whl"), wheel.name


def test_wheel_solves_from_a_fresh_environment(fresh_python, tmp_path):
    work = tmp_path / "elsewhere"
    work.mkdir()
    proc = subprocess.run(
        [str(fresh_python), "-c", SCRIPT], cwd=work, env=_bare_env(work), capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.strip().endswith("ok")


def test_wheel_runs_the_getting_started_page_and_plots_from_an_empty_folder(fresh_python, tmp_path):
    """The page's examples, in order, as a reader pastes them after the page's pip install line: what they print is
    what the page shows, and every result they make draws a figure with its plot() (headless: no display), saved."""
    page = DOCS / "getting-started.md"
    cases = examples(page.read_text())
    assert cases, f"{page.name} has no Python example"
    work = tmp_path / "empty"
    work.mkdir()
    printed, stderr = run_session([code for code, _ in cases] + [PLOT], work, python=fresh_python, env=_bare_env(work))
    assert printed is not None, stderr[-4000:]
    for k, ((_, shown), out) in enumerate(zip(cases, printed)):
        if shown is not None:
            assert same_print(out, shown) == [], f"example {k} of {page.name} printed\n{out}"
    *plotted, backend = printed[-1].splitlines()
    assert plotted and backend == "backend agg", printed[-1]
    for name in plotted:
        assert (work / f"{name}.png").read_bytes().startswith(b"\x89PNG"), name


def test_getting_started_installs_the_wheel_make_dist_builds(wheel):
    """The page's pip install line names the file make dist writes (its version, its tags), with the extra."""
    commands = re.findall(r"```sh\n(.*?)```", section(DOCS / "getting-started.md", "Install the library alone"), re.S)
    lines = [line.split("#")[0].strip() for block in commands for line in block.splitlines()]
    assert "make dist" in lines and f'pip install "dist/{wheel.name}[plot]"' in lines, lines


def test_wheel_metadata_describes_the_library(wheel):
    """The wheel's metadata: a licence expression, authors, classifiers, the Python it needs, the [plot] extra, the
    typed marker, and a long description of the library alone (not the compendium's make targets and notebooks)."""
    archive = zipfile.ZipFile(wheel)
    names = archive.namelist()
    assert "ocpkit/py.typed" in names
    (meta_name,) = [n for n in names if n.endswith(".dist-info/METADATA")]
    meta = email.message_from_string(archive.read(meta_name).decode())
    assert meta["License-Expression"] == "BSD-3-Clause"
    assert meta["Author"] == "the ocpkit compendium authors"
    assert meta["Requires-Python"] == ">=3.11"
    assert meta.get_all("Provides-Extra") == ["plot"]
    assert 'matplotlib; extra == "plot"' in meta.get_all("Requires-Dist")
    classifiers = meta.get_all("Classifier")
    assert "Typing :: Typed" in classifiers and "Programming Language :: Python :: 3.11" in classifiers
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    assert meta["Description-Content-Type"] == "text/markdown"
    description = meta.get_payload()
    assert description.startswith("# ocpkit") and "make " not in description and "notebooks/" not in description


def test_the_fresh_environment_holds_only_what_the_wheel_declares(fresh_python):
    """An undeclared import of the library would fail for a user: here too (tqdm and papermill are the compendium's)."""
    for module in ("tqdm", "papermill", "compendium"):
        proc = subprocess.run([str(fresh_python), "-c", f"import {module}"], capture_output=True, text=True)
        assert proc.returncode != 0 and "ModuleNotFoundError" in proc.stderr, (module, proc.stderr)
