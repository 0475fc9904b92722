"""Indirect shooting engine: control laws, compiled integrator, switching handling, Jacobians (ocpkit.shooting)."""

import casadi as ca
import numpy as np
import pytest

from ocpkit import Control, OptimalControlProblem, Outcome, SolverError, State
from ocpkit.shooting import CompiledSystem, HamiltonianSystem, Shooting, ShootingTrajectory, control_law, homotopy
from ocpkit.shooting.strategies import FiniteDifferences

from compendium.problems import double_integrator, double_integrator_solution, harmonic_oscillator


@pytest.fixture(scope="module")
def di_l1():
    pr = double_integrator(lam=1.0)
    return Shooting(pr, control_law(pr, "box"), switching="correction", rtol=1e-12, atol=1e-12)


@pytest.fixture(scope="module")
def osc_system():
    pr = harmonic_oscillator(lam=1.0)
    return pr, CompiledSystem(HamiltonianSystem(pr, control_law(pr, "box")))


def ball_problem(lam):
    return OptimalControlProblem(
        "ball",
        [State("a", initial=0.0, final=1.0), State("b", initial=0.0, final=0.0), State("m", initial=1.0)],
        [Control("u1", -1, 1), Control("u2", -1, 1)],
        lambda x, u, t, P: ca.vertcat(u[0] / x[2], u[1] / x[2] + x[0], -0.1 * ca.norm_2(u)),
        tf=2.0,
        lagrange=lambda x, u, t, P: P["lam"] * ca.norm_2(u) + (1 - P["lam"]) * ca.sumsqr(u),
        parameters={"lam": lam},
    )


@pytest.mark.parametrize("case", ["box-l1", "box-regularized", "ball-l1", "ball-regularized"])
def test_control_law_minimises_the_hamiltonian(case):
    kind, reg = case.split("-")
    reg = reg == "regularized"
    lam = 0.4 if reg else 1.0
    pr = double_integrator(lam=lam) if kind == "box" else ball_problem(lam)
    law = control_law(pr, kind, regularized=reg)
    sysm = HamiltonianSystem(pr, law)
    x, p, u = ca.SX.sym("x", pr.nx), ca.SX.sym("p", pr.nx), ca.SX.sym("u", pr.nu)
    P = pr.parameter_values
    H = ca.Function("H", [x, p, u], [pr.L(x, u, 0, P) + ca.dot(p, pr.f(x, u, 0, P))])
    rng = np.random.default_rng(1)
    for _ in range(200):
        xs = np.array([0.3, -0.2, 1.2][: pr.nx]) + 0.1 * rng.normal(size=pr.nx)
        ps = 3 * rng.normal(size=pr.nx)
        y = np.concatenate([xs, ps, [0.0]])
        mode = sysm.mode_at(y, P)
        ustar = np.asarray(sysm.control(y, mode, P)).ravel()
        cand = rng.uniform(-1, 1, size=(50, pr.nu))
        if kind == "ball":
            cand /= np.maximum(1.0, np.linalg.norm(cand, axis=1))[:, None]
            assert np.linalg.norm(ustar) <= 1 + 1e-12
        best = min(float(H(xs, ps, c)) for c in cand)
        assert float(H(xs, ps, ustar)) <= best + 1e-12


def test_hamiltonian_of_the_wrong_form_is_rejected():
    pr = OptimalControlProblem(
        "quartic",
        [State("x", initial=0.0, final=1.0)],
        [Control("u", -1, 1)],
        lambda x, u, t: u[0],
        tf=1.0,
        lagrange=lambda x, u, t: u[0] ** 4,
    )
    with pytest.raises(ValueError, match="not of the form"):
        control_law(pr, "box")
    with pytest.raises(ValueError, match="regularized=True"):
        control_law(double_integrator(lam=0.5), "box")
    with pytest.raises(ValueError, match="control_set"):
        control_law(double_integrator(), "sphere")


def test_non_autonomous_problem_is_rejected():
    pr = OptimalControlProblem(
        "timed",
        [State("x", initial=0.0, final=1.0)],
        [Control("u", -1, 1)],
        lambda x, u, t: u[0] * t,
        tf=1.0,
        lagrange=lambda x, u, t: ca.fabs(u[0]),
    )
    with pytest.raises(ValueError, match="autonomous"):
        control_law(pr, "box")


def test_analytic_switching_times_with_correction(di_l1):
    exact = double_integrator_solution()
    guess = np.array(exact.p0) * (1 + np.array([0.05, -0.03]))
    r = di_l1.solve(guess)
    assert r.converged and r.norm < 1e-12 and r.status == "converged" and r.status.remedy == ""
    assert r.tol == 1e-8 and 0 < r.iterations <= r.evaluations
    assert np.allclose(r.p0, exact.p0, atol=1e-10)
    assert np.allclose(r.integration.switching_times, [exact.t1, exact.t2], atol=1e-10)
    assert r.objective == pytest.approx(exact.fuel, abs=1e-10)


def test_detection_alone_and_no_detection_land_further_away():
    pr = double_integrator(lam=1.0)
    law = control_law(pr, "box")
    exact = double_integrator_solution()
    errors = {}
    for det in ("none", "detection", "correction"):
        s = Shooting(pr, law, switching=det, jacobian="fd", rtol=1e-8, atol=1e-8)
        r = s.solve(np.array(exact.p0) * 1.02, raise_on_failure=False)
        errors[det] = np.abs(r.p0 - exact.p0).max()
    assert errors["correction"] < 1e-10
    assert errors["none"] > 100 * errors["correction"]


@pytest.mark.parametrize("detection", ["detection", "correction"])
def test_variational_jacobian_matches_central_differences(osc_system, detection):
    pr, compiled = osc_system
    s = Shooting(pr, compiled.system.law, switching=detection, rtol=1e-12, atol=1e-12, system=compiled)
    z = np.array([1.0328, 0.003])
    S_var, J_var = s.jacobian_matrix(z, method="variational")
    traj = s.integrate(z)
    assert traj.switchings >= 30, "switchings inside the horizon"
    S_fd, J_fd = s.jacobian_matrix(z, method="central")
    assert np.allclose(S_var, S_fd, atol=1e-12)
    assert np.abs(J_var - J_fd).max() <= 1e-6 * np.abs(J_fd).max()


def test_energy_to_l1_homotopy_ends_at_the_l1_solution():
    reg_pr, l1_pr = double_integrator(lam=0.0), double_integrator(lam=1.0)
    reg = Shooting(reg_pr, control_law(reg_pr, "box", regularized=True), rtol=1e-12, atol=1e-12)
    l1 = Shooting(l1_pr, control_law(l1_pr, "box"), rtol=1e-12, atol=1e-12)
    path = homotopy(reg, [0.0, 0.5, 0.9, 0.99], [0.5, 0.5], final=l1)
    assert [r.parameters[0] for r in path] == [0.0, 0.5, 0.9, 0.99, 1.0]
    fuels = [r.objective for r in path]
    exact = double_integrator_solution()
    assert np.allclose(path[-1].p0, exact.p0, atol=1e-9)
    assert fuels[-1] == pytest.approx(exact.fuel, abs=1e-10)
    assert path[0].integration.switchings < path[-1].integration.switchings + 3


def test_no_detection_rejects_about_half_the_steps(osc_system):
    pr, compiled = osc_system
    z = np.array([1.03279562, 3.2e-9])
    y0 = np.concatenate([[10.0, 0.0], z, [0.0]])
    none = compiled.integrate(y0, 0.0, float(pr.tf), switching="none")
    det = compiled.integrate(y0, 0.0, float(pr.tf), switching="correction")
    assert none.rejected_ratio > 0.25
    assert det.rejected_ratio < 0.1
    assert det.steps < none.steps
    assert det.hamiltonian_drift < none.hamiltonian_drift


def test_integrator_is_accurate_on_a_smooth_flow(osc_system):
    """|p2| < 1 throughout: no thrust, the oscillator rotates freely; costates too."""
    pr, compiled = osc_system
    T = float(pr.tf)
    y0 = np.array([10.0, 0.0, 0.3, 0.2, 0.0])
    r = compiled.integrate(y0, 0.0, T, switching="correction", rtol=1e-11, atol=1e-11)
    c, s = np.cos(T), np.sin(T)
    # x' = (x2, -x1); p' = (p2, -p1) (p1' = -dH/dx1 = p2, p2' = -p1)
    expected = np.array([10 * c, -10 * s, 0.3 * c + 0.2 * s, 0.2 * c - 0.3 * s, 0.0])
    assert r.switchings == 0
    assert np.abs(r.y - expected).max() < 1e-8
    assert r.hamiltonian_drift < 1e-9


def test_failed_shooting_reports_norm_and_iterations(di_l1):
    with pytest.raises(SolverError, match=r"\|S\| = .* after \d+ shooting-function") as info:
        di_l1.solve([5.0, -3.0], maxfev=3)
    assert info.value.iterations is not None
    assert info.value.outcome is Outcome.MAX_ITERATIONS and info.value.result.status is Outcome.MAX_ITERATIONS
    assert Outcome.MAX_ITERATIONS.remedy in str(info.value)  # the message ends with what to try


def test_the_status_is_converged_exactly_at_tol_and_a_claim_above_it_is_a_stall(di_l1):
    """One rule for every engine: converged iff |S| <= tol; a solver's claim of convergence above tol is a stall,
    its own words kept in detail; a solver that gives no outcome and misses tol failed for its own reason."""
    exact = double_integrator_solution()
    start = np.array(exact.p0) * 1.02
    claims = lambda fun, jac, z0, *, tol, maxfev: (np.asarray(z0), "I converged", Outcome.CONVERGED)  # noqa: E731
    r = di_l1.solve(start, solver=claims, raise_on_failure=False)
    assert not r.converged and r.status is Outcome.STALLED and r.detail == "I converged"
    silent = lambda fun, jac, z0, *, tol, maxfev: (np.asarray(z0), "done")  # noqa: E731
    assert di_l1.solve(start, solver=silent, raise_on_failure=False).status is Outcome.SOLVER_FAILED
    assert di_l1.solve(exact.p0, solver=silent).status is Outcome.CONVERGED
    newton = di_l1.solve(start, solver="newton", tol=1e-30, raise_on_failure=False)
    assert not newton.converged and newton.status is Outcome.STALLED and newton.tol == 1e-30


def test_a_stall_is_diagnosed_unless_the_caller_keeps_only_the_status(di_l1):
    """A stall's noise and grazing are measured (integrations the run's own count leaves out) and said in the error;
    diagnose=False, for restarts that only skip a failed start, measures neither and keeps the status."""
    start = np.array(double_integrator_solution().p0) * 1.02
    told = di_l1.solve(start, solver="newton", tol=1e-30, raise_on_failure=False)
    told_after = di_l1.counts["integrations"] - told.n_integrations  # (solve restarts the counts)
    quiet = di_l1.solve(start, solver="newton", tol=1e-30, raise_on_failure=False, diagnose=False)
    quiet_after = di_l1.counts["integrations"] - quiet.n_integrations
    assert told.status is quiet.status is Outcome.STALLED and told.noise is not None and quiet.noise is None
    assert quiet.grazing is None and np.array_equal(told.z, quiet.z) and told.norm == quiet.norm
    assert quiet_after == 1 and told_after > 20  # the last iterate's integration; and the noise floor's
    with pytest.raises(SolverError) as info:
        di_l1.solve(start, solver="newton", tol=1e-30, diagnose=False)
    assert info.value.outcome is Outcome.STALLED and "noise" not in str(info.value).split("; the last")[0]


def test_bad_shooting_input(osc_system):
    pr, compiled = osc_system
    law = compiled.system.law
    with pytest.raises(ValueError, match="tolerances must be positive"):
        Shooting(pr, law, rtol=0.0, system=compiled)
    with pytest.raises(ValueError, match="switching must be one of"):
        Shooting(pr, law, switching="bisection", system=compiled)
    with pytest.raises(ValueError, match="jacobian must be one of"):
        Shooting(pr, law, jacobian="broyden", system=compiled)
    with pytest.raises(ValueError, match="solver must be one of"):
        Shooting(pr, law, system=compiled).solve([1.0, 0.0], solver="broyden")
    s = Shooting(pr, law, system=compiled)
    with pytest.raises(ValueError, match="z0 must have 2 entries"):
        s.solve([1.0])
    with pytest.raises(ValueError, match="tolerances must be positive"):
        compiled.integrate(np.zeros(5), 0.0, 1.0, atol=-1.0)
    with pytest.raises(ValueError, match="switching must be one of"):
        compiled.integrate(np.zeros(5), 0.0, 1.0, switching="fast")
    interval_start = OptimalControlProblem(
        "free",
        [State("x", initial=(0.0, 0.5), final=1.0)],
        [Control("u", -1, 1)],
        lambda x, u, t: u[0],
        tf=1.0,
        lagrange=lambda x, u, t: ca.fabs(u[0]),
    )
    with pytest.raises(ValueError, match="fixed or free initial states, not the interval of 'x'"):
        Shooting(interval_start, control_law(interval_start, "box"))


def test_compiled_library_is_cached(osc_system):
    pr, compiled = osc_system
    again = CompiledSystem(HamiltonianSystem(pr, control_law(pr, "box")))
    assert again.library_path == compiled.library_path


@pytest.mark.parametrize("d", [1e-17, 1e-16, 3e-16, 1e-15, 1e-14])
@pytest.mark.parametrize("detection", ["detection", "correction"])
def test_switching_at_the_final_time_to_rounding(d, detection):
    """The last switching of a bang-off-bang arc placed within a few ulps of tf: the integration ends normally."""
    pr = double_integrator(lam=1.0)
    compiled = CompiledSystem(HamiltonianSystem(pr, control_law(pr, "box")))
    T, c = 3.0, 2.0
    # p2(t) = p20 - c t reaches -1 (switch to u = +1) at T (1 - d)
    p20 = -1.0 + c * T * (1 - d)
    y0 = np.array([1.0, 0.0, c, p20, 0.0])
    Psi0 = np.zeros((5, 2))
    Psi0[2:4] = np.eye(2)
    for psi in (None, Psi0):
        r = compiled.integrate(y0, 0.0, T, switching=detection, Psi0=psi, rtol=1e-9, atol=1e-9)
        assert r.status == "ok"
        assert np.all(np.isfinite(r.y))


def _oscillator_switchings(R, theta, T):
    """Times in (0, T) where |p2| = R |cos(t + theta)| = 1 (p1' = p2, p2' = -p1 for the L1 oscillator)."""
    a = np.arccos(1.0 / R)
    base = np.array([-a, a, np.pi - a, np.pi + a])
    k = np.arange(-1, int(T / (2 * np.pi)) + 2)
    t = (base[None, :] + 2 * np.pi * k[:, None]).ravel() - theta
    return np.sort(t[(t > 0) & (t < T)])


@pytest.mark.parametrize("detection", ["detection", "correction"])
def test_short_arcs_inside_a_step_are_found(osc_system, detection):
    """|p2| exceeds 1 by 1e-4 at each extremum: 20 thrust arcs of width 0.028, shorter than the steps.

    The sign test at the step ends misses most of them; the interior check finds every one
    at its analytic switching times."""
    pr, compiled = osc_system
    R, theta, T = 1.0 + 1e-4, 0.3, 20 * np.pi
    y0 = np.array([1.0, 0.0, R * np.sin(theta), R * np.cos(theta), 0.0])
    exact = _oscillator_switchings(R, theta, T)
    assert exact.size == 40
    blind = compiled.integrate(y0, 0.0, T, switching=detection, interior_check=False)
    seen = compiled.integrate(y0, 0.0, T, switching=detection, interior_check=True)
    assert blind.switchings < 10, "the end-of-step test alone misses the short arcs"
    assert seen.switchings == 40 and seen.interior_switchings > 10
    # located to the integrator's accuracy: a crossing this shallow (dg/dt = 0.014) turns the global error
    # of the costates (rtol 1e-8, ten periods) into about 1e-5 in time, 0.05 % of an arc's width
    assert np.abs(seen.switching_times - exact).max() < 5e-5
    # the fuel is the total length of the thrust arcs
    assert seen.y[-1] == pytest.approx(np.sum(exact[1::2] - exact[0::2]), rel=1e-3)


def test_shooting_integrates_with_its_own_problem_parameters():
    """A Shooting on a compiled system shared with another parameter value integrates with its problem's own
    (regression: it used the values the shared system was compiled with)."""

    def problem(gain):
        return OptimalControlProblem(
            "gain",
            [State("x", initial=0.0, final=1.0)],
            [Control("u", -1, 1)],
            lambda x, u, t, P: P["gain"] * u[0],
            tf=2.0,
            lagrange=lambda x, u, t, P: ca.fabs(u[0]),
            parameters={"gain": gain},
        )

    compiled_at_one = CompiledSystem(HamiltonianSystem(problem(1.0), control_law(problem(1.0), "box")))
    pr = problem(3.0)
    s = Shooting(pr, control_law(pr, "box"), system=compiled_at_one)
    z = np.array([-2.0])  # p = -2: |p gain| > 1, so u = +1 all along
    traj = s.integrate(z, record=True)
    assert traj.y[0] == pytest.approx(6.0)  # x(2) = gain * 2, with the problem's gain 3
    assert np.allclose(traj.parameters, [3.0])
    assert np.asarray(traj.controls(compiled_at_one.system)).ravel()[0] == pytest.approx(1.0)


def test_finite_difference_step_follows_the_noise_of_the_shooting_function(osc_system):
    """sqrt(relative noise) (Dennis & Schnabel): the integrator's tolerance without detection, rounding with it."""
    pr, compiled = osc_system
    law = compiled.system.law
    assert Shooting(pr, law, switching="none", rtol=1e-8, system=compiled).fd_step == pytest.approx(1e-4)
    for detection in ("detection", "correction"):
        s = Shooting(pr, law, switching=detection, rtol=1e-8, system=compiled)
        assert s.fd_step == pytest.approx(np.sqrt(np.finfo(float).eps))
    assert Shooting(pr, law, fd_step=1e-6, system=compiled).fd_step == 1e-6
    with pytest.raises(ValueError, match="fd_step"):
        Shooting(pr, law, fd_step=0.0, system=compiled)


def test_one_failure_policy_for_integration_failures():
    """An integration that fails at the last iterate (here every integration: a budget of one step) is a run that
    failed: raised as a SolverError by default, returned with converged=False and the reason with
    raise_on_failure=False (it used to raise either way)."""
    pr = double_integrator(lam=1.0)
    starved = Shooting(pr, control_law(pr, "box"), max_steps=1)
    z0 = np.array([1.0, 1.0])
    with pytest.raises(SolverError):
        starved.solve(z0)
    r = starved.solve(z0, raise_on_failure=False)
    assert not r.converged and r.integration is None and "the integration at the last iterate failed" in r.detail
    assert r.status is Outcome.INTEGRATION_FAILED
    assert np.isnan(r.summary()["steps"]) and np.isnan(r.objective)
    with pytest.raises(ValueError, match="this run has no trajectory"):
        r.trajectory.state(0.0)


def test_solver_options_belong_to_the_solver(di_l1, monkeypatch):
    """MINPACK's xtol and factor are MinpackHybrid's; given to solve() with another solver they are refused (they
    used to be ignored silently), with MINPACK deprecated (and forwarded to it)."""
    from ocpkit.shooting import MinpackHybrid

    z0 = np.array([1.0, 1.0])
    good = di_l1.solve(z0, solver=MinpackHybrid(xtol=1e-12, factor=1.0))
    assert good.converged
    with pytest.raises(TypeError, match="xtol and factor are MINPACK's options"):
        di_l1.solve(z0, solver="newton", xtol=1e-12)
    used, call = [], MinpackHybrid.__call__
    monkeypatch.setattr(MinpackHybrid, "__call__", lambda self, *a, **k: used.append(self) or call(self, *a, **k))
    with pytest.warns(DeprecationWarning, match=r"Shooting.solve\(xtol=..., factor=...\) is deprecated"):
        old = di_l1.solve(z0, xtol=1e-12, factor=1.0)
    assert used == [MinpackHybrid(xtol=1e-12, factor=1.0)] and old.z == pytest.approx(good.z, rel=1e-8)


def test_a_last_iterate_outside_the_domain_is_a_failed_run():
    """A solver that stops where tf <= t0: returned as a failed run under raise_on_failure=False, raised otherwise;
    a free t0 is refused (the engine integrates from a fixed one)."""
    from ocpkit import FreeFinalTime, FreeInitialTime

    pr = OptimalControlProblem(
        "min_time",
        [State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        [Control("u", -1, 1)],
        lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=FreeFinalTime(0.5, 5.0, 2.0),
        mayer=lambda x0, xf, t0, tf: tf,
    )
    s = Shooting(pr, control_law(pr, "box"))

    def stops_outside(fun, jac, z0, *, tol, maxfev):
        return np.array([-1.0, -1.0, -0.5]), "stopped at tf < t0"

    r = s.solve(np.array([-1.0, -1.0, 2.0]), solver=stops_outside, raise_on_failure=False)
    assert not r.converged and r.integration is None and "stopped at tf < t0" in r.detail
    assert r.status is Outcome.INTEGRATION_FAILED
    with pytest.raises(ValueError, match="final time -0.5 must exceed t0"):
        s.solve(np.array([-1.0, -1.0, 2.0]), solver=stops_outside)
    with pytest.raises(ValueError, match="integrates from a fixed t0"):
        Shooting(pr.replace(t0=FreeInitialTime(0.0, 0.4, 0.1)), control_law(pr, "box"))


def gain_problem():
    """x'' = k u, min int u^2/2 + (k - 2)^2 over u and the static parameter k: J(k) = 6 / k^2 + (k - 2)^2, least at
    :func:`gain_optimum`."""
    from ocpkit import FreeParameter

    return OptimalControlProblem(
        "gain",
        [State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        [Control("u")],
        lambda x, u, t, p: [x["v"], p["k"] * u["u"]],
        tf=1.0,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
        mayer=lambda x0, xf, t0, tf, p: (p["k"] - 2.0) ** 2,
        free_parameters=[FreeParameter("k", 0.5, 4.0, guess=1.0)],
    )


def gain_optimum() -> float:
    """The k where dJ/dk = 0: 12 / k^3 = 2 (k - 2)."""
    from scipy.optimize import brentq

    return brentq(lambda k: 12 / k**3 - 2 * (k - 2), 0.5, 4.0)


def test_shooting_with_a_free_parameter():
    """x'' = k u, min int u^2/2 + (k - 2)^2 over u and the static parameter k: J(k) = 6 / k^2 + (k - 2)^2, least
    where 12 / k^3 = 2 (k - 2). Shooting treats k as a state of zero dynamics, free at both ends (its costate
    starts at 0 and ends at dphi/dk: the transversality conditions), with both Jacobians; the law derived for the
    problem as stated is derived again for it."""
    pr, k = gain_problem(), gain_optimum()
    for jacobian in ("variational", "fd"):
        s = Shooting(pr, control_law(pr, "box", regularized=True), jacobian=jacobian)
        assert s.problem.state_names == ["x", "v", "k"] and s.nz == 3
        r = s.solve(np.array([-12.0, -6.0, 2.0]))
        assert r.converged and r.free_parameters["k"] == pytest.approx(k, rel=1e-10)
        assert r.objective == pytest.approx(6 / k**2 + (k - 2) ** 2, rel=1e-10)
    with pytest.raises(ValueError, match=r"derive the law for problem.parameters_as_states\(\)"):
        Shooting(pr, control_law(pr, lambda x, p: -p["v"]))


def test_shooting_with_a_free_initial_state():
    """The double integrator to (1, 0) at rest from v(0) = 0 and x(0) free: no control at all, x(0) = 1, J = 0;
    a Mayer term on a free initial state is refused (its costate would not start at 0)."""
    pr = OptimalControlProblem(
        "free_start",
        [State("x", final=1.0), State("v", initial=0.0, final=0.0)],
        [Control("u")],
        lambda x, u, t: [x["v"], u["u"]],
        tf=1.0,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
    )
    r = Shooting(pr, control_law(pr, "box", regularized=True)).solve(np.array([0.3, 0.5]))
    assert r.converged and r.z[0] == pytest.approx(1.0, abs=1e-12) and abs(r.objective) < 1e-20
    with pytest.raises(ValueError, match="a Mayer term independent of the free initial states"):
        Shooting(pr.replace(mayer=lambda x0, xf, t0, tf: x0["x"] ** 2), control_law(pr, "box", regularized=True))


def _damped_oscillator_at_a_grazing(delta):
    """x1' = x2, x2' = -x1 - c x2 + u, |u| <= 1, min int |u| over ten periods; the costate's peaks grow by 8 %
    each (p2'' = -p2 + c p2'), and p0 is scaled so that the fourth peak of |p2| reaches ``1 + delta``: three peaks
    below the switching level, one grazing it (a thrust arc of width about 2 sqrt(2 delta), or, for delta < 0, a
    touch without a crossing), then about thirty transversal switchings."""
    from scipy.linalg import expm
    from scipy.optimize import minimize_scalar

    c, T = 0.05, 20 * np.pi
    pr = OptimalControlProblem(
        "damped_oscillator",
        [State("x1", initial=1.0, final=0.0), State("x2", initial=0.0, final=0.0)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t, P: ca.vertcat(x[1], -x[0] - c * x[1] + u[0]),
        tf=T,
        lagrange=lambda x, u, t, P: ca.fabs(u[0]),
    )
    A = np.array([[0.0, 1.0], [-1.0, -c]])
    direction = np.array([np.sin(0.3), np.cos(0.3)])

    def p2(s):
        return abs((expm(-A.T * s) @ direction)[1])

    t = np.linspace(0.0, T, 2001)
    samples = np.array([p2(s) for s in t])
    k = np.flatnonzero((samples[1:-1] > samples[:-2]) & (samples[1:-1] > samples[2:]))[3] + 1
    fourth = minimize_scalar(lambda s: -p2(s), bounds=(t[k - 1], t[k + 1]), method="bounded", options={"xatol": 1e-12})
    return pr, (1 + delta) / -fourth.fun * direction, float(fourth.x)


@pytest.mark.parametrize("switching", ["detection", "correction"])
@pytest.mark.parametrize("delta, step", [(1e-4, 1e-7), (1e-5, 1e-8), (-1e-5, 1e-7)])
def test_variational_jacobian_through_a_grazing_switching(switching, delta, step):
    """Many switchings, one of them grazing: the variational Jacobian (its jump term (phi_I - phi_II) tau'(y0) at
    every switching, slide 17 of Martinon & Gergaud) against central differences at the integrator's 1e-12.

    The grazing arc's switchings move as 1/sqrt(delta) with z (dg/dt about sqrt(2 delta) at the crossing), so its
    columns are 4 to 15 times those of transversal switchings alone; the difference step stays well below delta so
    that no difference crosses the grazing (the arc appearing or vanishing). Measured: 1e-7 to 1e-6 relative (the truncation error of the differences grows as (step / delta)^2)."""
    pr, z, _ = _damped_oscillator_at_a_grazing(delta)
    s = Shooting(pr, control_law(pr, "box"), switching=switching, rtol=1e-12, atol=1e-12)
    flight = s.integrate(z, record=True)
    times = flight.switching_times
    assert flight.switchings >= 30, "the transversal switchings after the grazing one"
    shortest = np.diff(times).min()
    if delta > 0:  # the grazing arc is found, at its width
        assert shortest == pytest.approx(2 * np.sqrt(2 * delta), rel=0.2)
    else:  # a touch without a crossing: no arc
        assert shortest > 0.5
    _, J_var = s.jacobian_matrix(z, method="variational")
    _, J_cd = s.jacobian_matrix(z, method=FiniteDifferences(central=True, step=step))
    columns = np.linalg.norm(J_var - J_cd, axis=0) / np.linalg.norm(J_cd, axis=0)  # a weak column seen too
    assert columns.max() <= 1e-5


@pytest.mark.parametrize("delta", [1e-4, -1e-5])
def test_the_closest_approach_of_a_switching_function_names_a_grazing_switching(delta):
    """A touch without a crossing (delta < 0: |p2| peaks 1e-5 below the switching level) is found at the peak, with
    its value; where every peak above the level crosses it, the nearest approach is a peak well below (not grazing)."""
    from ocpkit.shooting.grazing import closest_approach

    pr, z, peak = _damped_oscillator_at_a_grazing(delta)
    s = Shooting(pr, control_law(pr, "box"), rtol=1e-12, atol=1e-12)
    approach = closest_approach(ShootingTrajectory(s.integrate(z, record=True), s.compiled.system))
    if delta < 0:
        assert approach.grazing and approach.t == pytest.approx(peak, abs=1e-6)
        assert abs(approach.g) == pytest.approx(-delta, rel=1e-3)
        assert "comes within 1e-05 of zero" in approach.describe()
    else:
        assert not approach.grazing and abs(approach.g) > 0.05


def test_a_trajectory_builds_each_mapped_function_once_per_size():
    """A trajectory's flows are evaluated once per point and mode, and a map is built once per size: a closest
    approach asks for the switching functions at single points some tens of times (each map took 14 ms to build).
    The values are those of evaluating each end of each interval on its own."""
    pr, z, _ = _damped_oscillator_at_a_grazing(-1e-5)
    s = Shooting(pr, control_law(pr, "box"), rtol=1e-12, atol=1e-12)
    traj = ShootingTrajectory(s.integrate(z, record=True), s.compiled.system)
    built = len(traj._maps)
    for t in np.linspace(traj.t0, traj.tf, 30):
        traj.switching(np.array([t]))
    assert len(traj._maps) == built + 1
    system, P = s.compiled.system, traj.full_parameters
    for i in (0, len(traj._modes) // 2, len(traj._modes) - 1):
        m = int(traj._modes[i])
        assert np.array_equal(np.asarray(system.flow(traj._Y[i], m, P)).ravel(), traj._D0[i])
        assert np.array_equal(np.asarray(system.flow(traj._Y[i + 1], m, P)).ravel(), traj._D1[i])
        assert np.array_equal(np.asarray(system.acceleration(traj._Y[i + 1], m, P)).ravel(), traj._A1[i])


def test_a_stall_at_a_grazing_switching_says_so():
    """Away from the noise, a stall whose last iterate grazes says where, and what gets past it; one that does not
    graze says nothing of it (the wording of the slides' transfer at 0.2 N, notebook 05)."""
    from ocpkit.shooting.grazing import Approach
    from ocpkit.shooting.result import stall_advice

    said = stall_advice(1e-2, 1e-8, 1e-9, Approach(710.02, 0, 9.4e-6, 0.91, "the switching function of u1, u2, u3"))
    assert "not the integrator's noise" in said
    assert (
        "the switching function of u1, u2, u3 comes within 9.4e-06 of zero (1e-05 of its range) at t = 710.02" in said
    )
    assert "a grazing switching" in said and "solver='newton'" in said
    assert "grazing" not in stall_advice(1e-2, 1e-8, 1e-9, Approach(710.02, 0, 0.05, 0.91))
    assert "grazing" not in stall_advice(1e-2, 1e-8, 1e-9, None)
