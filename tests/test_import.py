"""`import ocpkit` stays light: SciPy, pandas and matplotlib load only when a function needs them (issue 14)."""

import subprocess
import sys


def test_import_ocpkit_loads_neither_scipy_nor_pandas_nor_matplotlib():
    code = (
        "import sys, ocpkit\n"
        "heavy = sorted(m for m in ('scipy', 'pandas', 'matplotlib') if m in sys.modules)\n"
        "print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout.strip()
    assert out == "", f"import ocpkit loaded {out}"


def test_a_solve_needs_none_of_them_either():
    """A transcription builds, solves and estimates its error with numpy and CasADi alone, and so does a
    refinement's stop test, which flies the control (the objective part of ``Solution.accuracy``) with CVODES
    through CasADi (a second mesh's multiplier estimate loads scipy.sparse)."""
    code = (
        "import sys\n"
        "import casadi as ca\n"
        "from ocpkit import HLGL, Radau, Control, OptimalControlProblem, State\n"
        "p = OptimalControlProblem('e', [State('x', initial=0.0, final=1.0), State('v', initial=0.0, final=0.0)],\n"
        "    [Control('u')], lambda x, u, t: ca.vertcat(x[1], u[0]), tf=1.0, lagrange=lambda x, u, t: u[0] ** 2)\n"
        "for tr in (HLGL(p, 4), Radau(p, 4, 2)):\n"
        "    s = tr.solve()\n"
        "    s.state(0.5), s.control(0.5), s.state_error\n"
        "print(','.join(sorted(m for m in ('scipy', 'pandas', 'matplotlib') if m in sys.modules)))\n"
        "HLGL(p, 4).solve(mesh_tolerance=1e-8)\n"
        "print(','.join(sorted(m for m in ('scipy', 'pandas', 'matplotlib') if m in sys.modules)))"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout.split("\n")
    assert out[0] == "", f"a solve loaded {out[0]}"
    assert out[1] == "", f"a refinement's stop test loaded {out[1]}"


def test_a_solve_does_not_load_numpy_ma():
    """NumPy 2.4's ``np.unique`` imports ``numpy.ma`` on its first plain call, about 20 ms of a whole short
    process: the build, solve and error estimate use ``ocpkit._arrays.unique`` instead (issue 26)."""
    code = (
        "import sys\n"
        "from ocpkit import HLGL, Radau\n"
        "from compendium.problems import flat_moon_ascent\n"
        "for tr in (HLGL(flat_moon_ascent(), 10), Radau(flat_moon_ascent(), 4, 3)):\n"
        "    tr.solve().state_error\n"
        "print('numpy.ma' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout.strip()
    assert out == "False"


def test_posing_a_compendium_problem_loads_neither_scipy_nor_pandas():
    """The compendium's problem modules import SciPy (the linear-tangent solution) and pandas (the gas-oil
    measurements) only in the functions that need them, so its one-liner costs about a plain CasADi solve."""
    code = (
        "import sys\n"
        "from compendium.problems import flat_moon_ascent, lunar_ascent, entry_landing, gasoil\n"
        "flat_moon_ascent(), lunar_ascent(), entry_landing()\n"
        "print(','.join(sorted(m for m in ('scipy', 'pandas', 'matplotlib') if m in sys.modules)))\n"
        "gasoil()\n"
        "print('pandas' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout.split("\n")
    assert out[0] == "", f"posing a problem loaded {out[0]}"
    assert out[1] == "True"  # the measurements are read with pandas when they are needed


def test_unique_is_numpys():
    import numpy as np

    from ocpkit._arrays import unique

    rng = np.random.default_rng(0)
    for values in (rng.integers(0, 7, 50), rng.normal(size=(4, 5)).round(1), np.array([], dtype=int), [3, 3, 1]):
        got, want = unique(values), np.unique(values)
        assert got.dtype == want.dtype and np.array_equal(got, want)
