"""Four-phase Delta III launch vehicle ascent; constants from ``data/problems/delta3.toml``.

Benson's thesis (MIT 2005), Betts (2010, Sec. 6.15) and the GPOPS-II example "multiple-stage
launch vehicle ascent" (Patterson & Rao, ACM TOMS 41(1), 2014; files launchMain.m,
launchContinuous.m, launchEndpoint.m, launchrv2oe.m, launchoe2rv.m). In every phase, in SI
units and Earth-centred inertial Cartesian coordinates,

    dr/dt = v
    dv/dt = -mu r / |r|^3 + (T_k / m) u + D / m,   D = -1/2 CD S rho |v_rel| v_rel
    dm/dt = -mdot_k
    v_rel = v - omega_E x r,   rho = rho0 exp(-(|r| - Re) / H)
    |u|^2 = 1 (path equality),  |r| >= Re (path inequality, optional)

with thrust and mass flow of the engines burning in phase k:

    phase 1, [0, 75.2 s]:     6 boosters + first stage
    phase 2, [75.2, 150.4 s]: 3 boosters + first stage
    phase 3, [150.4, 261 s]:  first stage
    phase 4, [261 s, tf]:     second stage, tf <= 961 s free

``mdot = T / (g0 Isp)`` with ``Isp = T / (g0 propellant / burn time)``, as launchMain.m
computes it. Between phases the position and velocity are continuous and the mass drops by
the spent boosters' (6, then 3) and the first stage's dry masses (:func:`delta3_mass_drops`).
The last phase ends on the target orbit: five classical elements ``(a, e, i, Omega, omega)``
of ``(r(tf), v(tf))`` are fixed (launchEndpoint.m), the true anomaly is free; maximise
``m(tf)``.

:func:`delta3_phases` gives the four single-phase problems; linking them (a multi-phase
problem) is left to the caller: ``Link(before, after, states="all", jumps={"m": drop})``.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ocpkit import Constraint, Control, FreeFinalTime, Guess, OptimalControlProblem, State

from ._data import load_problem_data

STATE_NAMES = ("x", "y", "z", "vx", "vy", "vz", "m")
CONTROL_NAMES = ("u1", "u2", "u3")
GUESS_KINDS = ("gpops2", "linear", "asset")
_ENGINE_NAMES = [("srb", "first_stage"), ("srb", "first_stage"), ("first_stage",), ("second_stage",)]


def rv_from_elements(a, e, i, Omega, omega, nu, mu):
    """Position and velocity (numpy, m and m/s) of classical orbital elements (angles in rad).

    As GPOPS-II's launchoe2rv.m: ``p = a (1 - e^2)``, ``r = p / (1 + e cos nu)``, perifocal
    ``r_pf = r (cos nu, sin nu, 0)``, ``v_pf = sqrt(mu / p) (-sin nu, e + cos nu, 0)``, rotated by
    ``R3(-Omega) R1(-i) R3(-omega)``.
    """
    p = a * (1.0 - e * e)
    r = p / (1.0 + e * math.cos(nu))
    r_pf = np.array([r * math.cos(nu), r * math.sin(nu), 0.0])
    v_pf = math.sqrt(mu / p) * np.array([-math.sin(nu), e + math.cos(nu), 0.0])
    cO, sO = math.cos(Omega), math.sin(Omega)
    co, so = math.cos(omega), math.sin(omega)
    ci, si = math.cos(i), math.sin(i)
    R = np.array(
        [
            [cO * co - sO * so * ci, -cO * so - sO * co * ci, sO * si],
            [sO * co + cO * so * ci, -sO * so + cO * co * ci, -cO * si],
            [so * si, co * si, ci],
        ]
    )
    return R @ r_pf, R @ v_pf


def _elements(r, v, mu, lib):
    """Shared body of :func:`orbital_elements` (lib = casadi) and :func:`orbital_elements_np` (lib = numpy)."""
    cross = ca.cross if lib is ca else np.cross
    dot = ca.dot if lib is ca else np.dot
    where = ca.if_else if lib is ca else (lambda c, a, b: a if c else b)
    acos = ca.acos if lib is ca else np.arccos
    h = cross(r, v)
    n = cross(lib.vertcat(0.0, 0.0, 1.0) if lib is ca else np.array([0.0, 0.0, 1.0]), h)
    n_norm = lib.sqrt(dot(n, n))
    h2 = dot(h, h)
    v2 = dot(v, v)
    r_norm = lib.sqrt(dot(r, r))
    e_vec = ((v2 - mu / r_norm) * r - dot(r, v) * v) / mu
    p = h2 / mu
    e = lib.sqrt(dot(e_vec, e_vec))
    a = p / (1.0 - e * e)
    i = acos(h[2] / lib.sqrt(h2))
    Omega = acos(n[0] / n_norm)
    Omega = where(n[1] < -np.finfo(float).eps, 2 * math.pi - Omega, Omega)
    omega = acos(dot(n, e_vec) / (n_norm * e))
    omega = where(e_vec[2] < 0, 2 * math.pi - omega, omega)
    nu = acos(dot(e_vec, r) / (e * r_norm))
    nu = where(dot(r, v) < 0, 2 * math.pi - nu, nu)
    return a, e, i, Omega, omega, nu


def orbital_elements(r, v, mu):
    """``(a, e, i, Omega, omega, nu)`` of position ``r`` and velocity ``v`` as CasADi expressions.

    As GPOPS-II's launchrv2oe.m: ``h = r x v``, ``n = k x h``,
    ``e_vec = ((v^2 - mu/r) r - (r.v) v) / mu``, ``a = (h^2/mu) / (1 - e^2)``,
    ``i = acos(h_z / |h|)``, ``Omega = acos(n_x / |n|)`` (``2 pi - Omega`` when ``n_y < 0``),
    ``omega = acos(n.e / (|n| e))`` (``2 pi - omega`` when ``e_z < 0``),
    ``nu = acos(e.r / (e |r|))`` (``2 pi - nu`` when ``r.v < 0``). Angles in rad, in [0, 2 pi);
    undefined for circular or equatorial orbits (none is met here). ``r``, ``v``: 3-vectors
    (CasADi columns or sequences of expressions).
    """
    r = ca.vertcat(*[r[k] for k in range(3)])
    v = ca.vertcat(*[v[k] for k in range(3)])
    return ca.vertcat(*_elements(r, v, mu, ca))


def orbital_elements_np(r, v, mu) -> np.ndarray:
    """The numpy twin of :func:`orbital_elements`: ``[a, e, i, Omega, omega, nu]``."""
    r = np.asarray(r, dtype=float).reshape(3)
    v = np.asarray(v, dtype=float).reshape(3)
    return np.array([float(q) for q in _elements(r, v, mu, np)])


def true_anomaly(mean_anomaly: float, e: float) -> float:
    """The true anomaly (rad, in (-pi, pi]) of an elliptic orbit at ``mean_anomaly`` (rad): Kepler's equation
    ``E - e sin E = M`` by Newton's method from ``E = M + e sign(M)`` (M reduced to (-pi, pi]: the iteration then
    converges for every e < 1), then ``tan(nu / 2) = sqrt((1 + e) / (1 - e)) tan(E / 2)``."""
    if not 0.0 <= e < 1.0:
        raise ValueError(f"the eccentricity must lie in [0, 1), got {e!r}")
    M = math.remainder(float(mean_anomaly), 2.0 * math.pi)
    E = M + e * math.copysign(1.0, M) if M else 0.0
    for _ in range(100):
        step = (E - e * math.sin(E) - M) / (1.0 - e * math.cos(E))
        E -= step
        if abs(step) <= 1e-15 * max(1.0, abs(E)):
            break
    else:
        raise ArithmeticError(f"Kepler's equation did not converge for M = {mean_anomaly!r}, e = {e!r}")
    return 2.0 * math.atan2(math.sqrt(1.0 + e) * math.sin(E / 2), math.sqrt(1.0 - e) * math.cos(E / 2))


def delta3_constants() -> dict:
    """Constants (SI, angles in rad), phase data and boundary values derived from the data file.

    ``phases`` holds one dict per phase: ``t0``, ``tf`` (the upper bound for the last),
    ``thrust`` (N), ``mdot`` (kg/s, positive), ``m_start`` and ``m_end``: launchMain.m's
    ``m10 m1f``, ``m20 m2f``, ``m30 m3f``, ``m40 m4f`` (the mass bounds of each phase,
    ``m4f`` the payload). ``mass_drops``: the three jumps of the mass between phases (kg,
    negative).
    """
    d = load_problem_data("delta3")
    E, V, P = d["earth"], d["vehicle"], d["phases"]
    srb, first, second = V["srb"], V["first_stage"], V["second_stage"]
    payload = V["payload"]["mass_kg"]
    mu, Re, w, g0 = E["mu_m3_s2"], E["radius_m"], E["rotation_rad_s"], E["g0_m_s2"]
    deg = math.pi / 180

    def engine(stage):
        mdot = stage["propellant_kg"] / stage["burn_time_s"]
        return {
            "thrust": stage["thrust_N"],
            "mdot": mdot,
            "isp": stage["thrust_N"] / (g0 * mdot),
            "dry": stage["total_mass_kg"] - stage["propellant_kg"],
        }

    S, F, U = engine(srb), engine(first), engine(second)
    t = [float(x) for x in P["times_s"]]
    n1, n2 = srb["burning_phase1"], srb["burning_phase2"]

    # launchMain.m, in order
    m10 = payload + second["total_mass_kg"] + first["total_mass_kg"] + srb["count"] * srb["total_mass_kg"]
    m1f = m10 - (n1 * S["mdot"] + F["mdot"]) * t[1]
    m20 = m1f - n1 * S["dry"]
    m2f = m20 - (n2 * S["mdot"] + F["mdot"]) * (t[2] - t[1])
    m30 = m2f - n2 * S["dry"]
    m3f = m30 - F["mdot"] * (t[3] - t[2])
    m40 = m3f - F["dry"]
    m4f = payload

    def flow(groups):
        """launchContinuous.m: mdot = sum T / (g0 Isp) over the burning engine groups."""
        return sum(k * e["thrust"] / (g0 * e["isp"]) for k, e in groups)

    groups = [[(n1, S), (1, F)], [(n2, S), (1, F)], [(1, F)], [(1, U)]]
    starts, ends = [m10, m20, m30, m40], [m1f, m2f, m3f, m4f]
    phases = [
        {
            "t0": t[k],
            "tf": t[k + 1],
            "thrust": sum(n * e["thrust"] for n, e in groups[k]),
            "mdot": flow(groups[k]),
            "m_start": starts[k],
            "m_end": ends[k],
            "engines": [(n, name) for (n, _), name in zip(groups[k], _ENGINE_NAMES[k])],
        }
        for k in range(4)
    ]

    lat = d["initial"]["latitude_deg"] * deg
    r0 = Re * np.array([math.cos(lat), 0.0, math.sin(lat)])
    omega_vec = np.array([0.0, 0.0, w])
    v0 = np.cross(omega_vec, r0)
    T = d["target"]
    target = (
        T["semi_major_axis_m"],
        T["eccentricity"],
        T["inclination_deg"] * deg,
        T["raan_deg"] * deg,
        T["argument_of_perigee_deg"] * deg,
    )
    r_out, v_out = rv_from_elements(*target, T["guess_true_anomaly_deg"] * deg, mu)
    r_asset, v_asset = rv_from_elements(*target, true_anomaly(T["guess_mean_anomaly_rad"], target[1]), mu)
    B = d["bounds"]
    return {
        "mu": mu,
        "Re": Re,
        "omega_E": w,
        "rho0": E["rho0_kg_m3"],
        "H": E["scale_height_m"],
        "g0": g0,
        "CD": V["drag_coefficient"],
        "S": V["reference_area_m2"],
        "srb": S,
        "first_stage": F,
        "second_stage": U,
        "payload_kg": payload,
        "times": t,
        "last_phase_min_duration_s": P["last_phase_min_duration_s"],
        "phases": phases,
        "mass_drops": (-n1 * S["dry"], -n2 * S["dry"], -F["dry"]),
        "r0": r0,
        "v0": v0,
        "latitude": lat,
        "target": target,
        "r_guess": r_out,
        "v_guess": v_out,
        "r_guess_asset": r_asset,
        "v_guess_asset": v_asset,
        "position_max": B["position_max_in_radii"] * Re,
        "speed_max": B["speed_component_max_m_s"],
        "control_max": B["control_component_max"],
        "speed_smoothing": d["model"]["speed_smoothing_m_s"],
        "length_unit": Re,
        "velocity_unit": math.sqrt(mu / Re),
    }


def delta3_mass_drops() -> tuple[float, float, float]:
    """The mass jumps ``m(t0 of phase k+1) - m(tf of phase k)``, k = 1, 2, 3 (kg, negative).

    launchMain.m's linkages: ``-6 mDrySrb``, ``-3 mDrySrb``, ``-mDryFirst``
    (-13680, -6840, -8830 kg).
    """
    return delta3_constants()["mass_drops"]


def _dynamics(c: dict, thrust: float, mdot: float, direction: bool = False):
    """The phase's ``f(x, u, t)`` (see the module docstring); ``direction``: the thrust along ``u / |u|``."""
    mu, Re, w = c["mu"], c["Re"], c["omega_E"]
    drag_k = 0.5 * c["CD"] * c["S"]
    rho0, H, eps2 = c["rho0"], c["H"], c["speed_smoothing"] ** 2

    def dynamics(x, u, t):
        r = x[0:3]
        v = x[3:6]
        m = x[6]
        rad = ca.sqrt(ca.dot(r, r))
        v_rel = v - ca.vertcat(-w * r[1], w * r[0], 0)  # omega_E x r, omega_E = (0, 0, w)
        speed_rel = ca.sqrt(ca.dot(v_rel, v_rel) + eps2)
        rho = rho0 * ca.exp(-(rad - Re) / H)
        drag = -drag_k * rho * speed_rel * v_rel
        unit = u[0:3] / ca.sqrt(ca.dot(u[0:3], u[0:3])) if direction else u[0:3]
        vdot = -mu / rad**3 * r + thrust / m * unit + drag / m
        return ca.vertcat(v, vdot, -mdot)

    return dynamics


def delta3_phases(*, altitude_constraint: bool = True, control: str = "unit") -> list[OptimalControlProblem]:
    """The four phases as single-phase problems, in launchMain.m's bounds (see the module docstring).

    States ``x, y, z`` (m; bounds +-2 Re, scale Re), ``vx, vy, vz`` (m/s; bounds +-10 km/s,
    scale sqrt(mu/Re) = 7.9 km/s), ``m`` (kg; bounds ``[m_end, m_start]`` of the phase, NLP
    variable ``(m - m_end) / (m_start - m_end)`` in [0, 1]); controls ``u1, u2, u3`` in [-1, 1]
    with the path equality ``|u|^2 = 1``; with ``altitude_constraint`` (default; Betts' and
    yapss' formulation, not GPOPS-II's) the path constraint ``|r| - Re >= 0`` (scaled by 100 km).
    ``control="direction"`` (ASSET's Delta III example): the thrust acts along ``u / |u|`` and the path
    constraint is ``0.25 <= |u|^2 <= 2.25`` instead of the equality (the same optimum; the direction's
    length is free).

    Phase 1 starts from the fixed lift-off state ``(r0, v0, m10)``; phases 2-4 have free initial
    states within the bounds (launchMain.m: the linkages fix them). Times are fixed except the
    last phase's final time, free in ``(t3, 961 s]`` (``FreeFinalTime``, the lower bound
    ``t3 + last_phase_min_duration_s`` because ocpkit needs ``tf > t0``). The last phase carries
    the objective ``-m(tf)`` (objective_scale 1e4 kg) and the boundary constraint ``orbit``:
    ``[a / Re, e, i, Omega, omega]`` of ``(r(tf), v(tf))`` equal to the target (a in Earth radii
    so the five rows are of order one). The earlier phases have the zero objective ``0 m(tf)``.
    """
    c = delta3_constants()
    Re, vu, rmax, vmax, umax = c["Re"], c["velocity_unit"], c["position_max"], c["speed_max"], c["control_max"]
    target = np.array(c["target"]) / np.array([Re, 1.0, 1.0, 1.0, 1.0])
    mu = c["mu"]
    problems = []
    for k, ph in enumerate(c["phases"]):
        first, last = k == 0, k == 3
        x0 = list(c["r0"]) + list(c["v0"]) + [ph["m_start"]] if first else [None] * 7
        lo, hi = ph["m_end"], ph["m_start"]
        states = [
            State(n, lower=-rmax, upper=rmax, scale=Re, initial=x0[j], unit="m", description=f"ECI {n[-1]}")
            for j, n in enumerate(STATE_NAMES[:3])
        ] + [
            State(n, lower=-vmax, upper=vmax, scale=vu, initial=x0[3 + j], unit="m/s", description=f"ECI {n}")
            for j, n in enumerate(STATE_NAMES[3:6])
        ]
        states.append(
            State("m", lower=lo, upper=hi, shift=lo, scale=hi - lo, initial=x0[6], unit="kg", description="mass")
        )
        controls = [
            Control(n, lower=-umax, upper=umax, guess=float(j == 1), description="thrust direction")
            for j, n in enumerate(CONTROL_NAMES)
        ]
        if control not in ("unit", "direction"):
            raise ValueError(f"control must be 'unit' or 'direction', got {control!r}")
        free_length = control == "direction"
        path = [
            Constraint(
                "thrust_direction",
                lambda x, u, t: ca.dot(u, u),
                lower=0.25 if free_length else 1.0,
                upper=2.25 if free_length else 1.0,
            )
        ]
        if altitude_constraint:
            path.append(Constraint("altitude", lambda x, u, t: ca.norm_2(x[0:3]) - Re, lower=0.0, scale=1e5))
        if last:
            tf = FreeFinalTime(ph["t0"] + c["last_phase_min_duration_s"], ph["tf"], ph["tf"], scale=1e3)
            boundary = [
                Constraint(
                    "orbit",
                    lambda x0_, xf, t0, tf_: (
                        orbital_elements(xf[0:3], xf[3:6], mu)[0:5] / ca.DM([Re, 1.0, 1.0, 1.0, 1.0])
                    ),
                    lower=target,
                    upper=target,
                )
            ]
            objective = {"mayer": lambda x0_, xf, t0, tf_: -xf[6], "objective_scale": 1e4}
        else:
            tf, boundary = ph["tf"], []
            objective = {"mayer": lambda x0_, xf, t0, tf_: 0 * xf[6]}
        engines = " + ".join(f"{n} {name}" for n, name in ph["engines"])
        problems.append(
            OptimalControlProblem(
                f"delta3_phase{k + 1}",
                states,
                controls,
                _dynamics(c, ph["thrust"], ph["mdot"], direction=free_length),
                t0=ph["t0"],
                tf=tf,
                path_constraints=path,
                boundary_constraints=boundary,
                description=f"Delta III ascent, phase {k + 1} ({engines})",
                **objective,
            )
        )
    return problems


def delta3_guesses(kind: str = "gpops2") -> list[Guess]:
    """Initial guesses of the four phases, one :class:`~ocpkit.Guess` each.

    ``"gpops2"`` (launchMain.m): position and velocity constant in each phase, ``(r0, v0)`` in
    phases 1-2 and the target orbit's ``(r, v)`` at true anomaly 0 in phases 3-4; the mass
    linear from the phase's ``m_start`` to ``m_end``; ``u = (0, 1, 0)``; last phase ``tf = 961 s``.
    (launchMain.m guesses phase 2's mass from ``m10`` to ``m1f``, outside that phase's bounds
    ``[m2f, m20]``; here it is ``m20`` to ``m2f``.)

    ``"linear"``: position and velocity linear in time over the whole flight, from ``(r0, v0)``
    at t = 0 to the target's ``(r, v)`` at true anomaly 0 at t = 961 s; mass and control as above.
    ``"asset"`` (ASSET's Delta III example): the same, to the target's point at mean anomaly -0.05 rad
    (``guess_mean_anomaly_rad`` in the data file), downrange and eastward, its line clear of the Earth.
    """
    if kind not in GUESS_KINDS:
        raise ValueError(f"kind must be one of {GUESS_KINDS}, got {kind!r}")
    c = delta3_constants()
    r0, v0 = c["r0"], c["v0"]
    r1, v1 = (c["r_guess_asset"], c["v_guess_asset"]) if kind == "asset" else (c["r_guess"], c["v_guess"])
    t_end = c["times"][-1]
    start = np.concatenate([r0, v0])
    end = np.concatenate([r1, v1])
    guesses = []
    for k, ph in enumerate(c["phases"]):
        if kind == "gpops2":
            values = start if k < 2 else end
            states = {n: float(values[j]) for j, n in enumerate(STATE_NAMES[:6])}
        else:
            states = {
                n: (lambda t, a=start[j], b=end[j]: a + (b - a) * np.asarray(t, dtype=float) / t_end)
                for j, n in enumerate(STATE_NAMES[:6])
            }
        states["m"] = (ph["m_start"], ph["m_end"])
        guesses.append(
            Guess(
                tf=ph["tf"] if k == 3 else None,
                states=states,
                controls={"u1": 0.0, "u2": 1.0, "u3": 0.0},
            )
        )
    return guesses
