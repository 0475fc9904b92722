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
        "    s.state(0.5), s.control(0.5), s.error_estimate\n"
        "print(','.join(sorted(m for m in ('scipy', 'pandas', 'matplotlib') if m in sys.modules)))\n"
        "HLGL(p, 4).solve(mesh_tolerance=1e-8)\n"
        "print(','.join(sorted(m for m in ('scipy', 'pandas', 'matplotlib') if m in sys.modules)))"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout.split("\n")
    assert out[0] == "", f"a solve loaded {out[0]}"
    assert out[1] == "", f"a refinement's stop test loaded {out[1]}"
