"""The same solve as ``ocpkit_solve.py``, in plain CasADi: HLGL (Herman & Conway) written out, IPOPT with the
same options and the same starting point. Prints t_f and IPOPT's iterations.

    python benchmarks/process/casadi_solve.py flat_moon|lunar_ascent [segments]

The baseline of ``benchmarks/bench_process.py``: what a researcher writing the transcription by hand in CasADi
would run. Vectorised as CasADi's own examples do (one segment function, mapped over the segments).
"""

import math
import sys

import casadi as ca
import numpy as np

S21 = math.sqrt(21.0)
IPOPT = {
    "print_level": 0,
    "sb": "yes",
    "tol": 1e-10,
    "max_iter": 3000,
    "mu_strategy": "adaptive",
    "mumps_pivot_order": 6,
    "mumps_permuting_scaling": 0,
}


def flat_moon():
    """Scaled variables: positions / 1e5 m, velocities / 1e3 m/s, time / 100 s."""
    g, a = 1.62, 3.0 * 1.62
    L, V, T = 1.0e5, 1.0e3, 100.0

    def f(x, u):
        return ca.vertcat(x[2] * V * T / L, x[3] * V * T / L, a * ca.cos(u[0]) * T / V, (a * ca.sin(u[0]) - g) * T / V)

    return dict(
        f=f,
        x0=[0.0, 0.0, 0.0, 0.0],
        xf=[None, 185.2e3 / L, 1627.0 / V, 0.0],
        x_guess=([0.0, 0.0, 0.0, 0.0], [2.0e5 / L, 185.2e3 / L, 1627.0 / V, 0.0]),
        u_bounds=(-math.pi / 2, math.pi / 2),
        u_guess=0.5,
        tf_bounds=(0.1, 20.0),
        tf_guess=5.0,
        tf_unit=T,
    )


def lunar_ascent():
    R, g_moon = 1737.4e3, 1.62
    v = math.sqrt(g_moon * R)
    g, a, eps = 1.0, 3.0, 1.0e-8
    yf, uf = 1.0 + 185.2e3 / R, 1627.0 / v

    def f(x, u):
        speed = ca.sqrt(x[2] ** 2 + x[3] ** 2 + eps**2)
        radius = ca.sqrt(x[0] ** 2 + x[1] ** 2)
        return ca.vertcat(
            x[2], x[3], a * ca.cos(u[0]) - 0.5 * g * speed / radius, a * ca.sin(u[0]) - g * speed / radius
        )

    return dict(
        f=f,
        x0=[0.0, 1.0, 0.0, 0.0],
        xf=[None, yf, uf, 0.0],
        x_guess=([0.0, 1.0, 0.0, 0.0], [0.25, yf, uf, 0.0]),
        u_bounds=(-math.pi, math.pi),
        u_guess=0.3,
        tf_bounds=(0.05, 5.0),
        tf_guess=0.5,
        tf_unit=1.0,
    )


def solve(p, n):
    nx = len(p["x0"])
    X = ca.MX.sym("X", nx, 2 * n + 1)  # states at segment ends and centres
    U = ca.MX.sym("U", 1, 4 * n + 1)  # controls at the five Lobatto points of each segment
    tf = ca.MX.sym("tf")
    # one segment: states at its three nodes, controls at its five points, its length h
    xi, xc, xe = (ca.SX.sym(k, nx) for k in ("xi", "xc", "xe"))
    u5 = ca.SX.sym("u", 5)
    h = ca.SX.sym("h")
    f = p["f"]
    fi, fc, fe = f(xi, u5[0]), f(xc, u5[2]), f(xe, u5[4])
    xa = (
        (231 + 39 * S21) * xi
        + 224 * xc
        + (231 - 39 * S21) * xe
        + h * ((21 + 3 * S21) * fi - 16 * S21 * fc + (3 * S21 - 21) * fe)
    ) / 686
    xb = (
        (231 - 39 * S21) * xi
        + 224 * xc
        + (231 + 39 * S21) * xe
        + h * ((21 - 3 * S21) * fi + 16 * S21 * fc - (21 + 3 * S21) * fe)
    ) / 686
    fa, fb = f(xa, u5[1]), f(xb, u5[3])
    c1 = (
        (180 + 32 * S21) * xi
        - 64 * S21 * xc
        + (32 * S21 - 180) * xe
        + h * ((9 + S21) * fi + 98 * fa + 64 * fc + (9 - S21) * fe)
    ) / 360
    c2 = (
        (180 - 32 * S21) * xi
        + 64 * S21 * xc
        - (180 + 32 * S21) * xe
        + h * ((9 - S21) * fi + 98 * fb + 64 * fc + (9 + S21) * fe)
    ) / 360
    segment = ca.Function("segment", [xi, xc, xe, u5, h], [ca.vertcat(c1, c2)]).map(n)
    Useg = ca.vertcat(*[U[0, k : k + 4 * (n - 1) + 1 : 4] for k in range(4)], U[0, 4 : 4 * n + 1 : 4])
    defects = segment(X[:, 0:-1:2], X[:, 1::2], X[:, 2::2], Useg, tf / n)
    w = ca.veccat(X, U, tf)
    g = ca.vec(defects)
    # bounds: boundary conditions on the first and last state nodes, control bounds, tf bounds
    inf = np.inf
    lbx = np.full((nx, 2 * n + 1), -inf)
    ubx = np.full((nx, 2 * n + 1), inf)
    lbx[:, 0] = ubx[:, 0] = p["x0"]
    for i, v in enumerate(p["xf"]):
        if v is not None:
            lbx[i, -1] = ubx[i, -1] = v
    lo = np.concatenate([lbx.ravel(order="F"), np.full(4 * n + 1, p["u_bounds"][0]), [p["tf_bounds"][0]]])
    hi = np.concatenate([ubx.ravel(order="F"), np.full(4 * n + 1, p["u_bounds"][1]), [p["tf_bounds"][1]]])
    s = np.linspace(0.0, 1.0, 2 * n + 1)
    a, b = (np.array(v) for v in p["x_guess"])
    x_guess = a[:, None] + (b - a)[:, None] * s[None, :]
    w0 = np.concatenate([x_guess.ravel(order="F"), np.full(4 * n + 1, p["u_guess"]), [p["tf_guess"]]])
    solver = ca.nlpsol("hlgl", "ipopt", {"x": w, "f": tf, "g": g}, {"ipopt": IPOPT, "print_time": False})
    res = solver(x0=w0, lbx=lo, ubx=hi, lbg=0, ubg=0)
    stats = solver.stats()
    if stats["return_status"] != "Solve_Succeeded":
        raise RuntimeError(f"IPOPT failed: {stats['return_status']}")
    return float(res["x"][-1]) * p["tf_unit"], stats["iter_count"]


if __name__ == "__main__":
    name = sys.argv[1]
    segments = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    tf, iterations = solve({"flat_moon": flat_moon, "lunar_ascent": lunar_ascent}[name](), segments)
    print(f"{tf:.12e} {iterations}")
