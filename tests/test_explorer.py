"""The explorer (compendium.explorer): its solving half against direct solves, its one-at-a-time worker, and the
widget's curves and status after a move (no browser here: tests/test_lab.py drives JupyterLab)."""

import dataclasses
import threading
import time

import numpy as np
import pytest

from ocpkit import HLGL

from compendium.explorer import STATIC_NOTE, ExploreSession, LatestOnly, explore
from compendium.problems import lunar_ascent


@pytest.fixture(scope="module")
def ascent():
    return HLGL(lunar_ascent(thrust_as_parameter=True), 20)


def test_each_value_is_solved_from_the_nearest_solved_one_and_is_the_direct_solution(ascent):
    session = ExploreSession(ascent, {"a": (0.5, 5.0)})
    assert session.defaults == {"a": 3.0}
    for a, start in [(3.2, 3.0), (3.15, 3.2), (2.0, 3.0), (1.5, 2.0)]:
        outcome = session.solve({"a": a})
        assert outcome.solved and outcome.start == pytest.approx({"a": start})
        fresh = HLGL(lunar_ascent(thrust_as_parameter=True), 20).solve(parameters={"a": a}, error_threshold=None)
        assert outcome.objective == pytest.approx(fresh.objective, rel=1e-7)
        assert outcome.error_estimate < 1e-6 and outcome.iterations <= 10


def test_a_value_without_a_solution_is_an_outcome_not_an_exception(ascent):
    session = ExploreSession(ascent, {"a": (0.05, 5.0)})
    outcome = session.solve({"a": 0.05})  # a twentieth of the weight: no ascent, from any solved point
    assert not outcome.solved and outcome.solution is None and outcome.attempts > 1
    assert outcome.status and outcome.status_line().startswith("FAILED")
    assert session.solve({"a": 2.5}).solved  # and the session goes on
    with pytest.raises(ValueError, match=r"parameter 'a' = 6.0 is outside its range \[0.05, 5\]"):
        session.solve({"a": 6.0})
    with pytest.raises(KeyError, match="unknown parameters"):
        session.solve({"thrust": 2.0})
    with pytest.raises(KeyError, match="unknown parameter 'g'"):
        ExploreSession(ascent, {"g": (0.1, 1.0)})


def test_the_worker_runs_the_newest_value_only():
    seen, done, gate, started = [], [], threading.Event(), threading.Event()

    def work(value):
        seen.append(value)
        started.set()
        gate.wait(5)
        return value

    worker = LatestOnly(work, done.append, debounce=0.0)
    worker.submit(0)
    assert started.wait(5)  # 0 is running
    for value in range(1, 20):
        worker.submit(value)  # each replaces the one before: only 19 will run
    gate.set()
    assert worker.idle(10)
    assert seen == [0, 19] and done == [19]  # 0 finished superseded: kept out of the drawing
    assert worker.dropped == 19


def test_a_move_redraws_the_curves_in_place_and_a_failure_draws_none(ascent):
    explorer = explore(ascent, {"a": (0.05, 5.0)}, ["Y", "theta"])
    lines = list(explorer.lines)
    explorer.sliders["a"].value = 2.0
    assert explorer.worker.idle(30)
    fresh = HLGL(lunar_ascent(thrust_as_parameter=True), 20).solve(parameters={"a": 2.0}, error_threshold=None)
    t, y = lines[0].get_data()
    assert explorer.lines == lines and np.all([line.get_visible() for line in lines])
    assert y == pytest.approx(fresh.state(t)[:, fresh.problem.state_names.index("Y")], abs=1e-9)
    assert "Solve_Succeeded" in explorer.status.value and set(explorer.timings) == {"solve_s", "data_s", "redraw_s"}
    explorer.sliders["a"].value = 0.05
    assert explorer.worker.idle(30)
    assert not any(line.get_visible() for line in lines) and "FAILED" in explorer.status.value
    bundle = explorer._repr_mimebundle_()
    assert bundle["text/plain"] == STATIC_NOTE and bundle["image/png"]
    assert "application/vnd.jupyter.widget-view+json" in bundle


def test_stored_and_reported_the_explorer_is_its_picture():
    """A widget view stored without its kernel renders nothing (nbconvert picks it first): stores and the report
    keep the picture and drop the view; an output that is only a widget keeps it."""
    import nbformat

    from compendium.notebook_source import WIDGET_VIEW, static_views

    view = {WIDGET_VIEW: {"model_id": "x", "version_major": 2, "version_minor": 0}}
    both = nbformat.v4.new_output("execute_result", {**view, "image/png": "iVBO", "text/plain": STATIC_NOTE})
    alone = nbformat.v4.new_output("display_data", {**view, "text/plain": "VBox()"})
    kept = static_views([both, alone])
    assert set(kept[0]["data"]) == {"image/png", "text/plain"} and WIDGET_VIEW in kept[1]["data"]


def test_lab_saves_the_explorer_as_it_is_stored():
    """make lab's pre-save hook: the widget's view goes where a picture comes with it, and so does the widgets'
    state in the notebook's metadata (new model ids every run)."""
    from compendium.notebook_source import WIDGET_VIEW
    from compendium.notebooks import pre_save_hook

    view = {WIDGET_VIEW: {"model_id": "x", "version_major": 2, "version_minor": 0}}
    cell = {"cell_type": "code", "outputs": [{"output_type": "execute_result", "data": {**view, "image/png": "iVBO"}}]}
    model = {"type": "notebook", "content": {"metadata": {"widgets": {"state": {}}, "kernelspec": {}}, "cells": [cell]}}
    pre_save_hook(model=model, path="n.ipynb", contents_manager=None)
    assert model["content"]["metadata"] == {"kernelspec": {}} and set(cell["outputs"][0]["data"]) == {"image/png"}
    pre_save_hook(model={"type": "file", "content": "text"}, path="a.txt", contents_manager=None)  # left alone


def test_the_worker_survives_an_error_and_shows_it_and_a_drag_solves_as_it_goes():
    done = []

    def work(value):
        if value == "boom":
            raise RuntimeError("boom")
        return value

    worker = LatestOnly(work, done.append, lambda request, exc: f"failed {request}: {exc}", debounce=0.02)
    worker.submit("boom")
    assert worker.idle(5) and done == ["failed boom: boom"]
    worker.submit("fine")
    assert worker.idle(5) and done[-1] == "fine" and worker._thread.is_alive()
    # a value every 5 ms for 0.5 s: quieter than the debounce never, yet solves start within max_wait
    done.clear()
    for i in range(100):
        worker.submit(i)
        time.sleep(0.005)
    assert worker.idle(5) and len(done) >= 3 and done[-1] == 99
    worker.stop()
    worker._thread.join(5)
    assert not worker._thread.is_alive()


def test_an_error_in_the_session_is_shown_not_hung(ascent, monkeypatch):
    explorer = explore(ascent, {"a": (0.05, 5.0)}, ["Y"])
    monkeypatch.setattr(explorer.session, "solve", lambda *a, **k: 1 / 0)
    explorer.sliders["a"].value = 2.0
    assert explorer.worker.idle(10)
    assert "ERROR: ZeroDivisionError" in explorer.status.value and not explorer.lines[0].get_visible()
    monkeypatch.undo()
    explorer.sliders["a"].value = 2.5
    assert explorer.worker.idle(10) and "Solve_Succeeded" in explorer.status.value
    explorer.close()


def test_a_first_solution_at_other_values_is_the_default(ascent):
    first = ascent.solve(parameters={"a": 2.0}, error_threshold=None)
    session = ExploreSession(ascent, {"a": (0.05, 5.0)}, first=first)
    assert session.defaults == {"a": 2.0}
    with pytest.raises(ValueError, match="outside its range"):
        ExploreSession(ascent, {"a": (2.5, 5.0)}, first=first)


def test_an_explorer_leaves_matplotlibs_backend_as_it_was():
    """ipympl's import makes itself matplotlib's backend (and closes every figure): in a notebook every figure after
    an explorer would have become a widget. Checked in a fresh process, where ipympl is not imported yet."""
    import subprocess
    import sys

    code = (
        "import matplotlib; matplotlib.use('agg'); import matplotlib.pyplot as plt\n"
        "kept = plt.figure()\n"
        "from ocpkit import HLGL\n"
        "from compendium.explorer import explore\n"
        "from compendium.problems import lunar_ascent\n"
        "e = explore(HLGL(lunar_ascent(thrust_as_parameter=True), 10), {'a': (1.0, 5.0)}, ['Y'])\n"
        "e.widget()\n"
        "print(matplotlib.get_backend(), type(plt.figure().canvas).__name__, plt.fignum_exists(kept.number))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.split() == ["agg", "FigureCanvasAgg", "True"], out.stdout + out.stderr


def test_a_value_dragged_away_and_back_is_the_one_drawn(ascent):
    """Back on the value drawn while another is on its way: the newest (the value drawn) is what ends drawn; an echo
    of the drawn value with nothing on its way starts no solve."""
    explorer = explore(ascent, {"a": (0.05, 5.0)}, ["Y"])
    solves = []
    solve = explorer.session.solve
    explorer.session.solve = lambda values, **kw: solves.append(dict(values)) or solve(values, **kw)
    explorer.sliders["a"].value = 3.0 + 1e-12  # within rounding of the default: an echo
    assert explorer.worker.idle(10) and solves == []
    explorer.sliders["a"].value = 2.0
    explorer.sliders["a"].value = 3.0  # back before 2.0 was drawn
    assert explorer.worker.idle(10) and explorer.outcome.values == {"a": 3.0}
    explorer.close()


def test_choices_build_each_transcription_once_and_start_from_the_nearest_solution_of_the_same_choices():
    from ocpkit import MultiRateHLGL

    problem = lunar_ascent()
    built = []

    def build(M, fast):
        built.append((M, tuple(fast)))
        return MultiRateHLGL(problem, 5, ratio=M, fast=fast)

    session = ExploreSession(build, {}, choices={"M": [1, 2], "fast": {"U, V": ["U", "V"], "V": ["V"]}})
    assert session.choice_defaults == {"M": 1, "fast": "U, V"} and built == [(1, ("U", "V"))]
    outcome = session.solve({"M": 2})
    fresh = MultiRateHLGL(problem, 5, ratio=2, fast=["U", "V"]).solve(error_threshold=None)
    assert outcome.solved and outcome.values == {"M": 2, "fast": "U, V"}
    assert outcome.objective == pytest.approx(fresh.objective, rel=1e-8)
    assert outcome.start == {"M": 1, "fast": "U, V"}  # the start's choices, by label
    partition = session.solve({"M": 2, "fast": "V"})
    assert partition.solved and partition.start == {"M": 2, "fast": "U, V"}  # the same M first
    again = session.solve({"M": 2})  # solved before: that solution, no attempt
    assert again.attempts == 0 and again.solution is outcome.solution
    assert built == [(1, ("U", "V")), (2, ("U", "V")), (2, ("V",))]  # each combination built once
    assert [s[1] for s in session.nearest({"M": 2, "fast": "V"}, count=3)] == [(2, "V"), (2, "U, V"), (1, "U, V")]
    with pytest.raises(ValueError, match=r"choice 'M' = 3 is not one of \[1, 2\]"):
        session.solve({"M": 3})
    with pytest.raises(ValueError, match="default 4 is not one of"):
        ExploreSession(build, {}, choices={"M": [1, 2]}, defaults={"M": 4})
    with pytest.raises(TypeError, match="build"):
        ExploreSession(HLGL(problem, 5), {}, choices={"M": [1, 2]})
    with pytest.raises(TypeError, match=r"cannot be its own label; give \{label: value\}"):
        ExploreSession(build, {}, choices={"fast": [["U", "V"], ["V"]]})
    with pytest.raises(ValueError, match="is not one of"):
        session.solve({"fast": ["V"]})  # a value, not its label
    with pytest.raises(KeyError, match="unknown parameters or choices"):
        session.solve({"N": 5})


class _Failing:
    """A family whose every solve fails (counted), with one parameter and one choice."""

    measure, objective_label = "error estimate", "objective"
    options, choice_defaults = {"k": {"x": 1, "y": 2}}, {"k": "x"}

    def __init__(self):
        self.attempts = []

    def parameters(self):
        return {"p": 0.5}

    def first(self):
        return "the first"

    def solved_at(self, solution):
        return {"p": 0.5}

    def attempt(self, values, labels, start, start_values):
        from ocpkit import SolverError

        self.attempts.append((dict(values), dict(labels)))
        raise SolverError("fake", "never")


def test_a_choice_that_fails_is_tried_once_from_each_nearest_point_not_stepped_towards():
    family = _Failing()
    session = ExploreSession(family, {"p": (0.0, 1.0)})
    outcome = session.solve({"k": "y"})  # the parameter where it was: no continuation to step along
    assert not outcome.solved and outcome.status == "never" and family.attempts == [({"p": 0.5}, {"k": "y"})]
    assert outcome.start == {"p": 0.5, "k": "x"}
    with pytest.raises(ValueError, match="give choices, defaults, solve_options and note to the family"):
        ExploreSession(family, {"p": (0.0, 1.0)}, choices={"k": [1]})


def test_drop_downs_choose_and_the_picture_says_so():
    import base64

    from ocpkit import MultiRateHLGL

    problem = lunar_ascent()
    explorer = explore(
        lambda M, fast: MultiRateHLGL(problem, 5, ratio=M, fast=fast),
        histories=["theta"],
        choices={"M": [1, 2], "fast": {("U", "V"): ["U", "V"], ("V",): ["V"]}},  # tuples as labels
        defaults={"M": 2},
    )
    try:
        assert not explorer.sliders and list(explorer.choosers) == ["M", "fast"]
        assert explorer.values() == {"M": 2, "fast": ("U", "V")}
        assert [label for label, _ in explorer.choosers["fast"].options] == ["('U', 'V')", "('V',)"]
        bundle = explorer._repr_mimebundle_()
        assert bundle["text/plain"] == STATIC_NOTE.replace("move the sliders", "make the choices")
        assert base64.b64decode(bundle["image/png"]).startswith(b"\x89PNG")
        before = explorer.lines[0].get_ydata().copy()
        explorer.choosers["fast"].value = ("V",)
        assert explorer.worker.idle(30) and explorer.outcome.solved
        assert explorer.outcome.values == {"M": 2, "fast": ("V",)}
        fresh = MultiRateHLGL(problem, 5, ratio=2, fast=["V"]).solve(error_threshold=None)
        assert explorer.outcome.objective == pytest.approx(fresh.objective, rel=1e-8)
        assert not np.array_equal(explorer.lines[0].get_ydata(), before)
    finally:
        explorer.close()
    with pytest.raises(ValueError, match="give the histories"):
        explore(lambda M: MultiRateHLGL(problem, 5, ratio=M, fast=["V"]), choices={"M": [1, 2]})


def test_the_two_timescale_explorer_offers_the_notebooks_choices_and_starts_from_its_solution():
    from ocpkit import MultiRateHLGL

    from compendium.studies.two_timescale import coupling_explorer

    problem = lunar_ascent()
    reference = HLGL(problem, 40).solve(error_threshold=None)
    case1 = MultiRateHLGL(problem, 5, ratio=2, fast=["U", "V"]).solve(error_threshold=None)
    explorer = coupling_explorer(
        problem,
        reference,
        segments=[5],
        ratios=[1],
        couplings=["galerkin"],
        partitions={"standard": [], "V fast": ["V"]},
        default={"N": 5, "M": 2, "coupling": "coarse", "fast": ["U", "V"]},
        first=case1,
    )
    try:
        options = {n: list(o) for n, o in explorer.session.options.items()}
        assert options == {"N": [5], "M": [1, 2], "coupling": ["galerkin", "coarse"], "fast": ["V fast", "U, V fast"]}
        assert explorer.session.first is case1 and "NLP parameters" in explorer.outcome.note
        galerkin = explorer.session.solve({"coupling": "galerkin"})
        assert galerkin.solved and galerkin.start == {"N": 5, "M": 2, "coupling": "coarse", "fast": "U, V fast"}
        error = float(galerkin.note.split("control vs reference ")[1].split(" %")[0])
        assert error < case1.difference(reference)["controls"] / 10  # the Galerkin coupling's control (notebook 02)
    finally:
        explorer.close()


def test_a_history_against_a_reference_is_the_difference_at_the_same_normalised_time():
    from compendium.explorer import History

    coarse = HLGL(lunar_ascent(), 5).solve(error_threshold=None)
    fine = HLGL(lunar_ascent(), 40).solve(error_threshold=None)
    t, y = History.against(fine, "theta", samples=501).data(coarse)
    scale = np.abs(fine.control(np.linspace(fine.t0, fine.tf, 501))[:, 0]).max()
    assert 100 * np.max(np.abs(y)) / scale == pytest.approx(coarse.difference(fine, 501)["theta"], rel=1e-12)
    with pytest.raises(KeyError, match="unknown history 'Z'"):
        History.against(fine, "Z")


@pytest.fixture(scope="module")
def transfer():
    """The slides' 5 N L1 transfer, from the published energy costates (as notebook 05 starts it)."""
    from compendium.problems.orbit_transfer import final_longitude
    from compendium.studies import orbit_transfer as study

    systems = study.TransferSystems()
    shooting = systems.shooting("fuel", 5.0, final="longitude", longitude=final_longitude(5.0), tol=1e-8)
    start = study.energy_start_vector(study.read_cache("orbit_transfer_energy"), "longitude", 5.0)
    return systems, study.solve_robustly(shooting, start, maxfev=300)


@pytest.mark.slow
def test_the_transfer_followed_along_the_thrust_reaches_the_slides_one_newton_extremal(transfer):
    from compendium.paper import paper_table
    from compendium.problems.orbit_transfer import final_longitude
    from compendium.studies import orbit_transfer as study

    systems, first = transfer
    session = ExploreSession(study.thrust_family(systems, first, 5.0), {"thrust_N": (1.0, 10.0)})
    step = session.solve({"thrust_N": 4.5})  # one step from 5 N
    assert step.solved and step.start == {"thrust_N": 5.0} and step.measure == "|S|" and step.error_estimate <= 1e-8
    assert step.solution.integration.y[5] == pytest.approx(final_longitude(4.5), abs=1e-6)  # Lf(Tmax) of 4.5 N
    assert f"fuel {study.fuel_kg(step.solution):.3f} kg" in step.status_line()
    path = [session.solve({"thrust_N": T}) for T in (3.0, 2.0, 1.0)]  # jumps of a slider dragged fast
    assert all(o.solved for o in path) and max(o.attempts for o in path) > 2  # some by continuation
    far = path[-1]
    slides = paper_table("switching_detection")
    one = slides[(slides.thrust_N == 1.0) & (slides.detection == "detection") & (slides.jacobian == "fd")].iloc[0]
    assert study.fuel_kg(far.solution) == pytest.approx(one.objective_kg, abs=0.05)
    assert far.solution.integration.switchings == pytest.approx(one.switchings, rel=0.01)


def test_a_transfer_explorer_draws_the_mass_and_the_thrust_and_a_failure_draws_none(transfer):
    from compendium.explorer import History, ShootingFamily
    from compendium.studies import orbit_transfer as study

    systems, first = transfer
    explorer = explore(
        study.thrust_family(systems, first, 5.0),
        {"thrust_N": (1.0, 10.0)},
        [History("m"), History("|u|", function=study.thrust_magnitude, samples=4000)],
        time_label="t (h)",
    )
    try:
        explorer.sliders["thrust_N"].value = 5.5
        assert explorer.worker.idle(60) and explorer.outcome.solved
        mass, thrust = (line.get_ydata() for line in explorer.lines)
        assert mass[-1] == pytest.approx(1500.0 - study.fuel_kg(explorer.outcome.solution), abs=1e-6)
        assert set(np.round(thrust, 9)) <= {0.0, 1.0} and explorer.axes[-1].get_xlabel() == "t (h)"
    finally:
        explorer.close()
    family = study.thrust_family(systems, first, 5.0)
    outcome = ExploreSession(family, {"thrust_N": (1.0, 10.0)}, halvings=1).solve({"thrust_N": 2.0})
    assert not outcome.solved and outcome.status_line().startswith("FAILED")  # too far for one halving
    assert outcome.attempts > 1 and outcome.start == {"thrust_N": 5.0}
    with pytest.raises(ValueError, match="converged"):
        ShootingFamily(family.build, dataclasses.replace(first, converged=False), {"thrust_N": 5.0})


def test_a_shooting_family_gets_all_its_values_and_a_failed_integration_is_a_failed_solve(transfer):
    from compendium.explorer import ShootingFamily
    from compendium.problems.orbit_transfer import final_longitude

    systems, first = transfer
    seen = []

    def build(values):  # a second value, not explored, still reaches build
        seen.append(dict(values))
        T = values["thrust_N"]
        return systems.shooting("fuel", T, final="longitude", longitude=final_longitude(T, values["c"]), tol=1e-8)

    family = ShootingFamily(build, first, {"thrust_N": 5.0, "c": 1.25})
    assert ExploreSession(family, {"thrust_N": (1.0, 10.0)}).solve({"thrust_N": 5.05}).solved
    assert seen == [{"thrust_N": 5.05, "c": 1.25}]
    broken = ShootingFamily(build, first, {"thrust_N": 5.0, "c": 1.25}, predict=lambda a, z, v: z[:3])
    outcome = ExploreSession(broken, {"thrust_N": (1.0, 10.0)}, halvings=1).solve({"thrust_N": 5.05})
    assert not outcome.solved and outcome.status.startswith("ValueError")  # a wrong start: failed, not an error
    other = dataclasses.replace(first)  # equal, but not the family's own
    with pytest.raises(ValueError, match="starts from its own first result"):
        ExploreSession(family, {"thrust_N": (1.0, 10.0)}, first=other)


def test_an_evicted_choice_takes_its_loop_with_it():
    """A family keeps a solve loop per built transcription; evicted from the last ``keep_built``, both go."""
    import gc
    import weakref

    from ocpkit import HLGL

    from compendium.explorer import TranscriptionFamily
    from compendium.problems import lunar_ascent

    family = TranscriptionFamily(
        build=lambda segments: HLGL(lunar_ascent(thrust_as_parameter=True), segments),
        choices={"segments": [4, 6, 8]},
        keep_built=1,
    )
    first = family.transcription({"segments": 4})
    family.attempt({"a": 3.0}, {"segments": 4}, None, {})
    assert len(family._loops) == 1
    gone = weakref.ref(first)
    del first
    family.transcription({"segments": 6})
    gc.collect()
    assert gone() is None and not family._loops
