"""Herman-Conway fifth-degree Gauss-Lobatto transcription (ocpkit.transcription.hlgl)."""

import casadi as ca
import numpy as np
import pytest
from _problems import min_energy_double_integrator

from ocpkit import HLGL, Control, FreeFinalTime, Guess, OptimalControlProblem, Radau, SolverError, State

from compendium.paper import paper_table
from compendium.problems import flat_moon_ascent, linear_tangent_solution, lunar_ascent
from compendium.studies.flat_moon import compare_with_exact


def polynomial_problem(coeffs, t0=0.3, tf=1.7):
    """dx/dt = p'(t) for the polynomial p with the given coefficients (highest first)."""
    dp = np.polyder(coeffs)

    def dynamics(x, u, t):
        return sum(c * t**k for k, c in enumerate(dp[::-1]))

    return OptimalControlProblem("poly", [State("x")], [], dynamics, t0=t0, tf=tf, mayer=lambda x0, xf, a, b: xf[0])


@pytest.mark.parametrize("degree", range(0, 8))
def test_defects_vanish_exactly_up_to_degree_five(degree):
    rng = np.random.default_rng(degree)
    coeffs = rng.normal(size=degree + 1)
    tr = HLGL(polynomial_problem(coeffs), mesh=[0.2, 0.5, 0.3])
    t_nodes = 0.3 + 1.4 * tr.state_node_fractions()
    X = np.polyval(coeffs, t_nodes)[:, None]
    d = np.abs(tr.defects(X, np.zeros((tr.n_control_points, 0)))).max()
    if degree <= 5:
        assert d < 1e-13
    else:
        assert d > 1e-6, "a sixth-degree solution cannot satisfy the quintic collocation exactly"


def test_lagrange_quadrature_and_fixed_final_time_minimum_energy():
    """min int u^2 dt, x1' = x2, x2' = u, (0,0) -> (1,0) in tf = 1: u = 6 - 12 t, J = 12."""
    pr = min_energy_double_integrator()
    sol = HLGL(pr, 5).solve()
    t = np.linspace(0, 1, 101)
    assert sol.objective == pytest.approx(12.0, abs=1e-9)
    assert np.abs(sol.control(t)[:, 0] - (6 - 12 * t)).max() < 1e-8
    assert np.abs(sol.state(t)[:, 0] - (3 * t**2 - 2 * t**3)).max() < 1e-10


@pytest.mark.parametrize("table", ["table1", "table2"])
def test_sizes_match_the_papers_standard_rows(table):
    row = paper_table(table).set_index("scheme").loc["standard"]
    tr = HLGL(lunar_ascent(), int(row["segments"]))
    assert tr.n_variables == row["nlp_parameters"]
    assert tr.n_defects == row["defect_equations"]
    n = int(row["segments"])
    assert tr.n_variables == 4 * (2 * n + 1) + (4 * n + 1) + 1


def test_flat_moon_agrees_with_linear_tangent_law():
    exact = linear_tangent_solution()
    sol = HLGL(flat_moon_ascent(), 16).solve(ipopt_options={"tol": 1e-12})
    err = compare_with_exact(sol, exact)
    assert abs(err["tf_error_s"]) < 1e-8
    assert err["max_theta_error_deg"] < 1e-4
    assert err["max_position_error_m"] < 1e-2
    assert err["max_velocity_error_m_s"] < 1e-3
    rei = sol.reintegrate()
    assert max(rei.max_error_by_state.values()) < 1e-2


def test_exact_solution_satisfies_its_ode():
    from scipy.integrate import solve_ivp

    ex = linear_tangent_solution()
    r = solve_ivp(
        lambda t, x: [x[2], x[3], ex.a * np.cos(ex.theta(t)), ex.a * np.sin(ex.theta(t)) - ex.g],
        (0, ex.tf),
        [0, 0, 0, 0],
        method="DOP853",
        rtol=1e-12,
        atol=1e-9,
    )
    assert np.abs(r.y[:, -1] - ex.state(ex.tf)).max() < 1e-6
    assert ex.state(ex.tf)[1:] == pytest.approx([185.2e3, 1627.0, 0.0], abs=1e-6)


def test_lunar_ascent_converges_and_reintegrates():
    sol = HLGL(lunar_ascent(), 20).solve()
    assert sol.status == "Solve_Succeeded"
    assert sol.tf == pytest.approx(0.4466453338, abs=1e-9)  # regression pin; independent reference below
    assert sol.tf == pytest.approx(Radau(lunar_ascent(), 10, 8).solve().tf, abs=1e-9)
    assert sol.reintegrate().max_error < 1e-8
    sol40 = HLGL(lunar_ascent(), 40).solve(guess=sol)
    assert sol40.tf == pytest.approx(sol.tf, abs=1e-10)


def test_solution_interpolants_pass_through_the_nlp_parameters():
    tr = HLGL(lunar_ascent(), 6)
    sol = tr.solve()
    assert np.allclose(sol.state(sol.state_times), sol.state_values, atol=1e-14)
    assert np.allclose(sol.control(sol.control_times), sol.control_values, atol=1e-12)
    # the Hermite interpolant's slope at the nodes is the dynamics there
    slope = sol.state_interpolant.derivative()(sol.state_times)
    u_nodes = sol.control(sol.state_times)
    f = np.array(
        [
            np.asarray(sol.problem.dynamics(x, u, t)).ravel()
            for t, x, u in zip(sol.state_times, sol.state_values, u_nodes)
        ]
    )
    assert np.allclose(slope, f, atol=1e-12)
    df = sol.to_dataframe(n=11)
    assert list(df.columns) == ["t", "X", "Y", "U", "V", "theta"] and len(df) == 11


def test_nonuniform_mesh_solves_flat_moon():
    exact = linear_tangent_solution()
    sol = HLGL(flat_moon_ascent(), mesh=[1, 2, 1, 3, 1, 2, 2, 1, 1, 2]).solve()
    assert abs(compare_with_exact(sol, exact)["tf_error_s"]) < 1e-4


@pytest.mark.parametrize("bad", [0, -3])
def test_nonpositive_segments_rejected(bad):
    with pytest.raises(ValueError, match="at least 1"):
        HLGL(lunar_ascent(), bad)


@pytest.mark.parametrize("bad", [2.5, "20", True])
def test_non_integer_segments_rejected(bad):
    with pytest.raises(TypeError, match="integer"):
        HLGL(lunar_ascent(), bad)


def test_bad_mesh_rejected():
    with pytest.raises(ValueError, match="positive"):
        HLGL(lunar_ascent(), mesh=[0.5, -0.1, 0.6])
    with pytest.raises(ValueError, match="disagrees"):
        HLGL(lunar_ascent(), 3, mesh=[0.5, 0.5])


def test_wrong_shapes_get_clear_errors():
    tr = HLGL(lunar_ascent(), 4)
    with pytest.raises(ValueError, match=r"states have shape"):
        tr.pack(np.zeros((3, 4)), np.zeros((17, 1)), 0.5)
    with pytest.raises(ValueError, match="returned shape"):
        tr.solve(Guess(states={"X": lambda t: np.zeros(3)}))
    with pytest.raises(KeyError, match="unknown states"):
        tr.solve(Guess(states={"Z": (0, 1)}))
    with pytest.raises(ValueError, match=r"dynamics returned shape \(3, 1\)"):
        OptimalControlProblem(
            "p", [State("a"), State("b")], [], lambda x, u, t: ca.vertcat(1, 2, 3), tf=1.0, lagrange=lambda x, u, t: 1
        )


def test_impossible_bounds_get_clear_errors():
    with pytest.raises(ValueError, match="impossible bounds"):
        State("x", lower=1.0, upper=0.0)
    with pytest.raises(ValueError, match="outside its bounds"):
        State("x", initial=2.0, upper=1.0)
    with pytest.raises(ValueError, match="outside"):
        FreeFinalTime(1.0, 2.0, guess=3.0)
    with pytest.raises(ValueError, match="duplicate"):
        OptimalControlProblem("p", [State("x"), State("x")], [], lambda x, u, t: x, tf=1.0, lagrange=lambda x, u, t: 1)


def test_infeasible_problem_raises_with_ipopt_status():
    """Reaching x = 10 from rest with |u| <= 1 in tf = 1 is impossible."""
    pr = OptimalControlProblem(
        "infeasible",
        [State("x", initial=0.0, final=10.0), State("v", initial=0.0)],
        [Control("u", lower=-1, upper=1)],
        lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=1.0,
        lagrange=lambda x, u, t: u[0] ** 2,
    )
    with pytest.raises(SolverError, match="Infeasible_Problem_Detected") as info:
        HLGL(pr, 5).solve()
    assert info.value.status == "Infeasible_Problem_Detected"


def test_iteration_limit_is_a_failure_not_a_result():
    with pytest.raises(SolverError, match="Maximum_Iterations_Exceeded"):
        HLGL(lunar_ascent(), 10).solve(ipopt_options={"max_iter": 2})


def test_each_defect_is_a_quadrature_weighted_collocation_defect():
    """C1 = w_a h (f_a - x_H'(t_a)) and C2 = w_b h (f_b - x_H'(t_b)), w = 49/180, x_H the quintic Hermite
    interpolant of the segment: why HLGL's defect multipliers are its costates (HLGL.costates)."""
    from ocpkit import nodes
    from ocpkit.transcription.hlgl import hlgl_defects

    rng = np.random.default_rng(0)
    h = 0.7
    xi, xc, xe, fi, fc, fe, fa, fb = rng.normal(size=8)
    rows, rhs = [], []
    for t, x, f in zip((0.0, h / 2, h), (xi, xc, xe), (fi, fc, fe)):
        rows += [[t**k for k in range(6)], [k * t ** (k - 1) if k else 0.0 for k in range(6)]]
        rhs += [x, f]
    c = np.linalg.solve(np.array(rows), np.array(rhs))

    def slope(t):
        return sum(k * c[k] * t ** (k - 1) for k in range(1, 6))

    ta, tb = h * nodes.HLGL_COLLOCATION
    c1, c2 = hlgl_defects(xi, xc, xe, fi, fa, fc, fb, fe, h)
    assert c1 == pytest.approx(49 / 180 * h * (fa - slope(ta)), abs=1e-13)
    assert c2 == pytest.approx(49 / 180 * h * (fb - slope(tb)), abs=1e-13)
