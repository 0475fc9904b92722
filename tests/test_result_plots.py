"""``plot()`` on every result (ocpkit.plotting): a direct solution of one phase and of two, a shooting trajectory, an
extremal and a refinement's history each return a matplotlib figure with the axes, bounds, phase boundaries,
switching times and arcs they are said to draw."""

import sys

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.figure import Figure
from test_structure import race, saturated

from ocpkit import (
    HLGL,
    Constraint,
    Control,
    FreeFinalTime,
    FreeInitialTime,
    FreeParameter,
    Link,
    MultiPhaseProblem,
    OptimalControlProblem,
    Program,
    Radau,
    State,
)
from ocpkit.indirect import to_extremal
from ocpkit.shooting import Shooting, control_law


def titles(fig):
    return [ax.get_title() for ax in fig.axes]


def lines(ax, gid):
    return [line for line in ax.get_lines() if line.get_gid() == gid]


def axes(fig, title):
    return next(ax for ax in fig.axes if ax.get_title() == title)


@pytest.fixture(scope="module")
def hlgl():
    """|u| <= 0.5, minimum energy: lower, regular, upper (junctions at 1.5 -+ sqrt(3)/2)."""
    return HLGL(saturated(), intervals=20).solve()


@pytest.fixture(scope="module")
def bouncing():
    """Two phases (the guide's bouncing ball), one linked state, the bounce a jump of v."""

    def flight(name, t0, tf, **ends):
        return OptimalControlProblem(
            name,
            states=[State("h", **ends.get("h", {})), State("v", **ends.get("v", {}))],
            controls=[],
            dynamics=lambda x, u, t, p: [x["v"], -p["g"]],
            t0=t0,
            tf=tf,
            free_parameters=[FreeParameter("g", 1.0, 30.0, guess=9.81)],
        )

    fall = flight("fall", 0.0, FreeFinalTime(0.1, 0.6, 0.4), h={"initial": 1.0, "final": 0.0}, v={"initial": 0.0})
    rise = flight("rise", FreeInitialTime(0.1, 0.6, 0.4), FreeFinalTime(0.61, 2.0, 0.8), v={"final": 0.0})
    bounce = Constraint("bounce", lambda e: e["rise"].x0["v"] + 0.9 * e["fall"].xf["v"], lower=0.0, upper=0.0)
    problem = MultiPhaseProblem(
        [fall, rise],
        [Link("fall", "rise", states=["h"])],
        cost=lambda e: (e["rise"].tf - 0.8) ** 2,
        constraints=[bounce],
    )
    return Program(problem, Radau(nodes=3, intervals=4)).solve()


def test_a_solution_of_one_phase_draws_its_states_controls_bounds_costates_nodes_and_mesh(hlgl):
    fig = hlgl.plot()
    assert isinstance(fig, Figure) and not plt.fignum_exists(fig.number)  # returned, not left open in pyplot
    assert titles(fig) == ["x", "v", "u", "lambda_x", "lambda_v"]
    u = axes(fig, "u")
    assert sorted(line.get_ydata()[0] for line in lines(u, "bound")) == [-0.5, 0.5]
    assert lines(axes(fig, "x"), "bound") == []  # x has no bounds
    (nodes,) = lines(axes(fig, "x"), "nodes")
    np.testing.assert_array_equal(nodes.get_xdata(), hlgl.state_times)
    (mesh,) = lines(u, "mesh")
    np.testing.assert_array_equal(mesh.get_xdata(), hlgl.breakpoints)
    assert lines(u, "switching") == [] and lines(u, "phase boundary") == []
    assert "saturated" in fig.get_suptitle() and f"{hlgl.objective:.8g}" in fig.get_suptitle()


def test_a_two_phase_solution_marks_its_phase_boundary_on_every_axes(bouncing):
    fig = bouncing.plot()
    assert titles(fig) == ["h", "v", "lambda_h", "lambda_v"]  # no controls: no axes for them
    boundary = bouncing.phases[1].t0
    for ax in fig.axes:
        (line,) = lines(ax, "phase boundary")
        assert line.get_xdata()[0] == boundary
    v = axes(fig, "v")
    curves = [line for line in v.get_lines() if line.get_gid() is None]
    assert [(c.get_xdata()[0], c.get_xdata()[-1]) for c in curves] == [(p.t0, p.tf) for p in bouncing.phases]
    assert "phases fall, rise" in fig.get_suptitle()


def test_a_state_constraint_is_drawn_against_its_limit():
    problem = OptimalControlProblem(
        "bryson_denham",
        states=[State("x", initial=0.0, final=0.0), State("v", initial=1.0, final=-1.0)],
        controls=[Control("u")],
        dynamics=lambda x, u, t: [x["v"], u["u"]],
        tf=1.0,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
        path_constraints=[Constraint("x_max", lambda x, u, t: x["x"], upper=1 / 9)],
    )
    sol = Radau(problem, nodes=4, intervals=10).solve()
    fig = sol.plot(which="constraints")
    assert titles(fig) == ["x_max"]
    ax = fig.axes[0]
    (bound,) = lines(ax, "bound")
    assert bound.get_ydata()[0] == pytest.approx(1 / 9)
    (nodes,) = lines(ax, "nodes")
    np.testing.assert_array_equal(nodes.get_xdata(), sol.path_times)
    curve = next(line for line in ax.get_lines() if line.get_gid() is None)
    assert curve.get_ydata().max() == pytest.approx(1 / 9, abs=1e-3)  # on its limit along the middle
    assert titles(sol.plot(names=["x"])) == ["x", "lambda_x"]  # a state and its costate


def test_a_shooting_trajectory_draws_its_costates_and_switching_times(hlgl):
    problem = saturated()
    law = control_law(problem, "box", regularized=True)
    result = Shooting(problem, law, switching="correction", jacobian="variational").solve(hlgl.costate(0.0))
    fig = result.trajectory.plot()
    assert titles(fig) == ["x", "v", "u", "lambda_x", "lambda_v"]
    switching = sorted(line.get_xdata()[0] for line in lines(axes(fig, "u"), "switching"))
    assert switching == list(result.trajectory.breakpoints[1:-1])
    junctions = 1.5 + np.array([-1.0, 1.0]) * np.sqrt(3) / 2
    assert all(np.min(np.abs(np.array(switching) - tj)) < 1e-8 for tj in junctions)
    assert lines(axes(fig, "x"), "nodes") == [] and lines(axes(fig, "x"), "mesh") == []
    titled = result.plot(which=["controls"])
    assert titles(titled) == ["u"] and str(result.status) in titled.get_suptitle()


@pytest.mark.parametrize("method", ["switching", "arcs"])
def test_an_extremal_shades_its_arcs_at_its_own_junctions(method):
    """Both routes: the switching method's structure snapped to its switching times, the arc shooting's own arcs."""
    from ocpkit.shooting.arcs import ArcResult

    direct = Radau(race(), 4, 15).solve(error_threshold=None)
    extremal = to_extremal(direct, method=method)  # upper then lower, switch at 1
    assert isinstance(extremal.shooting, ArcResult) is (method == "arcs")
    fig = extremal.plot()
    u = axes(fig, "u")
    assert [p.get_label() for p in u.patches] == ["upper", "lower"]
    assert u.patches[0].get_x() == 0.0 and u.patches[0].get_width() == pytest.approx(1.0, abs=1e-10)
    assert [line.get_xdata()[0] for line in lines(u, "switching")] == pytest.approx([1.0], abs=1e-10)
    assert "lambda_x" in titles(fig) and "|S|" in fig.get_suptitle()


def test_a_refinement_history_is_drawn_and_a_single_solve_says_how_to_get_one(hlgl):
    refined = HLGL(saturated(), 6).solve(mesh_tolerance=1e-6)
    fig = refined.plot_refinement()
    assert titles(fig) == ["mesh size", "error estimate", "interval boundaries of each mesh"]
    (tolerance,) = lines(axes(fig, "error estimate"), "tolerance")
    assert tolerance.get_ydata()[0] == 1e-6
    estimate = next(line for line in axes(fig, "error estimate").get_lines() if line.get_gid() is None)
    np.testing.assert_array_equal(estimate.get_ydata(), [m.error_estimate for m in refined.mesh_history])
    rows = axes(fig, "interval boundaries of each mesh").collections
    assert [len(r.get_positions()) for r in rows] == [m.fractions.size + 1 for m in refined.mesh_history]
    with pytest.raises(ValueError, match=r"no mesh history.*mesh_tolerance="):
        hlgl.plot_refinement()


def test_a_mesh_whose_state_met_the_tolerance_shows_the_part_that_did_not():
    """The energy-optimal double integrator refined to 1e-6 (the How-do-I page's example): mesh 1's state estimate
    meets the tolerance and its objective part does not, which is why a mesh 2 follows; the figure says so."""
    energy = OptimalControlProblem(
        "double_integrator",
        [State("x", initial=1.0, final=0.0), State("v", initial=0.0, final=0.0)],
        [Control("u", lower=-0.5, upper=0.5)],
        lambda x, u, t: [x["v"], u["u"]],
        tf=3.0,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
    )
    refined = HLGL(energy, intervals=10).solve(mesh_tolerance=1e-6)
    over = [m for m in refined.mesh_history if m.failing]
    assert over and all(m.error_estimate <= 1e-6 < m.worst for m in over)
    ax = axes(refined.plot_refinement(), "error estimate")
    (marker,) = lines(ax, "failing")
    np.testing.assert_array_equal(marker.get_xdata(), [m.iteration for m in over])
    np.testing.assert_array_equal(marker.get_ydata(), [m.worst for m in over])
    assert [a.get_text() for a in ax.texts] == [", ".join(m.failing) for m in over]


def test_bad_arguments_name_themselves_and_the_choices(hlgl):
    with pytest.raises(ValueError, match=r"unknown name 'speed'.*\['x', 'v', 'u'\]"):
        hlgl.plot(names=["speed"])
    with pytest.raises(ValueError, match=r"unknown group 'nodes'.*'states', 'controls', 'costates', 'constraints'"):
        hlgl.plot(which="nodes")
    with pytest.raises(ValueError, match=r"no constraints to draw: which= takes \['states', 'controls', 'costates'\]"):
        hlgl.plot(which="constraints")
    for n in (1, 2.5, True):
        with pytest.raises(ValueError, match="n must be a whole number of points per phase, at least 2"):
            hlgl.plot(n=n)
    with pytest.raises(ValueError, match=r"which= names no group: give some of \['states', 'controls', 'costates'\]"):
        hlgl.plot(which=[])
    with pytest.raises(ValueError, match=r"names= lists no name: give some of \['x', 'v', 'u'\]"):
        hlgl.plot(names=[])


def test_a_figure_given_is_drawn_into_when_empty(hlgl):
    mine = plt.figure()
    try:
        assert hlgl.plot(which="controls", fig=mine) is mine and titles(mine) == ["u"]
        with pytest.raises(ValueError, match="fig already holds axes"):
            hlgl.plot(fig=mine)
    finally:
        plt.close(mine)


def test_without_matplotlib_the_error_says_how_to_install_it(hlgl, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    with pytest.raises(ImportError, match="pip install matplotlib"):
        hlgl.plot()


def test_the_site_draws_a_pages_figures_with_the_pages_own_examples(tmp_path):
    """docs/_example_figures.py runs a page's python blocks and saves the figure of each block that assigns ``fig``
    as the next image, and runs nothing after the last (the Getting-started and How-do-I pictures are their examples',
    drawn at build time)."""
    import importlib.util

    from _examples import DOCS

    spec = importlib.util.spec_from_file_location("_example_figures", DOCS / "_example_figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    page = tmp_path / "page.md"
    page.write_text(
        "```python\nfrom test_structure import saturated\nfrom ocpkit import HLGL\n"
        "solution = HLGL(saturated(), intervals=8).solve()\n```\n\n"
        "```python\nfig = solution.plot(which='controls')\n```\n\n"
        "```python\nfig = solution.plot(which='states')\n```\n\n```python\nraise RuntimeError('not reached')\n```\n"
    )
    out = [tmp_path / "out" / "controls.png", tmp_path / "out" / "states.png"]
    module.draw(page, out)
    assert all(image.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for image in out)
    assert out[0].read_bytes() != out[1].read_bytes()
    page.write_text("```python\nx = 1\n```\n")
    with pytest.raises(ValueError, match="has 0 python blocks that assign fig, and example_figures in conf.py names 1"):
        module.draw(page, [tmp_path / "none.png"])
    assert "fig = solution.plot()" in (DOCS / "getting-started.md").read_text()
    assert "fig = sol.plot()" in (DOCS / "guide" / "how-do-i.md").read_text()


def test_a_failed_solve_and_a_phase_say_what_they_are_in_the_title(bouncing):
    failed = HLGL(saturated(), intervals=20).solve(ipopt_options={"max_iter": 2}, raise_on_failure=False)
    assert not failed.converged
    assert f"NOT CONVERGED ({failed.status})" in failed.plot()._suptitle.get_text()
    phase = bouncing.phase(0)
    assert phase.plot()._suptitle.get_text().startswith(f"{phase.problem.name}: the phase's own cost")


def test_a_large_problem_draws_its_states_and_controls_and_says_how_to_see_the_rest():
    """A chain of nine integrators: 9 states, 1 control and 9 costates are 19 axes, more than CROWDED."""
    from ocpkit.plotting import CROWDED

    chain = OptimalControlProblem(
        "chain",
        [State(f"x{k}", initial=1.0 if k == 0 else 0.0, final=0.0) for k in range(9)],
        [Control("u", -10.0, 10.0)],
        lambda x, u, t: [*(x[k + 1] for k in range(8)), u[0]],
        tf=10.0,
        lagrange=lambda x, u, t: u[0] ** 2,
    )
    sol = HLGL(chain, intervals=10).solve()
    assert 9 + 1 + 9 > CROWDED
    fig = sol.plot()
    assert titles(fig) == [*(f"x{k}" for k in range(9)), "u"]
    assert "costates left out, 10 axes already: plot(which=...) draws them" in fig._suptitle.get_text()
    assert len(titles(sol.plot(which=["costates"]))) == 9  # asked for, they are drawn


def test_a_window_backend_keeps_the_figure_open_for_plt_show(hlgl, monkeypatch):
    """Under Agg or the notebook's inline backend a figure is closed in pyplot at once (a notebook shows it once, as
    the cell's value); under a window backend it stays open, so that plt.show() shows it."""
    before = set(plt.get_fignums())
    fig = hlgl.plot(which="controls")
    assert set(plt.get_fignums()) == before
    monkeypatch.setattr(plt, "get_backend", lambda: "QtAgg")
    fig = hlgl.plot(which="controls")
    try:
        assert fig.number in plt.get_fignums()
    finally:
        plt.close(fig)
