"""The assembled Jacobian and Hessian equal CasADi's own derivatives (ocpkit.nlp)."""

import casadi as ca
import numpy as np
import pytest

from ocpkit import HLGL, MultiRateHLGL, OptimalControlProblem, Radau
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


TRANSCRIPTIONS = {
    "hlgl-lunar": lambda: HLGL(lunar_ascent(), 4),
    "hlgl-flat-moon": lambda: HLGL(flat_moon_ascent(), 4),
    "hlgl-lagrange": lambda: HLGL(with_lagrange(lunar_ascent()), 4),
    "multirate-coarse": lambda: MultiRateHLGL(with_lagrange(lunar_ascent()), 3, ratio=2, fast=["U", "V"]),
    "multirate-fine": lambda: MultiRateHLGL(flat_moon_ascent(), 3, ratio=3, fast=["vy"], coupling="fine"),
    "radau-global": lambda: Radau(with_lagrange(lunar_ascent()), 6),
    "radau-intervals": lambda: Radau(flat_moon_ascent(), [3, 4, 3], 3),
    "radau-entry-rate": lambda: Radau(entry_landing(thrust_angle_rate_deg_s=5.0), 4, 2),
}


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
    assert np.abs(J.full() - J_ref).max() < 1e-12
    assert np.abs(np.triu(H) + np.triu(H, 1).T - H_ref).max() < 1e-12


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
