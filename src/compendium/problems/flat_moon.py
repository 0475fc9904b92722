"""Flat-moon minimum-time ascent and its exact linear-tangent solution.

Dynamics (Bryson & Ho Sec. 2.7): dx/dt = vx, dy/dt = vy, dvx/dt = a cos(theta),
dvy/dt = a sin(theta) - g. With x(tf) free, the costates of x and y are
constant, those of vx and vy linear in time, and the optimal control obeys the
linear-tangent law ``tan(theta(t)) = tan(theta_0) - c t``. Writing
``tau = tan(theta)`` the states integrate in closed form:

    vx(t) = (a/c) [asinh(tau_0) - asinh(tau)]
    vy(t) = (a/c) [sqrt(1 + tau_0^2) - sqrt(1 + tau^2)] - g t
    x(t)  = (a/c) asinh(tau_0) t + (a/c^2) [K(tau) - K(tau_0)],  K(s) = s asinh(s) - sqrt(1 + s^2)
    y(t)  = (a/c) sqrt(1 + tau_0^2) t + (a/c^2) [G(tau) - G(tau_0)] - g t^2 / 2,
            G(s) = (s sqrt(1 + s^2) + asinh(s)) / 2

and the three terminal conditions on y, vx, vy fix (tau_0, c, tf).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ocpkit import Control, FreeFinalTime, OptimalControlProblem, State

from ._data import load_problem_data


def flat_moon_constants() -> dict:
    d = load_problem_data("flat_moon")
    g = d["constants"]["g_m_s2"]
    return {
        "g": g,
        "a": d["constants"]["thrust_to_weight"] * g,
        "y_f": d["target"]["altitude_m"],
        "vx_f": d["target"]["vx_m_s"],
        "vy_f": d["target"]["vy_m_s"],
        "scaling": dict(d["scaling"]),
        "theta_bounds": tuple(d["bounds"]["theta_rad"]),
        "tf_bounds": tuple(d["bounds"]["tf_s"]),
        "guess": dict(d["guess"]),
    }


def flat_moon_ascent(*, thrust_as_parameter: bool = False) -> OptimalControlProblem:
    """The flat-moon ascent in SI units (scaled internally).

    ``thrust_as_parameter``: the thrust-to-weight ratio is the problem parameter
    ``"thrust_to_weight"`` (``a = thrust_to_weight * g``), so that one transcription solves for
    many values (``solve(parameters={"thrust_to_weight": 2.5})``).
    """
    import casadi as ca

    c = flat_moon_constants()
    a, g = c["a"], c["g"]
    sc, gs = c["scaling"], c["guess"]
    L, V, T = sc["position_m"], sc["velocity_m_s"], sc["time_s"]

    def dynamics(x, u, t, P=None):
        acc = a if P is None else P["thrust_to_weight"] * g
        return ca.vertcat(x[2], x[3], acc * ca.cos(u[0]), acc * ca.sin(u[0]) - g)

    states = [
        State("x", initial=0.0, scale=L, unit="m", guess=tuple(gs["x_m"])),
        State("y", initial=0.0, final=c["y_f"], scale=L, unit="m"),
        State("vx", initial=0.0, final=c["vx_f"], scale=V, unit="m/s"),
        State("vy", initial=0.0, final=c["vy_f"], scale=V, unit="m/s"),
    ]
    lo, hi = c["theta_bounds"]
    controls = [Control("theta", lower=lo, upper=hi, guess=gs["theta_rad"], unit="rad")]
    tlo, thi = c["tf_bounds"]
    return OptimalControlProblem(
        "flat_moon_ascent",
        states,
        controls,
        dynamics,
        tf=FreeFinalTime(tlo, thi, gs["tf_s"], scale=T),
        mayer=lambda x0, xf, t0, tf, P=None: tf,
        objective_scale=T,
        description="Flat-moon minimum-time ascent (Bryson & Ho 2.7)",
        parameters={"thrust_to_weight": a / g} if thrust_as_parameter else None,
    )


def _K(s):
    return s * np.arcsinh(s) - np.sqrt(1 + s * s)


def _G(s):
    return 0.5 * (s * np.sqrt(1 + s * s) + np.arcsinh(s))


@dataclass(frozen=True)
class LinearTangentSolution:
    """Exact solution of the flat-moon ascent: ``tan(theta) = tan_theta0 - c t`` on [0, tf]."""

    a: float
    g: float
    tan_theta0: float
    c: float
    tf: float

    def theta(self, t) -> np.ndarray:
        return np.arctan(self.tan_theta0 - self.c * np.asarray(t, dtype=float))

    def costate(self, t) -> np.ndarray:
        """Costates (lambda_x, lambda_y, lambda_vx, lambda_vy) of H = lambda' f for min tf; linear in time.

        lambda_x = 0 (x(tf) free), lambda_y = c1 c, lambda_vx = c1, lambda_vy = c1 (tan theta_0 - c t),
        with c1 = -1 / (a sec theta_0 - g tan theta_0) from H = -1 (free tf, Mayer cost tf).
        """
        t = np.asarray(t, dtype=float)
        s0 = self.tan_theta0
        c1 = -1.0 / (self.a * np.sqrt(1 + s0**2) - self.g * s0)
        one = np.ones_like(t)
        return np.stack([0 * one, c1 * self.c * one, c1 * one, c1 * (s0 - self.c * t)], axis=-1)

    def state(self, t) -> np.ndarray:
        """States (x, y, vx, vy) at times ``t``; shape ``t.shape + (4,)``."""
        t = np.asarray(t, dtype=float)
        a, g, c, s0 = self.a, self.g, self.c, self.tan_theta0
        s = s0 - c * t
        vx = a / c * (np.arcsinh(s0) - np.arcsinh(s))
        vy = a / c * (np.sqrt(1 + s0**2) - np.sqrt(1 + s * s)) - g * t
        x = a / c * np.arcsinh(s0) * t + a / c**2 * (_K(s) - _K(s0))
        y = a / c * np.sqrt(1 + s0**2) * t + a / c**2 * (_G(s) - _G(s0)) - 0.5 * g * t * t
        return np.stack([x, y, vx, vy], axis=-1)


def linear_tangent_solution(tol: float = 1e-14, thrust_to_weight: float | None = None) -> LinearTangentSolution:
    """Solve the three terminal conditions for (tan theta_0, c, tf) with scipy's MINPACK hybrid method
    (``thrust_to_weight``: another ratio than the data file's)."""
    from scipy.optimize import root  # here, not at import: posing the problem needs no SciPy

    k = flat_moon_constants()
    g = k["g"]
    a = k["a"] if thrust_to_weight is None else float(thrust_to_weight) * g
    target = np.array([k["y_f"], k["vx_f"], k["vy_f"]])
    scale = np.array([k["scaling"]["position_m"], k["scaling"]["velocity_m_s"], k["scaling"]["velocity_m_s"]])

    def residual(z):
        s0, c, tf = z[0], z[1] / 100.0, z[2] * 100.0
        sol = LinearTangentSolution(a, g, s0, c, tf)
        return (sol.state(tf)[1:] - target) / scale

    z0 = np.array([1.0, 0.5, k["guess"]["tf_s"] * (k["a"] / a) / 100.0])  # t_f roughly inverse to the thrust
    res = root(residual, z0, method="hybr", tol=tol)
    # MINPACK may stop at "no further improvement" on a root already as exact as its arithmetic allows
    if np.max(np.abs(res.fun)) > 1e-10:
        raise RuntimeError(f"linear-tangent boundary-value problem did not converge: {res.message}")
    return LinearTangentSolution(a, g, float(res.x[0]), float(res.x[1]) / 100.0, float(res.x[2]) * 100.0)
