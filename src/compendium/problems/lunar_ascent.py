"""Desai & Conway's lunar ascent (seed 000, Eqs. 8-11); constants from ``data/problems/lunar_ascent.toml``."""

from __future__ import annotations

import dataclasses
import math

import casadi as ca

from ocpkit import Constraint, Control, FreeFinalTime, OptimalControlProblem, State

from ._data import load_problem_data


def lunar_ascent_constants(
    speed_smoothing: float | None = None, *, a: float | None = None, altitude_km: float | None = None
) -> dict:
    """Non-dimensional constants, initial state and target: the data file's (the paper's reading), with the speed
    smoothing ``speed_smoothing``, thrust acceleration ``a`` and target altitude ``altitude_km`` (km) given in their
    place, as :func:`lunar_ascent` solves with them. ``paper``: the data file's values of those three, for a
    printout to set beside them."""
    d = load_problem_data("lunar_ascent")
    for name, value in (("speed_smoothing", speed_smoothing), ("a", a), ("altitude_km", altitude_km)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be positive and finite, got {value!r}")
    R = d["units"]["length_m"]
    g_moon = d["units"]["g_moon_m_s2"]
    v_unit = math.sqrt(g_moon * R)
    paper_km = d["target"]["altitude_m"] / 1e3
    return {
        "g": d["constants"]["g"],
        "a": d["constants"]["a"] if a is None else float(a),
        "speed_smoothing": d["constants"]["speed_smoothing"] if speed_smoothing is None else float(speed_smoothing),
        "altitude_km": paper_km if altitude_km is None else float(altitude_km),
        "length_unit_m": R,
        "time_unit_s": math.sqrt(R / g_moon),
        "velocity_unit_m_s": v_unit,
        "initial": dict(d["initial"]),
        "final": {
            # the data file's target as it stands, to the last digit, unless another altitude is given
            "Y": 1.0 + (d["target"]["altitude_m"] if altitude_km is None else float(altitude_km) * 1e3) / R,
            "U": d["target"]["U_m_s"] / v_unit,
            "V": d["target"]["V_m_s"] / v_unit,
        },
        "paper": {
            "a": d["constants"]["a"],
            "speed_smoothing": d["constants"]["speed_smoothing"],
            "altitude_km": paper_km,
        },
        "theta_bounds": tuple(d["bounds"]["theta"]),
        "tf_bounds": tuple(d["bounds"]["tf"]),
        "guess": dict(d["guess"]),
    }


def ascent_rates(X, Y, U, V, theta, a, g, eps):
    """Eqs. (8)-(11): the rates of ``X, Y, U, V`` at thrust angle ``theta``, with the smoothed speed
    ``sqrt(U^2 + V^2 + eps^2)``."""
    speed = ca.sqrt(U**2 + V**2 + eps**2)
    radius = ca.sqrt(X**2 + Y**2)
    return U, V, a * ca.cos(theta) - 0.5 * g * speed / radius, a * ca.sin(theta) - g * speed / radius


def ascent_states(c: dict) -> list[State]:
    """The states ``X, Y, U, V`` with the initial state, target and straight-line guesses of the constants ``c``
    (:func:`lunar_ascent_constants`)."""
    ini, fin, guess = c["initial"], c["final"], c["guess"]

    def end_guess(name):
        return guess.get(name, (ini[name], fin.get(name, ini[name])))

    return [
        State("X", initial=ini["X"], guess=end_guess("X"), description="horizontal position / R"),
        State("Y", initial=ini["Y"], final=fin["Y"], guess=end_guess("Y"), description="vertical position / R"),
        State(
            "U", initial=ini["U"], final=fin["U"], guess=end_guess("U"), description="horizontal velocity / sqrt(g R)"
        ),
        State("V", initial=ini["V"], final=fin["V"], guess=end_guess("V"), description="vertical velocity / sqrt(g R)"),
    ]


def lunar_ascent(
    speed_smoothing: float | None = None,
    *,
    a: float | None = None,
    altitude_km: float | None = None,
    thrust_as_parameter: bool = False,
    target_as_parameter: bool = False,
) -> OptimalControlProblem:
    """Minimum-time lunar ascent, Eqs. (8)-(11) of Desai & Conway.

    ``sqrt(U^2 + V^2)`` is replaced by ``sqrt(U^2 + V^2 + eps^2)``, eps =
    ``speed_smoothing`` (default from the data file), so the dynamics are
    twice differentiable at the initial rest state. ``thrust_as_parameter``: the thrust
    acceleration ``a`` (the thrust-to-weight ratio, g = 1) is the problem parameter ``"a"``,
    so that one transcription solves for many values (``solve(parameters={"a": 2.5})``).
    ``target_as_parameter``: the target altitude is the parameter ``"altitude_km"`` (default the data file's
    185.2 km), the final ``Y`` held to it by the boundary equality ``target``
    (``solve(parameters={"altitude_km": 300})``); the default statement, with ``Y(t_f)`` fixed, is the paper's.
    ``a`` and ``altitude_km``: another thrust-to-weight ratio or target altitude (default: the data file's, the
    paper's), the constant of the statement or, as a parameter, its default value.
    """
    c = lunar_ascent_constants(speed_smoothing, a=a, altitude_km=altitude_km)
    eps, g, a, target_km, R = c["speed_smoothing"], c["g"], c["a"], c["altitude_km"], c["length_unit_m"]

    def dynamics(x, u, t, P=None):
        X, Y, U, V = ca.vertsplit(x)
        thrust = P["a"] if P is not None and "a" in P else a
        return ca.vertcat(*ascent_rates(X, Y, U, V, u[0], thrust, g, eps))

    guess = c["guess"]
    states = ascent_states(c)
    parameters, boundary = {}, []
    if thrust_as_parameter:
        parameters["a"] = a
    if target_as_parameter:
        parameters["altitude_km"] = float(target_km)
        states[1] = dataclasses.replace(states[1], final=None)
        boundary.append(
            Constraint("target", lambda x0, xf, t0, tf, P: xf["Y"] - (1.0 + P["altitude_km"] * 1e3 / R), 0.0, 0.0)
        )
    lo, hi = c["theta_bounds"]
    controls = [Control("theta", lower=lo, upper=hi, guess=guess["theta"], unit="rad", description="thrust angle")]
    tlo, thi = c["tf_bounds"]
    return OptimalControlProblem(
        "lunar_ascent",
        states,
        controls,
        dynamics,
        tf=FreeFinalTime(tlo, thi, guess["tf"]),
        mayer=lambda x0, xf, t0, tf, P=None: tf,
        description="Desai & Conway lunar ascent, minimum time (Eqs. 8-11)",
        parameters=parameters or None,
        boundary_constraints=boundary,
    )
