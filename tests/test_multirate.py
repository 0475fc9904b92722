"""Two-timescale (multi-rate) HLGL collocation (ocpkit.transcription.multirate)."""

import casadi as ca
import numpy as np
import pytest
from _problems import min_energy_double_integrator

from ocpkit import HLGL, Control, MultiRateHLGL, OptimalControlProblem, State

from compendium.paper import paper_table
from compendium.problems import lunar_ascent
from compendium.studies.two_timescale import compare_case

CASES = {  # paper table -> (scheme row, fast states, ratio)
    "table1": ("two_to_one", ["U", "V"], 2),
    "table2": ("four_to_one", ["V"], 4),
}


@pytest.mark.parametrize("table", CASES)
def test_sizes_of_all_four_rows(table):
    paper = paper_table(table).set_index("scheme")
    scheme, fast, ratio = CASES[table]
    coarse, fine = (int(v) for v in paper.loc[scheme, "segments"].split("/"))
    assert fine == coarse * ratio
    mr = MultiRateHLGL(lunar_ascent(), coarse, ratio=ratio, fast=fast)
    assert mr.n_variables == paper.loc[scheme, "nlp_parameters"]
    assert mr.n_defects == paper.loc[scheme, "defect_equations"]
    std = HLGL(lunar_ascent(), fine)
    assert std.n_variables == paper.loc["standard", "nlp_parameters"]
    assert std.n_defects == paper.loc["standard", "defect_equations"]


@pytest.mark.parametrize("table", CASES)
def test_max_difference_at_or_below_the_papers(table):
    paper = paper_table(table).set_index("scheme")
    scheme, fast, ratio = CASES[table]
    coarse = int(paper.loc[scheme, "segments"].split("/")[0])
    rows, _, _ = compare_case(lunar_ascent(), coarse, ratio, fast, scheme)
    ours = rows.set_index("scheme").loc[scheme]
    assert ours["max_state_diff_pct"] <= paper.loc[scheme, "max_state_diff_pct"]
    assert ours["max_control_diff_pct"] <= paper.loc[scheme, "max_control_diff_pct"]


def test_ratio_one_agrees_with_standard_to_discretisation_accuracy():
    pr = lunar_ascent()
    std = HLGL(pr, 20).solve()
    one = MultiRateHLGL(pr, 20, ratio=1, fast=["U", "V"]).solve()
    assert one.decision_variables == std.decision_variables
    assert one.tf == pytest.approx(std.tf, abs=1e-9)
    d = one.difference(std)
    assert d["states"] < 1e-6 and d["controls"] < 1e-4


def test_fine_coupling_is_more_accurate_at_the_same_size():
    pr = lunar_ascent()
    ref = HLGL(pr, 160).solve()
    paper = MultiRateHLGL(pr, 10, ratio=2, fast=["U", "V"]).solve()
    fine = MultiRateHLGL(pr, 10, ratio=2, fast=["U", "V"], coupling="fine").solve()
    assert fine.decision_variables == paper.decision_variables
    assert fine.difference(ref)["controls"] < 0.1 * paper.difference(ref)["controls"]


def coupled_polynomial_problem(deg_x):
    """x' = p'(t) (slow, degree deg_x), z' = x (fast, degree deg_x + 1)."""
    rng = np.random.default_rng(deg_x)
    c = rng.normal(size=deg_x + 1)
    dc = np.polyder(c)

    def dyn(x, u, t):
        return ca.vertcat(sum(a * t**k for k, a in enumerate(dc[::-1])) if dc.size else 0, x[0])

    pr = OptimalControlProblem(
        "coupled", [State("x"), State("z")], [], dyn, t0=0.2, tf=1.5, mayer=lambda a, b, s, t: b[1]
    )
    zc = np.polyint(c)
    return pr, c, zc


@pytest.mark.parametrize("ratio", [1, 2, 3, 4])
@pytest.mark.parametrize("deg_x", [2, 4, 5])
def test_defects_vanish_for_representable_polynomials(ratio, deg_x):
    """Slow x of degree <= 5 and fast z = integral of x of degree <= 5 satisfy every defect exactly."""
    pr, c, zc = coupled_polynomial_problem(deg_x)
    mr = MultiRateHLGL(pr, mesh=[0.3, 0.7], ratio=ratio, fast=["z"])
    tc = 0.2 + 1.3 * mr.coarse_node_fractions()
    tf_ = 0.2 + 1.3 * mr.fine_node_fractions()
    d = np.abs(mr.defects(np.polyval(c, tc)[:, None], np.polyval(zc, tf_)[:, None], np.zeros((mr.n_control_points, 0))))
    if deg_x + 1 <= 5:
        assert d.max() < 1e-12
    else:
        assert d[:2].max() < 1e-12, "the slow defects are exact for a quintic x"
        assert d[2:].max() > 1e-8, "a sixth-degree fast state cannot be collocated exactly"


def test_lagrange_cost_with_split_states():
    """min int u^2, x1' = x2 (slow), x2' = u (fast): u = 6 - 12 t, J = 12, represented exactly."""
    pr = min_energy_double_integrator()
    sol = MultiRateHLGL(pr, 3, ratio=2, fast=["x2"]).solve()
    t = np.linspace(0, 1, 51)
    assert sol.objective == pytest.approx(12.0, abs=1e-9)
    assert np.abs(sol.control(t)[:, 0] - (6 - 12 * t)).max() < 1e-8
    assert np.abs(sol.state(t)[:, 1] - (6 * t - 6 * t**2)).max() < 1e-9


def test_all_slow_and_all_fast_partitions_solve():
    pr = lunar_ascent()
    all_slow = MultiRateHLGL(pr, 10, ratio=2, slow=pr.state_names).solve()
    all_fast = MultiRateHLGL(pr, 10, ratio=2, fast=pr.state_names).solve()
    assert all_slow.tf == pytest.approx(all_fast.tf, abs=1e-6)


def test_partition_errors_are_clear():
    pr = lunar_ascent()
    with pytest.raises(ValueError, match=r"\['W'\] are not states"):
        MultiRateHLGL(pr, 10, ratio=2, fast=["W"])
    with pytest.raises(ValueError, match=r"\['U'\] are in both"):
        MultiRateHLGL(pr, 10, ratio=2, slow=["X", "Y", "U"], fast=["U", "V"])
    with pytest.raises(ValueError, match=r"\['Y'\] are in neither"):
        MultiRateHLGL(pr, 10, ratio=2, slow=["X"], fast=["U", "V"])
    with pytest.raises(ValueError, match="more than once"):
        MultiRateHLGL(pr, 10, ratio=2, fast=["V", "V"])
    with pytest.raises(TypeError, match="sequence of names"):
        MultiRateHLGL(pr, 10, ratio=2, fast="V")
    with pytest.raises(ValueError, match="name the slow states"):
        MultiRateHLGL(pr, 10, ratio=2)


@pytest.mark.parametrize("ratio, exc", [(0, ValueError), (-2, ValueError), (1.5, TypeError)])
def test_bad_ratio(ratio, exc):
    with pytest.raises(exc, match="ratio"):
        MultiRateHLGL(lunar_ascent(), 10, ratio=ratio, fast=["V"])


def test_unknown_coupling():
    with pytest.raises(ValueError, match="coupling must be one of"):
        MultiRateHLGL(lunar_ascent(), 10, ratio=2, fast=["V"], coupling="cubic")


# -- couplings beyond the paper and controls on the fine mesh ---------------------------------------------------


@pytest.mark.parametrize("ratio", [1, 2, 3, 4, 5])
def test_fine_quadrature_weights_integrate_polynomials_over_each_half(ratio):
    from ocpkit.nodes import HLGL_CONTROL_NODES
    from ocpkit.transcription.multirate import fine_quadrature_weights

    W = fine_quadrature_weights(ratio)
    s = np.concatenate([(j + HLGL_CONTROL_NODES[:4]) / ratio for j in range(ratio)] + [[1.0]])
    exact_to = 7 if ratio % 2 == 0 else 4  # whole Gauss-Lobatto segments, or a quartic cut at the centre
    for k in range(exact_to + 1):
        assert W[0] @ s**k == pytest.approx(0.5 ** (k + 1) / (k + 1), abs=1e-14)
        assert W[1] @ s**k == pytest.approx((1 - 0.5 ** (k + 1)) / (k + 1), abs=1e-14)


@pytest.mark.parametrize(
    "coupling, controls",
    [
        ("coarse", "coarse"),
        ("fine", "coarse"),
        ("quadrature", "coarse"),
        ("quadrature", "fine"),
        ("galerkin", "coarse"),
        ("galerkin", "fine"),
    ],
)
def test_every_coupling_represents_the_min_energy_solution(coupling, controls):
    """u = 6 - 12 t, v = 6t - 6t^2, x = 3t^2 - 2t^3 are represented exactly, and the running cost is integrated
    exactly on the fine grid: J = 12 whatever the coupling and the control mesh."""
    pr = min_energy_double_integrator()
    tr = MultiRateHLGL(pr, 3, ratio=3, fast=["x2"], coupling=coupling, control_mesh=controls)
    sol = tr.solve()
    t = np.linspace(0, 1, 51)
    assert sol.objective == pytest.approx(12.0, abs=1e-8)
    assert np.abs(sol.control(t)[:, 0] - (6 - 12 * t)).max() < 1e-7
    assert np.abs(sol.state(t)[:, 1] - (6 * t - 6 * t**2)).max() < 1e-9


@pytest.mark.parametrize("coupling", ["quadrature", "galerkin"])
def test_weak_couplings_with_ratio_one_are_the_collocation_scheme(coupling):
    """With M = 1 the two weak defects are HLGL's: the quintic's slope is the quartic through f."""
    pr = lunar_ascent()
    ipopt = {"tol": 1e-12}
    col = MultiRateHLGL(pr, 10, ratio=1, fast=["U", "V"]).solve(ipopt_options=ipopt)
    weak = MultiRateHLGL(pr, 10, ratio=1, fast=["U", "V"], coupling=coupling).solve(ipopt_options=ipopt)
    assert weak.tf == pytest.approx(col.tf, abs=1e-11)
    d = weak.difference(col)
    assert d["states"] < 1e-8 and d["controls"] < 1e-6


@pytest.mark.parametrize("ratio", [1, 2, 3, 4])
def test_legendre_weights_integrate_against_p0_and_p1(ratio):
    from ocpkit.nodes import HLGL_CONTROL_NODES, hermite_quintic_basis
    from ocpkit.transcription.multirate import legendre_weights

    W, B = legendre_weights(ratio)
    s = np.concatenate([(j + HLGL_CONTROL_NODES[:4]) / ratio for j in range(ratio)] + [[1.0]])
    for k in range(7):
        assert W[0] @ s**k == pytest.approx(1 / (k + 1), abs=1e-14)
        assert W[1] @ s**k == pytest.approx(2 / (k + 2) - 1 / (k + 1), abs=1e-14)
    # B integrates the quintic Hermite interpolant: exact for a quintic
    p = np.polynomial.Polynomial([0.3, -1.0, 0.5, 2.0, -0.7, 0.4])
    dp = p.deriv()
    values = [p(0.0), dp(0.0), p(0.5), dp(0.5), p(1.0), dp(1.0)]
    assert B @ values == pytest.approx(p.integ()(1.0) - p.integ()(0.0), abs=1e-14)
    assert np.allclose(hermite_quintic_basis(np.array([0.25]))[0] @ values, p(0.25))


@pytest.mark.parametrize("fast, ratio", [(["U", "V"], 2), (["V"], 3)])
def test_galerkin_coupling_keeps_the_standard_order_where_the_papers_loses_it(fast, ratio):
    """Control error against a converged reference on 10 and 20 coarse segments: the paper's coupling gains a
    factor of about 4 (second order), the Galerkin coupling more than 12 (fourth order or better)."""
    pr = lunar_ascent()
    ipopt = {"tol": 1e-13}
    ref = HLGL(pr, 200).solve(ipopt_options=ipopt)
    t = np.linspace(0.0, 1.0, 2001)

    def gain(coupling):
        e = []
        for n in (10, 20):
            sol = MultiRateHLGL(pr, n, ratio=ratio, fast=fast, coupling=coupling).solve(ipopt_options=ipopt)
            e.append(np.abs(sol.control(t * sol.tf) - ref.control(t * ref.tf)).max())
        return e[0] / e[1]

    assert gain("coarse") < 6
    assert gain("galerkin") > 12


def test_every_state_fast_with_fine_controls_is_standard_hlgl_on_the_fine_mesh():
    pr = lunar_ascent()
    ipopt = {"tol": 1e-12}
    std = HLGL(pr, 20).solve(ipopt_options=ipopt)
    mr = MultiRateHLGL(pr, 10, ratio=2, fast=pr.state_names, coupling="quadrature", control_mesh="fine").solve(
        ipopt_options=ipopt
    )
    assert mr.decision_variables == std.decision_variables
    assert mr.tf == pytest.approx(std.tf, abs=1e-10)  # the controls' points differ (equispaced, HLGL's)
    d = mr.difference(std)
    assert d["states"] < 1e-9 and d["controls"] < 1e-7


@pytest.mark.parametrize("ratio", [2, 3])
def test_sizes_with_controls_on_the_fine_mesh(ratio):
    pr = lunar_ascent()
    N = 5
    tr = MultiRateHLGL(pr, N, ratio=ratio, fast=["V"], coupling="quadrature", control_mesh="fine")
    assert tr.n_control_points == 4 * ratio * N + 1
    assert tr.n_variables == 3 * (2 * N + 1) + (2 * ratio * N + 1) + (4 * ratio * N + 1) + 1
    assert np.allclose(tr.control_point_fractions(), np.linspace(0, 1, 4 * ratio * N + 1))
    assert "controls on the fine mesh" in tr.label


def test_unknown_control_mesh_and_fine_controls_with_a_collocation_coupling():
    with pytest.raises(ValueError, match="control_mesh"):
        MultiRateHLGL(lunar_ascent(), 10, ratio=2, fast=["V"], control_mesh="finest")
    for coupling in ("coarse", "fine"):
        with pytest.raises(ValueError, match="needs coupling in"):
            MultiRateHLGL(lunar_ascent(), 10, ratio=2, fast=["V"], coupling=coupling, control_mesh="fine")


def _polynomial_problem_with_a_state_dependent_running_cost():
    """x' = z + u1 (slow), z' = x + u2 (fast), L = x z + u1, on [0.2, 1.5]: with x of degree 4, z of degree 3 and
    the controls that make them solutions, every defect vanishes and the cost is a polynomial's integral."""
    rng = np.random.default_rng(1)
    cx, cz = rng.normal(size=5), rng.normal(size=4)
    u1, u2 = np.polysub(np.polyder(cx), cz), np.polysub(np.polyder(cz), cx)
    pr = OptimalControlProblem(
        "poly",
        [State("x"), State("z")],
        [Control("u1"), Control("u2")],
        lambda x, u, t: ca.vertcat(x[1] + u[0], x[0] + u[1]),
        t0=0.2,
        tf=1.5,
        lagrange=lambda x, u, t: x[0] * x[1] + u[0],
    )
    integral = np.polyint(np.polyadd(np.polymul(cx, cz), u1))
    return pr, cx, cz, u1, u2, np.polyval(integral, 1.5) - np.polyval(integral, 0.2)


@pytest.mark.parametrize("ratio", [1, 2, 3, 5])
@pytest.mark.parametrize(
    "coupling, controls",
    [("coarse", "coarse"), ("fine", "coarse"), ("quadrature", "fine"), ("galerkin", "coarse"), ("galerkin", "fine")],
)
def test_running_cost_on_the_fine_grid_sees_the_states_there(coupling, controls, ratio):
    """The running cost depends on both states: exact for polynomials the scheme represents, on a non-uniform mesh
    with t0 != 0 (the slow states at the fine points from their coarse Hermite, the fast from their fine one)."""
    pr, cx, cz, u1, u2, exact = _polynomial_problem_with_a_state_dependent_running_cost()
    mr = MultiRateHLGL(pr, mesh=[0.3, 0.7], ratio=ratio, fast=["z"], coupling=coupling, control_mesh=controls)

    def t(s):
        return 0.2 + 1.3 * s

    tu = t(mr.control_point_fractions())
    X = np.polyval(cx, t(mr.coarse_node_fractions()))[:, None]
    Z = np.polyval(cz, t(mr.fine_node_fractions()))[:, None]
    U = np.stack([np.polyval(u1, tu), np.polyval(u2, tu)], 1)
    assert np.abs(mr.defects(X, Z, U)).max() < 1e-12
    J = float(mr.nlp.objective_function(mr.pack(X, Z, U))) * pr.objective_scale
    assert J == pytest.approx(exact, abs=1e-12)


@pytest.mark.parametrize("controls", ["coarse", "fine"])
def test_a_control_bound_holds_at_every_control_point(controls):
    """min int u^2 with u <= 4 (a path constraint) between rest states: the bound is active; with the controls free
    between constrained points the NLP would undercut the true optimum (J = 12.44 for HLGL)."""
    from ocpkit import Constraint

    bound = Constraint("u_max", lambda x, u, t: u[0], upper=4.0)
    pr = min_energy_double_integrator().replace(path_constraints=[bound])
    mr = MultiRateHLGL(pr, 2, ratio=4, fast=["x2"], coupling="galerkin", control_mesh=controls)
    sol = mr.solve(error_threshold=None)
    assert mr.n_path_points == 4 * mr.control_quartics * 2 + 1
    assert sol.control_values.max() <= 4.0 + 1e-6  # IPOPT's constraint tolerance
    assert sol.objective >= HLGL(pr, 8).solve(error_threshold=None).objective - 1e-3
