"""One whole process: import ocpkit, pose a problem, solve it with HLGL, print t_f and IPOPT's iterations.

    python benchmarks/process/ocpkit_solve.py flat_moon|lunar_ascent [segments]

Timed from outside by ``benchmarks/bench_process.py`` against ``casadi_solve.py``, the same NLP written in plain
CasADi. The constants are those of ``data/problems/flat_moon.toml`` and ``lunar_ascent.toml``, written out so that
the process imports ocpkit alone (the compendium's problem modules read the repository and import SciPy);
``bench_process.py`` checks that t_f equals the compendium's own solve.
"""

import math
import sys

import casadi as ca

from ocpkit import HLGL, Control, FreeFinalTime, OptimalControlProblem, State


def flat_moon():
    g, a = 1.62, 3.0 * 1.62
    L, V, T = 1.0e5, 1.0e3, 100.0
    return OptimalControlProblem(
        "flat_moon_ascent",
        [
            State("x", initial=0.0, scale=L, guess=(0.0, 2.0e5)),
            State("y", initial=0.0, final=185.2e3, scale=L),
            State("vx", initial=0.0, final=1627.0, scale=V),
            State("vy", initial=0.0, final=0.0, scale=V),
        ],
        [Control("theta", -math.pi / 2, math.pi / 2, guess=0.5)],
        lambda x, u, t: ca.vertcat(x[2], x[3], a * ca.cos(u[0]), a * ca.sin(u[0]) - g),
        tf=FreeFinalTime(10.0, 2000.0, 500.0, scale=T),
        mayer=lambda x0, xf, t0, tf: tf,
        objective_scale=T,
    )


def lunar_ascent():
    R, g_moon = 1737.4e3, 1.62
    v = math.sqrt(g_moon * R)
    g, a, eps = 1.0, 3.0, 1.0e-8
    yf, uf = 1.0 + 185.2e3 / R, 1627.0 / v

    def dynamics(x, u, t):
        speed = ca.sqrt(x[2] ** 2 + x[3] ** 2 + eps**2)
        radius = ca.sqrt(x[0] ** 2 + x[1] ** 2)
        return ca.vertcat(
            x[2], x[3], a * ca.cos(u[0]) - 0.5 * g * speed / radius, a * ca.sin(u[0]) - g * speed / radius
        )

    return OptimalControlProblem(
        "lunar_ascent",
        [
            State("X", initial=0.0, guess=(0.0, 0.25)),
            State("Y", initial=1.0, final=yf),
            State("U", initial=0.0, final=uf),
            State("V", initial=0.0, final=0.0),
        ],
        [Control("theta", -math.pi, math.pi, guess=0.3)],
        dynamics,
        tf=FreeFinalTime(0.05, 5.0, 0.5),
        mayer=lambda x0, xf, t0, tf: tf,
    )


if __name__ == "__main__":
    name = sys.argv[1]
    segments = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    problem = {"flat_moon": flat_moon, "lunar_ascent": lunar_ascent}[name]()
    sol = HLGL(problem, segments).solve(error_threshold=None)
    print(f"{sol.tf:.12e} {sol.iterations}")
