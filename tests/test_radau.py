"""Legendre-Gauss-Radau collocation (ocpkit.nodes LGR functions, ocpkit.transcription.radau)."""

import math

import numpy as np
import pytest
from _problems import min_energy_double_integrator

from ocpkit import HLGL, OptimalControlProblem, Radau, SolverError, State
from ocpkit.nodes import differentiation_matrix, lgr_differentiation_matrix, lgr_nodes, lgr_weights

from compendium.problems import (
    entry_landing,
    entry_landing_constants,
    flat_moon_ascent,
    linear_tangent_solution,
    minimum_downrange_bound,
)
from compendium.studies.entry_landing import landing_summary
from compendium.studies.flat_moon import compare_costates, compare_with_exact

S6 = math.sqrt(6.0)
REFERENCE = {  # LGR points and weights on [-1, 1] (closed form for N = 3, tabulated for N = 4)
    3: ([-1.0, (1 - S6) / 5, (1 + S6) / 5], [2 / 9, (16 + S6) / 18, (16 - S6) / 18]),
    4: (
        [-1.0, -0.575318923521694, 0.181066271118531, 0.822824080974592],
        [0.125, 0.657688639960120, 0.776386937686344, 0.440924422353536],
    ),
}


@pytest.mark.parametrize("n", [3, 4])
def test_nodes_and_weights_match_reference_values(n):
    tau, w = REFERENCE[n]
    assert np.allclose(lgr_nodes(n), tau, atol=1e-12)
    assert np.allclose(lgr_weights(lgr_nodes(n)), w, atol=1e-12)


@pytest.mark.parametrize("n", [2, 3, 4, 7, 20, 60, 100])
def test_closed_form_differentiation_matrix_matches_barycentric(n):
    tau = lgr_nodes(n)
    D = lgr_differentiation_matrix(tau)
    ref = differentiation_matrix(np.append(tau, 1.0))[:n]
    assert D.shape == (n, n + 1)
    assert D[0, 0] == pytest.approx(-(n**2 + 1) / 4)
    assert np.abs(D - ref).max() <= 1e-10 * np.abs(ref).max()
    assert np.abs(D.sum(axis=1)).max() <= 1e-11 * n**2


@pytest.mark.parametrize("n", [3, 4, 9])
def test_exactness_of_differentiation_and_quadrature(n):
    tau = lgr_nodes(n)
    x = np.append(tau, 1.0)
    D, w = lgr_differentiation_matrix(tau), lgr_weights(tau)
    for k in range(n + 1):
        assert np.allclose(D @ x**k, k * tau ** max(k - 1, 0) if k else 0, atol=1e-11)
    assert not np.allclose(D @ x ** (n + 1), (n + 1) * tau**n, atol=1e-6)
    for k in range(2 * n - 1):
        assert w @ tau**k == pytest.approx((1 - (-1) ** (k + 1)) / (k + 1), abs=1e-13)
    assert abs(w @ tau ** (2 * n - 1) - (1 - (-1) ** (2 * n)) / (2 * n)) > 1e-8


def polynomial_problem(coeffs, t0=0.3, tf=1.7):
    dp = np.polyder(coeffs)

    def dynamics(x, u, t):
        return sum(c * t**k for k, c in enumerate(dp[::-1]))

    return OptimalControlProblem(
        "poly", [State("x", shift=0.5, scale=2.0)], [], dynamics, t0=t0, tf=tf, mayer=lambda x0, xf, a, b: xf[0]
    )


@pytest.mark.parametrize("mesh", [([6], None), ([4, 4, 4], [0.2, 0.5, 0.3])])
def test_defects_vanish_for_polynomials_up_to_degree_n(mesh):
    counts, fractions = mesh
    n = counts[0]
    for degree in range(n + 2):
        c = np.random.default_rng(degree).normal(size=degree + 1)
        pr = polynomial_problem(c)
        tr = Radau(pr, counts, len(counts), mesh=fractions) if fractions else Radau(pr, n)
        t = 0.3 + 1.4 * tr.state_point_fractions()
        d = np.abs(tr.defects(np.polyval(c, t)[:, None], np.zeros((tr.n_collocation, 0))))
        if degree <= n:
            assert d.max() < 1e-11
        else:
            assert d.max() > 1e-8


def test_lagrange_quadrature_minimum_energy():
    sol = Radau(min_energy_double_integrator(), 4, 3).solve()
    t = np.linspace(0, 1, 51)
    assert sol.objective == pytest.approx(12.0, abs=1e-9)
    assert np.abs(sol.control(t)[:, 0] - (6 - 12 * t)).max() < 1e-8


@pytest.mark.parametrize("nodes, intervals", [(20, 1), (10, 4)])
def test_flat_moon_states_and_costates_against_closed_form(nodes, intervals):
    exact = linear_tangent_solution()
    sol = Radau(flat_moon_ascent(), nodes, intervals).solve(ipopt_options={"tol": 1e-12})
    assert abs(compare_with_exact(sol, exact)["tf_error_s"]) < 1e-7
    lam = compare_costates(sol, exact)
    assert lam["max"] < 1e-8
    # the Hamiltonian of the estimates is -1 (free tf, Mayer cost tf) at every point
    x, lam_v = sol.state_values, sol.costate_values
    f = np.array([np.asarray(sol.problem.dynamics(xi, sol.control(t), t)).ravel() for t, xi in zip(sol.state_times, x)])
    assert np.abs((lam_v * f).sum(axis=1) + 1.0).max() < 1e-6


def test_costates_dataframe_exports_the_estimates_and_refuses_without_them():
    sol = Radau(min_energy_double_integrator(), 4, 2).solve()
    df = sol.costates_dataframe()
    assert list(df.columns) == ["t", "lambda_x1", "lambda_x2"]
    assert np.array_equal(df.to_numpy()[:, 1:], sol.costate_values)
    import dataclasses

    seeing = HLGL(min_energy_double_integrator(), 2).solve()
    blind = dataclasses.replace(seeing, phases=[dataclasses.replace(seeing.phases[0], costate_values=None)])
    with pytest.raises(ValueError, match="no costate estimates"):
        blind.costates_dataframe()


def test_affine_scaling_does_not_change_the_solution():
    base = min_energy_double_integrator()
    shifted = OptimalControlProblem(
        "shifted",
        [State("x1", initial=0.0, final=1.0, shift=0.5, scale=0.25), State("x2", initial=0.0, final=0.0, scale=3.0)],
        base.controls,
        lambda x, u, t: base.dynamics(x, u, t),
        tf=1.0,
        lagrange=lambda x, u, t: u[0] ** 2,
    )
    for make in (lambda p: Radau(p, 5, 2), lambda p: HLGL(p, 3)):
        a, b = make(base).solve(), make(shifted).solve()
        assert a.objective == pytest.approx(b.objective, abs=1e-10)
        assert np.allclose(a.state_values, b.state_values, atol=1e-9)


def test_entry_landing_converges_and_final_mass_is_mesh_independent():
    m = {n: landing_summary(Radau(entry_landing(), n).solve())["final_mass"] for n in (60, 100)}
    assert abs(m[60] - m[100]) < 1e-6
    assert 0.8 < m[100] < 1.0


def test_entry_landing_controls_are_admissible_and_reintegrate():
    sol = Radau(entry_landing(), 10, 20).solve()
    u = sol.control(sol.time_grid(1001))
    lo = [c.lower for c in sol.problem.controls]
    hi = [c.upper for c in sol.problem.controls]
    assert np.all(u >= lo) and np.all(u <= hi)
    c = entry_landing_constants()
    e = sol.reintegrate(controls="interpolant").max_error_by_state
    assert max(e["r"], e["s"]) * c["R0_m"] < 0.01  # metres


def test_published_downrange_is_infeasible():
    assert minimum_downrange_bound("corrected")["downrange_bound_m"] > 60
    with pytest.raises(SolverError, match="Infeasible_Problem_Detected"):
        Radau(entry_landing(downrange_m=60.0), 10, 20).solve()
    shortest = Radau(entry_landing(objective="min_downrange"), 10, 20).solve()
    bound = minimum_downrange_bound("as_published")["downrange_bound_m"]
    assert landing_summary(shortest)["final_downrange_m"] >= bound


def test_rate_limit_is_imposed():
    rate = 5.0
    sol = Radau(entry_landing(thrust_angle_rate_deg_s=rate), 10, 20).solve()
    c = entry_landing_constants()
    r = sol.control(sol.time_grid(501))[:, sol.problem.control_names.index("eps_rate")]
    assert np.degrees(np.abs(r).max()) / c["time_unit_s"] <= rate * (1 + 1e-9)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"aero_model": "newtonian"}, "aero_model"),
        ({"downrange_m": -5.0}, "downrange_m"),
        ({"thrust_angle_rate_deg_s": 0.0}, "thrust_angle_rate"),
        ({"objective": "min_time"}, "objective"),
    ],
)
def test_bad_entry_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        entry_landing(**kwargs)


@pytest.mark.parametrize(
    "nodes, intervals, exc, match",
    [
        (1, 1, ValueError, "at least 2"),
        (0, 3, ValueError, "at least 2"),
        (2.5, 1, TypeError, "integer"),
        ([5, 5], 3, ValueError, "2 node counts given for 3 intervals"),
        (5, 0, ValueError, "at least 1"),
    ],
)
def test_bad_radau_parameters(nodes, intervals, exc, match):
    with pytest.raises(exc, match=match):
        Radau(flat_moon_ascent(), nodes, intervals)


def test_reintegrate_rejects_unknown_control_mode():
    sol = Radau(min_energy_double_integrator(), 4, 1).solve()
    with pytest.raises(ValueError, match="controls must be"):
        sol.reintegrate(controls="raw")


def test_reintegration_uses_each_intervals_own_control_up_to_its_end():
    """LGR controls jump at interval boundaries; each interval is re-integrated with its own polynomial."""
    from scipy.integrate import solve_ivp

    from ocpkit.nodes import lagrange_matrix

    tr = Radau(flat_moon_ascent(), 3, 4)
    sol = tr.solve()
    rei = sol.reintegrate(controls="interpolant", rtol=1e-12, atol=1e-12)
    x = sol.state_values[0].copy()
    bp = sol.breakpoints
    for i, (a, b) in enumerate(zip(bp[:-1], bp[1:])):
        tau = tr.tau[i]
        u = sol.control_values[tr.offsets[i] : tr.offsets[i] + tr.counts[i], 0]

        def rhs(t, y, a=a, b=b, tau=tau, u=u):
            theta = float(lagrange_matrix(tau, np.array([2 * (t - a) / (b - a) - 1]))[0] @ u)
            return np.asarray(sol.problem.dynamics(y, [theta], t)).ravel()

        x = solve_ivp(rhs, (a, b), x, method="DOP853", rtol=1e-13, atol=1e-10).y[:, -1]
    err = np.abs(rei.states[-1] - x)
    # with the next interval's control at each interval's end the positions differ by ~1e-6 m
    assert err[:2].max() < 2e-7 and err[2:].max() < 5e-10


def test_a_large_nlp_with_a_shared_column_is_ordered_by_qamd():
    """From SHARED_COLUMN_POINTS collocation points, a Radau NLP with a free tf (a column every point depends on:
    AMF's time grows much faster than the mesh there) gets ocpkit's QAMD ordering; one point fewer, or a fixed tf,
    keeps Radau's AMF; an override still wins."""
    from ocpkit.program.program import SHARED_COLUMN_POINTS

    from compendium.problems import flat_moon_ascent, rayleigh_mixed

    moon, fixed = flat_moon_ascent(), rayleigh_mixed()  # free tf; fixed tf, no free parameter
    at = -(-SHARED_COLUMN_POINTS // 3)
    big, short = Radau(moon, 3, at), Radau(moon, 3, at - 1)
    assert big.program.n_collocation_points >= SHARED_COLUMN_POINTS > short.program.n_collocation_points
    assert big.program.shared_columns == 1 and Radau(fixed, 3, at).program.shared_columns == 0
    assert big.effective_ipopt_options()["mumps_pivot_order"] == 6
    assert short.effective_ipopt_options()["mumps_pivot_order"] == 2
    assert Radau(fixed, 3, at).effective_ipopt_options()["mumps_pivot_order"] == 2
    assert big.effective_ipopt_options({"mumps_pivot_order": 2})["mumps_pivot_order"] == 2
    # a dense column spans its own phase: Delta III's four phases of 2700 points, only the last with a free tf
    from ocpkit import Link, Program

    from compendium.problems import delta3_mass_drops, delta3_phases

    links = [Link(k, k + 1, jumps={"m": jump}) for k, jump in enumerate(delta3_mass_drops()[:3])]
    four = Program.from_phases([Radau(p, 3, 900) for p in delta3_phases()], links)
    assert four.n_collocation_points == 10800 and four.points_with_shared_columns == 2700
    assert four.ipopt_defaults == {"mumps_pivot_order": 2}


def test_the_ordering_is_recorded_and_an_override_wins():
    """Radau factorises with MUMPS's AMF ordering below the size of the test above (the rule measured in
    benchmarks/bench_orderings.py, QAMD for several intervals, changes where IPOPT converges; Radau.ipopt_defaults);
    the solution records the linear algebra it ran with, an override wins, and linked phases share a default only
    where every phase asks for it."""
    from test_phases import leg  # min 1/2 int u^2 from (0, 0) to (1, 0), split at t = 1/2

    from ocpkit import HLGL, Link, Program
    from ocpkit.nlp import linear_solver

    from compendium.problems import delta3_mass_drops, delta3_phases, flat_moon_ascent

    problem = flat_moon_ascent()
    assert Radau(problem, 20).effective_ipopt_options()["mumps_pivot_order"] == 2
    assert Radau(problem, 5, 4).solve(error_threshold=None).linear_solver == "mumps (AMF ordering)"
    given = Radau(problem, 5, 4).solve(ipopt_options={"mumps_pivot_order": 6}, error_threshold=None)
    assert given.linear_solver == "mumps (QAMD ordering)" and linear_solver({"linear_solver": "spral"}) == "spral"
    assert HLGL(problem, 10).solve(error_threshold=None).linear_solver == "mumps (QAMD ordering)"
    drops = delta3_mass_drops()
    links = [Link(k, k + 1, jumps={"m": drops[k]}) for k in range(3)]
    assert Program.from_phases([Radau(p, 8, 4) for p in delta3_phases()], links).ipopt_defaults == {
        "mumps_pivot_order": 2
    }
    legs = [HLGL(leg(0.0, 0.5, initial=(0.0, 0.0)), 5), Radau(leg(0.5, 1.0, final=(1.0, 0.0)), 6, 2)]
    two = Program.from_phases(legs).solve(error_threshold=None)  # HLGL and Radau: ocpkit's default for the one NLP
    assert two.linear_solver == "mumps (QAMD ordering)"
