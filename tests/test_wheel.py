"""ocpkit stands alone: its wheel, installed in a fresh environment with no repository around it, solves
an HLGL problem, a Radau problem and a shooting problem with switching correction from a temporary folder."""

import subprocess
import sys
import sysconfig
import textwrap
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

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


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("dist")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(out), str(REPO)],
        check=True,
        capture_output=True,
        text=True,
    )
    (whl,) = out.glob("ocpkit-*.whl")
    return whl


def test_wheel_holds_the_library_alone(wheel):
    import zipfile

    names = zipfile.ZipFile(wheel).namelist()
    assert "ocpkit/shooting/dopri5.c" in names, "the integrator's C source ships with the package"
    assert not [n for n in names if n.startswith("compendium/")], "the compendium is not part of the library"


def test_wheel_solves_from_a_fresh_environment(wheel, tmp_path):
    env_dir = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(env_dir)], check=True)
    python = env_dir / "bin" / "python"
    subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-index", str(wheel)], check=True)
    # the dependencies (casadi, numpy, scipy, pandas) come from this environment's site-packages, added as a
    # plain path: its .pth files (this repository's src/, the editable install) are not processed
    purelib = Path(
        subprocess.run(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            check=True,
            capture_output=True,
            text=True,
        ).stdout.strip()
    )
    (purelib / "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {"PATH": "/usr/bin:/bin", "HOME": str(work), "XDG_CACHE_HOME": str(work / ".cache")}
    proc = subprocess.run([str(python), "-c", SCRIPT], cwd=work, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.strip().endswith("ok")


def test_wheel_metadata_describes_the_library(wheel):
    """The wheel's metadata: a licence expression, authors, classifiers, the typed marker, and a long description
    of the library alone (not the compendium's make targets and notebooks)."""
    import email
    import zipfile

    archive = zipfile.ZipFile(wheel)
    names = archive.namelist()
    assert "ocpkit/py.typed" in names
    (meta_name,) = [n for n in names if n.endswith(".dist-info/METADATA")]
    meta = email.message_from_string(archive.read(meta_name).decode())
    assert meta["License-Expression"] == "BSD-3-Clause"
    assert meta["Author"] == "the ocpkit compendium authors"
    classifiers = meta.get_all("Classifier")
    assert "Typing :: Typed" in classifiers and "Programming Language :: Python :: 3.11" in classifiers
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    description = meta.get_payload()
    assert description.startswith("# ocpkit") and "make " not in description and "notebooks/" not in description
