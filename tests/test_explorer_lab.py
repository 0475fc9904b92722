"""The explorer in JupyterLab, driven as a user drives it (issue 25): notebook 01 run in Lab in headless Chromium, its
thrust slider moved by keyboard, the new solution read back from the kernel, a value without a solution shown as
failed with no curve, and the published record untouched; notebook 05's thrust slider moved the same way, each
value an extremal found by shooting continuation, its fuel in the status line.

A throw-away clone of the repository is served by `python -m compendium.lab` (as in tests/test_lab_roundtrip.py,
whose Chromium driver, over the DevTools protocol, and Lab commands this reuses). About 20 s each.
"""

from __future__ import annotations

import ast
import json
import time
from collections.abc import Callable

import nbformat
import pytest
from test_lab import needs_chromium
from test_lab_roundtrip import (
    _Browser,
    _clone_working_tree,
    _git,
    _lab_on,
    _run_all,
    pytestmark,  # noqa: F401  (the same skips: Lab and the kernel installed)
)

NAME = "01_lunar_ascent.ipynb"
MOVE_TIMEOUT = 5.0  # from the key press to the new status line in the page (the kernel's part: 0.04 s, benchmarks/bench_explorer.py)

# the explore cell's output: its slider handle, the readout and the status line
_WIDGETS = """(() => {
  const panel = window.__roundtrip.panel;
  const cell = panel.content.widgets.find(c => c.model.type === 'code'
                                               && c.model.sharedModel.getSource().includes('explore('));
  if (!cell) return {error: 'no explore cell in the notebook'};
  const node = cell.outputArea.node;
  const handle = node.querySelector('.noUi-handle');
  const canvas = node.querySelector('.jupyter-matplotlib canvas, .jupyter-matplotlib-canvas-div canvas');
  const status = node.querySelector('.widget-html-content');
  const readout = node.querySelector('.widget-readout');
  window.__explorer = {handle, status};
  return {done: !!(handle && canvas && status), handle: !!handle, canvas: !!canvas,
          status: status && status.textContent, readout: readout && (readout.innerText || readout.value)};
})()"""

# the status line, once it differs from BEFORE, no longer says that a value is being solved, and starts with PREFIX
_STATUS_CHANGED = """(() => {
  const text = window.__explorer.status.textContent;
  return {done: text !== BEFORE && !text.startsWith('solving') && text.startsWith(PREFIX), status: text};
})()"""

# the status line, once it contains TEXT
_STATUS_HAS = """(() => {
  const text = window.__explorer.status.textContent;
  return {done: text.includes(TEXT), status: text};
})()"""

# the explorer as the kernel holds it, after its worker has settled (stdout of one silent execution)
_READ_BACK = """
import gc as _gc, json as _json
from compendium.explorer import Explorer as _Explorer
_e = [_o for _o in _gc.get_objects() if isinstance(_o, _Explorer)][-1]
assert _e.worker.idle(30), "the explorer's worker is still busy"
_o = _e.outcome
_fresh = _e.session.transcription.solve(parameters=_e.values(), error_threshold=None, raise_on_failure=False)
print(_json.dumps({"slider": _e.values(), "drawn": _o.values if _o else None, "solved": bool(_o and _o.solved),
                   "objective": _o.objective if _o else None, "fresh": _fresh.objective if _fresh.converged else None,
                   "visible": [_l.get_visible() for _l in _e.lines], "timings": _e.timings,
                   "worker": {"delivered": _e.worker.delivered, "dropped": _e.worker.dropped,
                              "errors": [repr(_x) for _x in _e.worker.errors]}, "status": _o.status if _o else None}))
"""

_EXECUTE = """(async () => {
  const kernel = window.__roundtrip.panel.sessionContext.session.kernel;
  const future = kernel.requestExecute({code: CODE, silent: false, store_history: false});
  let text = '', error = null;
  future.onIOPub = msg => {
    if (msg.header.msg_type === 'stream') text += msg.content.text;
    if (msg.header.msg_type === 'error') error = msg.content.ename + ': ' + msg.content.evalue;
  };
  await future.done;
  return {done: true, text, error};
})()"""


def _key(browser: _Browser, key: str, code: int) -> None:
    browser.js("window.__explorer.handle.focus()")
    for kind in ("rawKeyDown", "keyUp"):
        browser.call("Input.dispatchKeyEvent", type=kind, key=key, code=key, windowsVirtualKeyCode=code)


def _read_back(
    browser: _Browser, settled: bool = False, code: str = _READ_BACK, until: Callable[[dict], bool] | None = None
) -> dict:
    """The explorer as the kernel holds it (``code``: a read-back printing it as one JSON line, notebook 01's by
    default). ``settled``: read again, for up to MOVE_TIMEOUT, until the value drawn is the sliders' and ``until``
    holds of the read, where given (a key's last value change may reach the kernel after the first read; seen once in
    CI, with the worker idle and the third of five values drawn: the reads are printed)."""
    end = time.monotonic() + MOVE_TIMEOUT
    while True:
        value = browser.js(_EXECUTE.replace("CODE", json.dumps(code)))
        assert not value["error"], value
        read = json.loads(value["text"].strip().splitlines()[-1])
        done = read["drawn"] == read["slider"] and (until is None or until(read))
        if not settled or done or time.monotonic() > end:
            return read
        print(f"not yet drawn: {read}")
        time.sleep(0.2)


def _move(browser: _Browser, key: str, code: int, times: int = 1, prefix: str = "") -> tuple[dict, float]:
    """Press ``key`` ``times`` on the slider; the status line once it has changed (and starts with ``prefix``: a
    status of an earlier key's last value, which can reach the kernel late, is not taken for this key's)."""
    before = browser.js("window.__explorer.status.textContent")
    start = time.monotonic()
    for _ in range(times):
        _key(browser, key, code)
    changed = _STATUS_CHANGED.replace("BEFORE", json.dumps(before)).replace("PREFIX", json.dumps(prefix))
    return browser.poll(changed, MOVE_TIMEOUT, f"{key} on the slider"), time.monotonic() - start


@needs_chromium
def test_moving_the_thrust_slider_in_lab_solves_and_redraws(tmp_path, monkeypatch):
    monkeypatch.delenv("OCPKIT_OUTPUT_DIR", raising=False)
    monkeypatch.delenv("OCPKIT_PROGRESS", raising=False)
    clone = tmp_path / "clone"
    _clone_working_tree(clone)
    with _lab_on(clone, tmp_path) as (server, browser):
        _run_all(server, browser, NAME)
        widgets = browser.poll(_WIDGETS, 30, "the explorer's slider, figure and status line in the page")
        assert "Solve_Succeeded" in widgets["status"], widgets
        default = _read_back(browser)
        assert default["slider"] == {"a": 3.0, "altitude_km": 185.2}

        moved, seconds = _move(browser, "ArrowRight", 39, times=5)
        after = _read_back(browser, settled=True)
        print(f"five steps right: the status line changed after {seconds:.2f} s; {after['timings']}")
        assert after["slider"]["a"] > 3.0 and after["drawn"] == after["slider"] and after["solved"]
        assert after["objective"] == pytest.approx(after["fresh"], rel=1e-7)  # the solution at that value
        assert after["objective"] < default["objective"] and all(after["visible"])  # more thrust, sooner
        assert "Solve_Succeeded" in moved["status"] and seconds < MOVE_TIMEOUT

        # the slider's low end, a twentieth of the weight: no solution (the status of a right step's last value can
        # still arrive first: seen once in CI, the kernel then at 3.2458 with Home's value not yet received)
        failed, _ = _move(browser, "Home", 36, prefix="FAILED")
        low = _read_back(browser, settled=True)
        assert low["slider"]["a"] == pytest.approx(0.05) and not low["solved"], low
        assert not any(low["visible"]) and failed["status"].startswith("FAILED"), failed
    assert _git(clone, "status", "--porcelain", "--", "figures", "data") == ""  # the record is untouched


# notebook 05's explorer as the kernel holds it: the transfer drawn, and the thrust the slider shows
_READ_BACK_TRANSFER = """
import gc as _gc, json as _json
from compendium.explorer import Explorer as _Explorer
from compendium.studies.orbit_transfer import fuel_kg as _fuel
_e = [_o for _o in _gc.get_objects() if isinstance(_o, _Explorer)][-1]
assert _e.worker.idle(60), "the explorer's worker is still busy"
_o = _e.outcome
print(_json.dumps({"slider": _e.values(), "drawn": _o.values, "solved": _o.solved, "norm": _o.error_estimate,
                   "fuel": _fuel(_o.solution) if _o.solved else None, "note": _o.note,
                   "visible": [_l.get_visible() for _l in _e.lines], "step": _e.sliders["thrust_N"].step}))
"""


def _explore_cells_of_05(cells: list) -> list:
    """Notebook 05's cells that its Explore cell needs, in order: the parameters, the set-up, the cells that define
    the minimum-time table, the energy solutions and the L1 runs at each thrust (``reference``), the Explore cell and
    the last, which moves the run's outputs into place. The rest of a run at 5 N (the longitude scan, the Jacobian
    check, the horizon study: about 30 s of its 36) draws on none of them."""
    needed = {"tmin_table", "energy", "reference"}

    def assigned(source: str) -> set[str]:  # the names a cell's top-level statements assign
        targets = [t for node in ast.parse(source).body if isinstance(node, ast.Assign) for t in node.targets]
        return {n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)}

    kept = [
        c
        for c in cells
        if c.cell_type == "code"
        and (
            {"parameters", "hide-cell", "remove-cell"} & set(c.metadata.get("tags", []))
            or needed & assigned(c.source)
            or "explore(" in c.source
        )
    ]
    found = {name for c in kept for name in needed & assigned(c.source)}
    assert found == needed, f"notebook 05's cells changed: found {sorted(found)}"
    assert "explore(" in kept[-2].source and "outputs.publish()" in kept[-1].source, "notebook 05's end changed"
    return kept


@needs_chromium
def test_moving_the_transfers_thrust_in_lab_follows_the_extremal(tmp_path, monkeypatch):
    """Notebook 05's Explore section: two steps left on the thrust slider, each an extremal found by shooting
    continuation from the last, its fuel and switchings in the status line. The notebook's thrusts are set to the
    explorer's own 5 N in its parameters cell, as a user exploring would, and only the cells the Explore cell
    follows the transfer from are kept before it (:func:`_explore_cells_of_05`): nbval runs the whole notebook."""
    monkeypatch.delenv("OCPKIT_OUTPUT_DIR", raising=False)
    monkeypatch.delenv("OCPKIT_PROGRESS", raising=False)
    clone = tmp_path / "clone"
    _clone_working_tree(clone)
    path = clone / "notebooks" / "05_orbit_transfer.ipynb"
    nb = nbformat.read(str(path), as_version=4)
    cell = next(c for c in nb.cells if "parameters" in c.metadata.get("tags", []))
    assert cell.source.startswith("thrusts = [5.0, 1.0]"), cell.source[:80]
    cell.source = cell.source.replace("thrusts = [5.0, 1.0]", "thrusts = [5.0]", 1)
    nb.cells = _explore_cells_of_05(nb.cells)
    nbformat.write(nb, str(path))
    with _lab_on(clone, tmp_path) as (server, browser):
        _run_all(server, browser, "05_orbit_transfer.ipynb")
        widgets = browser.poll(_WIDGETS, 60, "the transfer explorer's slider, figure and status line in the page")
        assert "converged" in widgets["status"] and "switchings" in widgets["status"], widgets
        default = _read_back(browser, code=_READ_BACK_TRANSFER)
        assert default["slider"] == {"thrust_N": 5.0} and default["solved"]

        _, seconds = _move(browser, "ArrowLeft", 37, times=2)
        # both steps: the kernel can hold the first step's value, drawn, before the second's reaches it
        two_left = 5.0 - 2 * default["step"]
        after = _read_back(
            browser,
            settled=True,
            code=_READ_BACK_TRANSFER,
            until=lambda read: read["slider"]["thrust_N"] == pytest.approx(two_left, rel=1e-9),
        )
        print(f"two steps left: the status line changed after {seconds:.2f} s; {after['note']}")
        assert after["slider"]["thrust_N"] == pytest.approx(two_left, rel=1e-9), after
        assert after["drawn"] == after["slider"] and after["solved"]
        assert after["norm"] <= 1e-8 and all(after["visible"])
        # the page's status line shows that extremal (the first step's can reach the page first: the race notebook
        # 01's Home step met in CI)
        fuel = json.dumps(f"fuel {after['fuel']:.3f} kg")
        browser.poll(_STATUS_HAS.replace("TEXT", fuel), MOVE_TIMEOUT, "the status line of the extremal drawn")
    assert _git(clone, "status", "--porcelain", "--", "figures", "data") == ""  # the record is untouched
