"""Fuel-optimal entry-landing of the Radau blog post (seed 002); constants from ``data/problems/entry_landing.toml``.

States r, s, V, gamma, m (non-dimensional with R0, g0, m0); controls: lift
fraction u_L, thrust fraction u_T, thrust angle eps. Fixed final time 25 s;
maximise the final mass.

Options correct or reproduce the post:

* ``aero_model="corrected"`` (default) scales lift by ``g0 R0`` as the
  non-dimensionalisation requires; ``"as_published"`` by ``g0 r0`` with
  ``r0 = 3 km / R0``, as the post's listing does (about 1e-10 of the lift);
* ``downrange_m=None`` (default) leaves the final downrange free; a number
  fixes it (the post fixes 60 m, which no trajectory can meet: notebook 03);
* ``thrust_angle_rate_deg_s``: None (default, as the post, whose limit is zero
  by integer division and never imposed) or a limit on ``|d eps / dt|``,
  imposed exactly by making eps a state driven by its rate;
* ``speed_cap=True`` keeps the post's bound ``V <= V0``; ``False`` lifts it;
* ``objective="max_final_mass"`` (the post) or ``"min_downrange"`` (the
  shortest downrange any admissible trajectory can land at).
"""

from __future__ import annotations

import math

import casadi as ca

from ocpkit import Constraint, Control, OptimalControlProblem, State

from ._data import load_problem_data

AERO_MODELS = ("corrected", "as_published")
OBJECTIVES = ("max_final_mass", "min_downrange")


def entry_landing_constants() -> dict:
    """Non-dimensional constants and boundary values derived from the data file."""
    d = load_problem_data("entry_landing")
    u, v, i, f, b = d["units"], d["vehicle"], d["initial"], d["final"], d["bounds"]
    R0, g0, m0 = u["R0_m"], u["g0_m_s2"], u["m0_kg"]
    v_unit, t_unit = math.sqrt(g0 * R0), math.sqrt(R0 / g0)
    deg = math.pi / 180
    return {
        "R0_m": R0,
        "g0": g0,
        "m0_kg": m0,
        "velocity_unit_m_s": v_unit,
        "time_unit_s": t_unit,
        "Sref_m2": math.pi * v["Rref_m"] ** 2,
        "rho": v["rho_kg_m3"],
        "Tmax": v["Tmax_N"] / (m0 * g0),
        "Isp": v["Isp_s"] / t_unit,
        "drag_to_lift": v["drag_to_lift"],
        "lift_fraction": tuple(v["lift_fraction"]),
        "thrust_fraction": tuple(v["thrust_fraction"]),
        "thrust_angle": tuple(a * deg for a in v["thrust_angle_deg"]),
        "thrust_angle_rate_deg_s": v["thrust_angle_rate_deg_s"],
        "r0": 1.0 + i["altitude_m"] / R0,
        "h0_R0": i["altitude_m"] / R0,
        "s0": i["downrange_m"] / R0,
        "V0": i["velocity_m_s"] / v_unit,
        "gamma0": i["flight_path_angle_deg"] * deg,
        "m_initial": i["mass"],
        "rf": 1.0 + f["altitude_m"] / R0,
        "Vf": f["velocity_m_s"] / v_unit,
        "gammaf": f["flight_path_angle_deg"] * deg,
        "tf": f["time_s"] / t_unit,
        "published_downrange_m": f["published_downrange_m"],
        "gamma_bounds": tuple(a * deg for a in b["flight_path_angle_deg"]),
        "mass_bounds": tuple(b["mass"]),
        "downrange_bounds": tuple(b["downrange_R0"]),
    }


def lift_scale(aero_model: str) -> float:
    """Non-dimensional lift per unit V^2 and unit lift fraction: 0.5 rho Sref (g0 R0 or g0 r0) / (m0 g0)."""
    if aero_model not in AERO_MODELS:
        raise ValueError(f"aero_model must be one of {AERO_MODELS}, got {aero_model!r}")
    c = entry_landing_constants()
    length = c["R0_m"] if aero_model == "corrected" else c["h0_R0"]  # the post's g0 * r0, r0 = 3 km / R0
    return 0.5 * c["rho"] * c["Sref_m2"] * c["g0"] * length / (c["m0_kg"] * c["g0"])


def _entry_constants(initial_speed_m_s: float | None, initial_flight_path_deg: float | None) -> dict:
    """:func:`entry_landing_constants` with another initial speed (m/s) or flight-path angle (deg), checked."""
    c = entry_landing_constants()
    if initial_speed_m_s is not None:
        if not (math.isfinite(initial_speed_m_s) and initial_speed_m_s > 0):
            raise ValueError(f"initial_speed_m_s must be a positive speed, got {initial_speed_m_s!r}")
        c["V0"] = initial_speed_m_s / c["velocity_unit_m_s"]
    if initial_flight_path_deg is not None:
        if not (math.isfinite(initial_flight_path_deg) and -90 <= initial_flight_path_deg <= 90):
            raise ValueError(f"initial_flight_path_deg must lie in [-90, 90], got {initial_flight_path_deg!r}")
        c["gamma0"] = initial_flight_path_deg * math.pi / 180
    return c


def minimum_downrange_bound(
    aero_model: str = "corrected",
    *,
    initial_speed_m_s: float | None = None,
    initial_flight_path_deg: float | None = None,
) -> dict:
    """A lower bound on the final downrange (m) of any trajectory admissible under the post's bounds.

    With gamma in [-90, 90] deg, ds/dt = V cos(gamma) >= 0: the downrange never
    decreases. The horizontal speed ``V cos(gamma)`` starts at ``V0 cos(gamma0)``
    and must reach 0 (gamma_f = -90 deg). Its rate of change is the horizontal
    component of thrust, lift and drag over the mass (gravity is vertical), at most
    ``a_max = (Tmax + sqrt(1 + (D/L)^2) L_max) / m_min`` with the lift largest at
    ``u_L = 1`` and ``V = V0`` (``V <= V0``). Hence ``s_f >= (V0 cos gamma0)^2 / (2 a_max)``.
    ``initial_speed_m_s``, ``initial_flight_path_deg``: another entry, as :func:`entry_landing`.
    """
    c = _entry_constants(initial_speed_m_s, initial_flight_path_deg)
    k = lift_scale(aero_model)
    L_max = k * c["V0"] ** 2
    a_max = (c["Tmax"] + math.hypot(1.0, c["drag_to_lift"]) * L_max) / c["mass_bounds"][0]  # in g0
    v_h0 = c["V0"] * math.cos(c["gamma0"]) * c["velocity_unit_m_s"]
    a = a_max * c["g0"]
    return {"horizontal_speed_m_s": v_h0, "max_horizontal_deceleration_m_s2": a, "downrange_bound_m": v_h0**2 / (2 * a)}


def entry_landing(
    aero_model: str = "corrected",
    downrange_m: float | None = None,
    thrust_angle_rate_deg_s: float | None = None,
    *,
    speed_cap: bool = True,
    objective: str = "max_final_mass",
    glide_slope_deg: float | None = None,
    max_sensed_g: float | None = None,
    initial_speed_m_s: float | None = None,
    initial_flight_path_deg: float | None = None,
    constants_as_parameters: bool = False,
) -> OptimalControlProblem:
    """The entry-landing problem (see the module docstring for the options).

    ``initial_speed_m_s``, ``initial_flight_path_deg``: another initial speed or flight-path angle
    than the data file's (the speed cap, when on, follows the initial speed).

    ``constants_as_parameters``: the initial speed and flight-path angle (and the glide slope, where one is given)
    are the solve-time parameters ``initial_speed_m_s``, ``initial_flight_path_deg`` (``glide_slope_deg``), their
    values the defaults: the initial speed and angle held by boundary equalities, the speed cap a path
    constraint, so that one transcription solves for many values (``solve(parameters=...)``, the explorer). The
    default statement, with the initial state fixed, is the post's.

    Two path constraints the post left out (notebook 06):

    * ``glide_slope_deg``: the vehicle stays above a cone through the landing site (the final
      downrange ``downrange_m``, which must then be given) at this elevation angle:
      ``h >= tan(angle) (s_site - s)``, i.e. ``(r - rf) - tan(angle) (s_site - s) >= 0``;
    * ``max_sensed_g``: the sensed (non-gravitational) acceleration, thrust plus lift plus
      drag over mass, at most this many g0: ``((T cos eps + D)^2 + (T sin eps - L)^2) / m^2
      <= max_sensed_g^2`` (units of g0, the problem's acceleration unit).
    """
    c = _entry_constants(initial_speed_m_s, initial_flight_path_deg)
    k_lift = lift_scale(aero_model)
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    if downrange_m is not None and not (math.isfinite(downrange_m) and downrange_m >= 0):
        raise ValueError(f"downrange_m must be a non-negative distance in metres or None, got {downrange_m!r}")
    rate = thrust_angle_rate_deg_s
    if rate is not None and not (rate > 0 and math.isfinite(rate)):
        raise ValueError(f"thrust_angle_rate_deg_s must be positive or None, got {thrust_angle_rate_deg_s!r}")
    Tmax, Isp, kD = c["Tmax"], c["Isp"], c["drag_to_lift"]
    rated = thrust_angle_rate_deg_s is not None

    def forces(x, u):
        """Thrust, lift, drag (per m0 g0) and the thrust angle."""
        V = x[2]
        uL, uT = u[0], u[1]
        eps = x[5] if rated else u[2]
        T = uT * Tmax
        L = uL * k_lift * V**2
        D = kD * L
        return T, L, D, eps

    def dynamics(x, u, t):
        r, s, V, gamma, m = (x[i] for i in range(5))
        T, L, D, eps = forces(x, u)
        xdot = [
            V * ca.sin(gamma),
            V * ca.cos(gamma),
            (-T * ca.cos(eps) - D) / m - ca.sin(gamma) / r**2,
            (-T * ca.sin(eps) + L) / (m * V) - ca.cos(gamma) / (r**2 * V),
            -T / Isp,
        ]
        if rated:
            xdot.append(u[2])
        return ca.vertcat(*xdot)

    h0 = c["h0_R0"]
    sf = None if downrange_m is None else downrange_m / c["R0_m"]
    v_unit, deg = c["velocity_unit_m_s"], math.pi / 180
    parameters, boundary = {}, []
    if constants_as_parameters:
        given = load_problem_data("entry_landing")["initial"]
        parameters["initial_speed_m_s"] = given["velocity_m_s"] if initial_speed_m_s is None else initial_speed_m_s
        parameters["initial_flight_path_deg"] = (
            given["flight_path_angle_deg"] if initial_flight_path_deg is None else initial_flight_path_deg
        )
        boundary = [
            Constraint("initial_speed", lambda x0, xf, t0, tf, P: x0[2] - P["initial_speed_m_s"] / v_unit, 0.0, 0.0),
            Constraint(
                "initial_flight_path", lambda x0, xf, t0, tf, P: x0[3] - P["initial_flight_path_deg"] * deg, 0.0, 0.0
            ),
        ]
    states = [
        State(
            "r",
            lower=c["rf"],
            upper=c["r0"],
            initial=c["r0"],
            final=c["rf"],
            shift=1.0,
            scale=h0,
            description="radius / R0",
        ),
        State(
            "s",
            lower=c["downrange_bounds"][0],
            upper=c["downrange_bounds"][1],
            initial=c["s0"],
            final=sf,
            scale=h0,
            guess=0.0,
            description="downrange / R0",
        ),
        State(
            "V",
            lower=c["Vf"],
            upper=c["V0"] if speed_cap and not constants_as_parameters else math.inf,
            initial=None if constants_as_parameters else c["V0"],
            final=c["Vf"],
            scale=c["V0"],
            guess=(c["V0"], c["Vf"]) if constants_as_parameters else None,
            description="speed / sqrt(g0 R0)",
        ),
        State(
            "gamma",
            lower=c["gamma_bounds"][0],
            upper=c["gamma_bounds"][1],
            initial=None if constants_as_parameters else c["gamma0"],
            final=c["gammaf"],
            unit="rad",
            guess=(c["gamma0"], c["gammaf"]) if constants_as_parameters else None,
            description="flight-path angle",
        ),
        State(
            "m",
            lower=c["mass_bounds"][0],
            upper=c["mass_bounds"][1],
            initial=c["m_initial"],
            shift=0.9,
            scale=0.1,
            guess=1.0,
            description="mass / m0",
        ),
    ]
    lo, hi = c["thrust_angle"]
    eps_scale = max(abs(lo), abs(hi))
    controls = [
        Control("u_L", *c["lift_fraction"], guess=1.0, description="lift fraction"),
        Control("u_T", *c["thrust_fraction"], guess=1.0, description="thrust fraction"),
    ]
    if rated:
        rate = thrust_angle_rate_deg_s * math.pi / 180 * c["time_unit_s"]  # rad per time unit
        states.append(
            State("eps", lower=lo, upper=hi, scale=eps_scale, guess=0.0, unit="rad", description="thrust angle")
        )
        controls.append(Control("eps_rate", -rate, rate, scale=rate, guess=0.0, description="thrust-angle rate"))
    else:
        controls.append(Control("eps", lo, hi, scale=eps_scale, guess=0.0, unit="rad", description="thrust angle"))
    path = []
    if constants_as_parameters and speed_cap:
        path.append(
            Constraint("speed_cap", lambda x, u, t, P: x[2] - P["initial_speed_m_s"] / v_unit, upper=0.0, scale=c["V0"])
        )
    if glide_slope_deg is not None:
        if sf is None:
            raise ValueError("a glide-slope cone needs the landing site: give downrange_m")
        if not 0 < glide_slope_deg < 90:
            raise ValueError(f"glide_slope_deg must lie in (0, 90), got {glide_slope_deg!r}")
        if constants_as_parameters:
            parameters["glide_slope_deg"] = glide_slope_deg

            def cone(x, u, t, P):
                return (x[0] - c["rf"]) - ca.tan(P["glide_slope_deg"] * deg) * (sf - x[1])

        else:
            slope = math.tan(math.radians(glide_slope_deg))

            def cone(x, u, t):
                return (x[0] - c["rf"]) - slope * (sf - x[1])

        path.append(Constraint("glide_slope", cone, lower=0.0, scale=h0))
    if max_sensed_g is not None:
        if not (max_sensed_g > 0 and math.isfinite(max_sensed_g)):
            raise ValueError(f"max_sensed_g must be positive, got {max_sensed_g!r}")

        def sensed_squared(x, u, t):
            T, L, D, eps = forces(x, u)
            return ((T * ca.cos(eps) + D) ** 2 + (T * ca.sin(eps) - L) ** 2) / x[4] ** 2

        path.append(Constraint("sensed_acceleration", sensed_squared, upper=max_sensed_g**2, scale=max_sensed_g**2))
    return OptimalControlProblem(
        "entry_landing",
        states,
        controls,
        dynamics,
        path_constraints=path,
        boundary_constraints=boundary,
        parameters=parameters or None,
        tf=c["tf"],
        mayer=(lambda x0, xf, t0, tf: -xf[4]) if objective == "max_final_mass" else (lambda x0, xf, t0, tf: xf[1] / h0),
        description=f"Entry-landing, {objective} (aero {aero_model}, downrange "
        f"{'free' if downrange_m is None else f'{downrange_m} m'}, "
        f"thrust-angle rate {'free' if not rated else f'{thrust_angle_rate_deg_s} deg/s'})",
    )
