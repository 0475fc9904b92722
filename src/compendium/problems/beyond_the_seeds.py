"""Published problems beyond the seeds, for the refinement's trust; constants in
``data/problems/beyond_the_seeds.toml``, published values in ``data/paper/beyond_the_seeds.csv``.

* :func:`tumour`: tumour anti-angiogenesis (Ledzewicz & Schättler 2008; Betts 2010, Ex. 6.17), a bang, singular,
  bang-off control with a free final time;
* :func:`catalyst_mixing`: COPS 3.0's catalyst mixing, bang, singular, bang on a fixed horizon (a Mayer cost: a
  transcription that resolves the singular arc poorly reports a yield its own control does not give);
* :func:`free_flying_robot`: Sakawa's free-flying robot (Betts 2010, Ex. 6.13), an L1 cost with bang-bang thrusters;
* :func:`miser3_state_constraint`: MISER3's linear-quadratic problem under a time-varying ceiling on a state, active
  on an interior arc (a path constraint that collocation holds at its points only);
* :func:`orbit_raising`: Bryson & Ho's maximum-radius orbit transfer, the thrust angle as the control (an angle:
  declared periodic), and a terminal condition that couples two states (a boundary constraint);
* :func:`rayleigh`: the Rayleigh problem, whose Hamiltonian flow blows up from costates a little off;
* :func:`rayleigh_mixed`: the Rayleigh problem under the mixed state-control constraint ``u + x1 / 6 <= 0``
  (Maurer & Augustin 2001; Betts 2010, Sec. 4.14), whose boundary arc is that of a mixed constraint.

The shuttle's reentry is in :mod:`.shuttle_reentry`.
"""

from __future__ import annotations

import math

import casadi as ca

from ocpkit import Constraint, Control, FreeFinalTime, OptimalControlProblem, State

from ._data import load_problem_data


def tumour() -> OptimalControlProblem:
    c = load_problem_data("beyond_the_seeds")["tumour"]
    p_max = ((c["b"] - c["mu"]) / c["d"]) ** 1.5

    def dynamics(x, u, t):
        p, q = x[0], x[1]
        return ca.vertcat(
            -c["xi"] * p * ca.log(p / q),
            q * (c["b"] - (c["mu"] + c["d"] * p ** (2 / 3) + c["G"] * u[0])),
            u[0],
        )

    return OptimalControlProblem(
        "tumour_anti_angiogenesis",
        states=[
            State("p", c["p_min"], p_max, initial=p_max / 2, scale=p_max, guess=(p_max / 2, p_max / 4)),
            State("q", c["p_min"], p_max, initial=p_max / 4, scale=p_max, guess=p_max / 4),
            State("y", 0.0, c["A"], initial=0.0, scale=c["A"], guess=(0.0, c["A"])),
        ],
        controls=[Control("u", 0.0, c["a"], scale=c["a"], guess=c["a"] / 2)],
        dynamics=dynamics,
        tf=FreeFinalTime(c["tf"][0], c["tf"][1], c["tf_guess"]),
        mayer=lambda x0, xf, t0, tf: xf[0],
        objective_scale=p_max,
        description="Tumour anti-angiogenesis (Ledzewicz & Schättler 2008; Betts 2010, Ex. 6.17)",
    )


def catalyst_mixing() -> OptimalControlProblem:
    c = load_problem_data("beyond_the_seeds")["catalyst"]
    return OptimalControlProblem(
        "catalyst_mixing",
        states=[
            State("x1", 0.0, 1.0, initial=c["x0"][0], guess=(1.0, 0.9)),
            State("x2", 0.0, 1.0, initial=c["x0"][1], guess=0.05),
        ],
        controls=[Control("u", 0.0, 1.0, guess=0.5)],
        dynamics=lambda x, u, t: ca.vertcat(u[0] * (10 * x[1] - x[0]), u[0] * (x[0] - 10 * x[1]) - (1 - u[0]) * x[1]),
        tf=c["tf"],
        mayer=lambda x0, xf, t0, tf: -1 + xf[0] + xf[1],
        objective_scale=0.1,
        description="Catalyst mixing (COPS 3.0)",
    )


def free_flying_robot() -> OptimalControlProblem:
    c = load_problem_data("beyond_the_seeds")["robot"]
    names = ["x", "y", "theta", "vx", "vy", "omega"]

    def dynamics(x, u, t):
        F1, F2 = u[0] - u[1], u[2] - u[3]
        return ca.vertcat(
            x[3], x[4], x[5], (F1 + F2) * ca.cos(x[2]), (F1 + F2) * ca.sin(x[2]), c["alpha"] * F1 - c["beta"] * F2
        )

    return OptimalControlProblem(
        "free_flying_robot",
        states=[
            State(n, initial=a, final=b, guess=(a, b), scale=10.0 if n in ("x", "y") else 1.0)
            for n, a, b in zip(names, c["initial"], c["final"])
        ],
        controls=[Control(f"u{i}", 0.0, c["u_max"], guess=0.5, scale=1.0) for i in range(1, 5)],
        dynamics=dynamics,
        tf=c["tf"],
        lagrange=lambda x, u, t: u[0] + u[1] + u[2] + u[3],
        path_constraints=[
            Constraint("thrusters_1", lambda x, u, t: u[0] + u[1], upper=1.0),
            Constraint("thrusters_2", lambda x, u, t: u[2] + u[3], upper=1.0),
        ],
        description="Free-flying robot (Sakawa 1999; Betts 2010, Ex. 6.13)",
    )


def free_flying_robot_net() -> OptimalControlProblem:
    """The free-flying robot on its net thrusts ``F1 = u1 - u2``, ``F2 = u3 - u4`` in ``[-1, 1]`` with the cost
    ``|F1| + |F2|``: the statement to shoot (the maximum principle's bang-off-bang and L1-singular arcs), the
    four-control :func:`free_flying_robot` being the smooth one to solve directly (an optimum never fires both
    thrusters of a pair, so ``u1 + u2 = |F1|``)."""
    c = load_problem_data("beyond_the_seeds")["robot"]
    names = ["x", "y", "theta", "vx", "vy", "omega"]

    def dynamics(x, u, t):
        F1, F2 = u[0], u[1]
        return ca.vertcat(
            x[3], x[4], x[5], (F1 + F2) * ca.cos(x[2]), (F1 + F2) * ca.sin(x[2]), c["alpha"] * F1 - c["beta"] * F2
        )

    return OptimalControlProblem(
        "free_flying_robot_net",
        states=[State(n, initial=a, final=b) for n, a, b in zip(names, c["initial"], c["final"])],
        controls=[Control("F1", -1.0, 1.0), Control("F2", -1.0, 1.0)],
        dynamics=dynamics,
        tf=c["tf"],
        lagrange=lambda x, u, t: ca.fabs(u[0]) + ca.fabs(u[1]),
        description="Free-flying robot on its net thrusts, L1 cost (Sakawa 1999; Betts 2010, Ex. 6.13)",
    )


def miser3_state_constraint() -> OptimalControlProblem:
    c = load_problem_data("beyond_the_seeds")["miser3"]
    a, b, ceiling = c["ceiling"]
    box, ubox, w = c["state_box"], c["control_box"], c["control_weight"]
    return OptimalControlProblem(
        "miser3_state_constraint",
        states=[
            State("x1", -box, box, initial=c["x0"][0], guess=c["x0"][0]),
            State("x2", -box, box, initial=c["x0"][1], guess=c["x0"][1]),
        ],
        controls=[Control("u", -ubox, ubox, guess=0.0)],
        dynamics=lambda x, u, t: ca.vertcat(x[1], -x[1] + u[0]),
        tf=c["tf"],
        lagrange=lambda x, u, t: x[0] ** 2 + x[1] ** 2 + w * u[0] ** 2,
        path_constraints=[Constraint("ceiling", lambda x, u, t: x[1] - (a * (t - b) ** 2 + ceiling), upper=0.0)],
        description="MISER3's state-constrained problem (Teo, Goh & Wong 1991; PROPT, PSOPT stc1)",
    )


def orbit_raising(periodic: bool = True) -> OptimalControlProblem:
    """``periodic=False`` states the thrust angle as a plain unbounded control, as a user might first write it: the
    NLP may then move its node values by whole turns (233.7, -109.7 and -417 degrees in one interval)."""
    c = load_problem_data("beyond_the_seeds")["orbit_raising"]
    mu, thrust, rate = c["mu"], c["thrust"], c["mass_rate"]

    def dynamics(x, u, t):
        r, v_r, v_t, phi = x[0], x[2], x[3], u[0]
        acceleration = thrust / (1.0 - rate * t)
        return ca.vertcat(
            v_r,
            v_t / r,
            v_t**2 / r - mu / r**2 + acceleration * ca.sin(phi),
            -v_r * v_t / r + acceleration * ca.cos(phi),
        )

    return OptimalControlProblem(
        "orbit_raising",
        states=[
            State("r", 0.5, 3.0, initial=1.0, guess=(1.0, 1.5)),
            State("theta", initial=0.0, guess=(0.0, math.pi)),
            State("v_r", initial=0.0, final=0.0, guess=0.1),
            State("v_t", initial=math.sqrt(mu), guess=(1.0, 0.8)),
        ],
        controls=[Control("phi", period=2 * math.pi if periodic else None, guess=0.5)],
        dynamics=dynamics,
        tf=c["tf"],
        mayer=lambda x0, xf, t0, tf: -xf[0],
        boundary_constraints=[
            Constraint("circular", lambda x0, xf, t0, tf: xf[3] - ca.sqrt(mu / xf[0]), lower=0.0, upper=0.0)
        ],
        description="Orbit raising, maximum radius (Bryson & Ho 1975, Sec. 2.7)",
    )


def rayleigh() -> OptimalControlProblem:
    """The Rayleigh problem with no constraint (Maurer & Augustin 2001): ``x1' = x2``,
    ``x2' = -x1 + x2 (1.4 - 0.14 x2^2) + 4 u``, minimise ``int u^2 + x1^2`` over ``[0, 4.5]`` from ``(-5, -5)``, the
    final state free. Its Hamiltonian flow is unstable: from costates a little off, ``p2`` and ``x2`` feed each
    other (``p2' ~ 0.42 x2^2 p2``, ``x2' ~ -8 p2``), and the flow from Radau 4 x 20's costates at t0 blows up near
    ``t = 1.2``, a quarter of the horizon (``x2 = 24``, ``p2 = -447`` at ``t = 1.19``; no step completes past
    1.1965)."""
    return _rayleigh("rayleigh", (), "Rayleigh problem (Maurer & Augustin 2001)")


def rayleigh_mixed() -> OptimalControlProblem:
    """:func:`rayleigh` under the mixed state-control constraint ``u + x1 / 6 <= 0`` (Betts 2010, Sec. 4.14)."""
    ratio = load_problem_data("beyond_the_seeds")["rayleigh"]["ratio"]
    return _rayleigh(
        "rayleigh_mixed",
        [Constraint("mixed", lambda x, u, t: u[0] + x[0] / ratio, upper=0.0)],
        "Rayleigh problem with a mixed state-control constraint (Maurer & Augustin 2001; Betts 2010)",
    )


def _rayleigh(name: str, path_constraints, description: str) -> OptimalControlProblem:
    c = load_problem_data("beyond_the_seeds")["rayleigh"]
    a, b = c["damping"]
    return OptimalControlProblem(
        name,
        states=[State("x1", initial=c["x0"][0], guess=0.0), State("x2", initial=c["x0"][1], guess=0.0)],
        controls=[Control("u", guess=0.0)],
        dynamics=lambda x, u, t: ca.vertcat(x[1], -x[0] + x[1] * (a - b * x[1] ** 2) + c["gain"] * u[0]),
        tf=c["tf"],
        lagrange=lambda x, u, t: u[0] ** 2 + x[0] ** 2,
        path_constraints=path_constraints,
        description=description,
    )


__all__ = [
    "catalyst_mixing",
    "free_flying_robot",
    "miser3_state_constraint",
    "orbit_raising",
    "rayleigh",
    "rayleigh_mixed",
    "tumour",
]
