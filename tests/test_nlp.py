"""The assembled Jacobian and Hessian equal CasADi's own derivatives (ocpkit.nlp)."""

import casadi as ca
import numpy as np
import pytest

from ocpkit import (
    HLGL,
    Constraint,
    Control,
    Duration,
    FreeFinalTime,
    FreeInitialTime,
    FreeParameter,
    Link,
    MultiPhaseProblem,
    MultiRateHLGL,
    OptimalControlProblem,
    Program,
    Radau,
    State,
)
from ocpkit.nlp import Block, SeparableNLP

from compendium.problems import entry_landing, flat_moon_ascent, lunar_ascent


def reference_derivatives(nlp, w, lam_f, lam_g):
    J = ca.Function("J", [nlp.w], [ca.jacobian(nlp.g, nlp.w)])(w).full()
    H = ca.Function("H", [nlp.w], [ca.hessian(lam_f * nlp.f + ca.dot(ca.DM(lam_g), nlp.g), nlp.w)[0]])(w).full()
    return J, H


def with_lagrange(pr):
    return OptimalControlProblem(
        "with_lagrange",
        pr.states,
        pr.controls,
        lambda x, u, t: pr.dynamics(x, u, t),
        tf=pr.tf,
        mayer=lambda x0, xf, t0, tf: tf**2 + xf[0] * x0[1],
        lagrange=lambda x, u, t: x[2] ** 2 * u[0] ** 2 + ca.sin(x[0] * t),
    )


def every_kind(t0=0.0, tf=None, control=None, **kwargs):
    """One phase with a block of every kind the program writes: path and boundary constraints, a pinned parameter
    ``g`` and a free one ``k``, a free start and a duration, a running and a Mayer cost; and, through ``control``,
    end values of the control (held by a point's bounds, or by a row of the control's interpolant)."""
    return OptimalControlProblem(
        f"every_kind_{t0}",
        [State("x", initial=0.0), State("v", initial=0.0, scale=2.0), State("m", 1.0, 3.0, shift=2.0)],
        [control or Control("u", -2.0, 2.0, initial=0.5, final=(-0.25, 0.25))],
        lambda x, u, t, p: [x["v"], p["k"] * u["u"] / x["m"] - p["g"] * ca.sin(x["x"]), -0.1 * u["u"] ** 2],
        t0=FreeInitialTime(0.0, 1.0, 0.5, scale=2.0) if t0 is None else t0,
        tf=tf or Duration(0.5, 3.0, 1.5, scale=1.5),
        lagrange=lambda x, u, t, p: (u["u"] * t) ** 2 + p["k"] * x["v"] ** 2,
        mayer=lambda x0, xf, t0, tf, p: (xf["x"] - 1.0) ** 2 * tf + p["k"] * x0["m"],
        parameters={"g": 0.3},
        free_parameters=[FreeParameter("k", 0.5, 2.0, guess=1.0, scale=0.5, shift=1.0)],
        path_constraints=[Constraint("speed", lambda x, u, t: x["v"] * x["m"] + u["u"] * t, upper=2.0, scale=2.0)],
        boundary_constraints=[Constraint("end", lambda x0, xf, t0, tf, p: xf["v"] * tf - p["k"], lower=-1.0)],
        **kwargs,
    )


def linked_phases():
    """Two phases on two schemes: a state link with a jump, a free final time met by the next phase's free start
    (a time row), a free parameter the phases share (one NLP variable), a trajectory cost and a linkage
    constraint."""
    first = every_kind(0.0, FreeFinalTime(0.5, 2.0, 1.0))
    second = every_kind(None, Duration(0.5, 3.0, 1.5), control=Control("u", -2.0, 2.0, final=0.0))
    statement = MultiPhaseProblem(
        {"first": first, "second": second},
        [Link("first", "second", jumps={"m": -0.5})],
        cost=lambda e, p: e["second"].tf * p["k"] + e["first"].xf["v"] ** 2,
        constraints=[Constraint("meet", lambda e: e["second"].xf["x"] - e["first"].x0["m"], upper=0.0)],
    )
    return Program(statement, {"first": HLGL(intervals=3), "second": Radau(nodes=[3, 4], intervals=2)})


TRANSCRIPTIONS = {
    "hlgl-lunar": lambda: HLGL(lunar_ascent(), 4),
    "hlgl-flat-moon": lambda: HLGL(flat_moon_ascent(), 4),
    "hlgl-lagrange": lambda: HLGL(with_lagrange(lunar_ascent()), 4),
    "multirate-coarse": lambda: MultiRateHLGL(with_lagrange(lunar_ascent()), 3, ratio=2, fast=["U", "V"]),
    "multirate-fine": lambda: MultiRateHLGL(flat_moon_ascent(), 3, ratio=3, fast=["vy"], coupling="fine"),
    "radau-global": lambda: Radau(with_lagrange(lunar_ascent()), 6),
    "radau-intervals": lambda: Radau(flat_moon_ascent(), [3, 4, 3], 3),
    "radau-entry-rate": lambda: Radau(entry_landing(thrust_angle_rate_deg_s=5.0), 4, 2),
    "hlgl-every-kind": lambda: HLGL(every_kind(None), 3),
    "radau-every-kind": lambda: Radau(every_kind(None), [3, 5], 2),
    "multirate-every-kind": lambda: MultiRateHLGL(every_kind(None), 2, ratio=2, fast=["v"], coupling="quadrature"),
    "multirate-fine-controls": lambda: MultiRateHLGL(
        every_kind(None), 2, ratio=2, fast=["v", "m"], coupling="galerkin", control_mesh="fine"
    ),
    "program-linked-phases": linked_phases,
}


def test_the_checked_nlps_hold_every_kind_of_block():
    """The derivative check sees every block the program writes, not only defects and costs (a block kind added
    without a derivative check is trusted only through converged solves)."""
    names = {b.name for b in linked_phases().nlp.blocks} | {b.name for b in HLGL(every_kind(None), 3).nlp.blocks}
    for kind in ("defects", "lagrange", "mayer", "path_constraints_0", "boundary_constraints", "control_final_u"):
        assert any(n.endswith(kind) for n in names), kind
    for kind in ("link_0_1", "link_time_0_1", "trajectory_cost", "linkage_constraints", "lgr_dynamics"):
        assert any(n.endswith(kind) for n in names), kind
    program = linked_phases()
    assert program.layout["parameter k"].size == 1  # shared: one variable, no row
    assert {p.layout.times.t0_position is not None for p in program.phases} == {False, True}


@pytest.mark.parametrize("name", TRANSCRIPTIONS)
def test_assembled_derivatives_match_casadi(name):
    tr = TRANSCRIPTIONS[name]()
    nlp = tr.nlp
    rng = np.random.default_rng(3)
    w = rng.normal(size=tr.n_variables)
    lam_f, lam_g = 0.7, rng.normal(size=tr.n_constraints)
    J_ref, H_ref = reference_derivatives(nlp, w, lam_f, lam_g)
    _, J = nlp.jac_g(w, [])
    H = nlp.hess_lag(w, [], lam_f, lam_g).full()
    assert np.allclose(np.tril(H, -1), 0), "IPOPT expects the upper triangle only"
    # to rounding, relative to the derivatives' size (a random point can make some large: 1/m near m = 0)
    assert np.abs(J.full() - J_ref).max() < 1e-12 * max(1.0, np.abs(J_ref).max())
    assert np.abs(np.triu(H) + np.triu(H, 1).T - H_ref).max() < 1e-12 * max(1.0, np.abs(H_ref).max())


def test_duplicate_variables_in_one_block_are_summed_correctly():
    """A block whose two local variables are the same NLP variable: d2(z0*z1)/dw2 = 2."""
    z, p = ca.SX.sym("z", 2), ca.SX.sym("p", 0)
    fun = ca.Function("prod", [z, p], [z[0] * z[1]])
    nlp = SeparableNLP(1, 1, [Block("b", fun, np.array([[0], [0]]), np.zeros((0, 1)), np.array([[0]]))])
    H = nlp.hess_lag([1.5], [], 0.0, [1.0]).full()
    assert H[0, 0] == pytest.approx(2.0)
    _, J = nlp.jac_g([1.5], [])
    assert J.full()[0, 0] == pytest.approx(3.0)


def test_block_shape_errors_are_clear():
    z, p = ca.SX.sym("z", 2), ca.SX.sym("p", 1)
    fun = ca.Function("f", [z, p], [z[0] + p])
    with pytest.raises(ValueError, match="constants have shape"):
        Block("b", fun, np.zeros((2, 3), int), np.zeros((2, 3)), np.zeros((1, 3), int))
    with pytest.raises(ValueError, match="outside"):
        SeparableNLP(1, 1, [Block("b", fun, np.array([[0], [5]]), np.zeros((1, 1)), np.array([[0]]))])


def test_quasi_newton_solvers_reach_the_exact_hessian_optimum():
    """IPOPT with L-BFGS and SciPy's SLSQP on a transcription's NLP (nlp_bounds + package), as notebook 02 uses."""
    import casadi as ca

    from ocpkit import HLGL, Control, OptimalControlProblem, State
    from ocpkit.nlp import solve_nlp_slsqp

    problem = OptimalControlProblem(
        "min_energy",
        [State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        [Control("u", -10.0, 10.0)],
        lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=1.0,
        lagrange=lambda x, u, t: u[0] ** 2 / 2,
    )
    tr = HLGL(problem, 4)
    exact = tr.solve()
    lbfgs = tr.solve(ipopt_options={"hessian_approximation": "limited-memory", "tol": 1e-9})
    assert lbfgs.iterations > exact.iterations and lbfgs.objective == pytest.approx(6.0, rel=1e-7)
    lbw, ubw, lbg, ubg = tr.nlp_bounds()
    sol = tr.package(solve_nlp_slsqp(tr.nlp, tr.initial_point(), lbw, ubw, lbg, ubg))
    assert sol.status.startswith("SLSQP") and sol.objective == pytest.approx(6.0, rel=1e-8)
    with pytest.raises(ValueError, match="hessian_approximation"):
        tr.solve(ipopt_options={"hessian_approximation": "bfgs"})
