"""Derivative blocks compiled to C equal the interpreted ones to the last bit; the assembly sums as before."""

from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from test_nlp import TRANSCRIPTIONS

from ocpkit import HLGL, Program
from ocpkit import _compiled_blocks as cb
from ocpkit.nlp import _assemble

from compendium.problems import lunar_ascent


@pytest.fixture
def compile_small_blocks(monkeypatch):
    monkeypatch.setattr(cb, "MIN_INSTANCES", 1)


@pytest.mark.parametrize("name", TRANSCRIPTIONS)
def test_compiled_derivatives_equal_the_interpreted_ones(name, compile_small_blocks):
    interpreted, compiled = TRANSCRIPTIONS[name](), TRANSCRIPTIONS[name]()
    interpreted.compile, compiled.compile = False, True
    assert interpreted.nlp.compiled is None and compiled.nlp.compiled.name.startswith("nlp_")
    rng = np.random.default_rng(5)
    w = rng.normal(size=compiled.n_variables)
    lam_g = rng.normal(size=compiled.n_constraints)
    for a, b in zip(interpreted.nlp.jac_g(w, []), compiled.nlp.jac_g(w, [])):
        assert a.sparsity() == b.sparsity() and np.array_equal(np.array(a.nonzeros()), np.array(b.nonzeros()))
    a, b = interpreted.nlp.hess_lag(w, [], 0.7, lam_g), compiled.nlp.hess_lag(w, [], 0.7, lam_g)
    assert a.sparsity() == b.sparsity() and np.array_equal(np.array(a.nonzeros()), np.array(b.nonzeros()))


def test_a_compiled_solve_is_the_interpreted_one():
    """The lunar ascent on 200 segments and as two linked phases: the same iterates, the same solution."""
    solutions = []
    for compile in (False, True):
        tr = HLGL(lunar_ascent(), 200)
        tr.compile = compile
        solutions.append(tr.solve(error_threshold=None))
        assert (tr.nlp.compiled is not None) == compile
    a, b = solutions
    assert np.array_equal(a.nlp_result.w, b.nlp_result.w) and a.iterations == b.iterations
    phases = []
    for compile in (False, True):
        mp = Program.from_phases([HLGL(lunar_ascent(), 100), HLGL(lunar_ascent(), 100)])
        mp.compile = compile
        phases.append(mp.nlp)
    w = np.random.default_rng(1).normal(size=phases[0].n_variables)
    assert np.array_equal(
        np.array(phases[0].jac_g(w, [])[1].nonzeros()), np.array(phases[1].jac_g(w, [])[1].nonzeros())
    )


def test_auto_compiles_large_nlps_only():
    small = HLGL(lunar_ascent(), 20)
    assert small.nlp.compiled is None  # below AUTO_INSTRUCTIONS
    mid = HLGL(lunar_ascent(), 500)  # 2.9 million instructions, but fewer than 1000 instances: not repaid
    assert mid.nlp.compiled is None
    large = HLGL(lunar_ascent(), 1500)
    assert large.nlp.compiled is not None


def test_a_missing_or_failing_compiler(monkeypatch, tmp_path):
    monkeypatch.setenv("OCPKIT_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(cb, "AUTO_INSTRUCTIONS", 0)
    monkeypatch.setattr(cb, "AUTO_INSTANCES", 0)
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    tr = HLGL(lunar_ascent(), 100)
    assert tr.nlp.compiled is None  # auto: interpreted, silently
    forced = HLGL(lunar_ascent(), 100)
    forced.compile = True
    with pytest.raises(RuntimeError, match="no-such-cc.*was not found"):
        forced.build()
    monkeypatch.setenv("CC", "false")  # found, and fails
    with pytest.warns(cb.CompilationWarning, match="stay interpreted: compiling the NLP's derivative blocks failed"):
        assert HLGL(lunar_ascent(), 100).nlp.compiled is None
    bad = HLGL(lunar_ascent(), 100)
    bad.compile = "yes"
    with pytest.raises(ValueError, match="compile must be 'auto', True or False"):
        bad.build()


@pytest.mark.parametrize("seed", range(4))
def test_assembly_sums_each_key_in_the_entries_order(seed):
    rng = np.random.default_rng(seed)
    n = 200
    keys = rng.integers(0, 60 if seed % 2 else 400, n)
    weights = np.where(rng.random(n) < 0.1, 2.0, 1.0) if seed > 1 else np.ones(n)
    if seed == 0:
        keys = rng.permutation(n)  # every key once: a gather
    values = rng.normal(size=n)
    v = ca.MX.sym("v", n)
    ukeys, out = _assemble(keys, weights, v)
    got = np.array(ca.Function("a", [v], [out])(values)).ravel()
    expected = dict.fromkeys(ukeys.tolist(), 0.0)
    for j in range(n):  # the full sparse product's order: entry by entry
        expected[int(keys[j])] += weights[j] * values[j]
    assert ukeys.tolist() == sorted(expected)
    assert np.array_equal(got, np.array([expected[k] for k in ukeys.tolist()]))


def test_a_choice_of_compile_survives_refinement():
    """``compile`` set on the object holds on every mesh of a refinement from it (here False on meshes "auto"
    would compile)."""
    from ocpkit import _compiled_blocks

    tr = HLGL(lunar_ascent(), 1500)
    tr.compile = False
    solution = tr.solve(mesh_tolerance=1e-3, max_mesh_iterations=2)
    last = solution.program
    assert last.compile is False and last.nlp.compiled is None
    assert _compiled_blocks._normalised(np.True_) is True and _compiled_blocks._normalised(0) is False


def test_a_broken_library_in_the_cache_is_compiled_again(monkeypatch, tmp_path):
    """A library cut short in the cache (written by another process, never loaded here) is compiled again."""
    import subprocess
    import sys

    monkeypatch.setenv("OCPKIT_CACHE_DIR", str(tmp_path))
    code = (
        "from ocpkit import HLGL\nfrom compendium.problems import lunar_ascent\n"
        "tr = HLGL(lunar_ascent(), 100)\ntr.compile = True\nprint(tr.nlp.compiled)"
    )
    library = Path(
        subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout.strip()
    )
    broken = tmp_path / "broken"
    broken.write_bytes(library.read_bytes()[:100])
    broken.replace(library)  # a new file under the name (a loaded library is never written in place)
    again = HLGL(lunar_ascent(), 100)
    again.compile = True
    assert again.nlp.compiled == library and library.stat().st_size > 1000
    assert not list(tmp_path.glob("*.partial"))


def test_a_compiled_multiphase_solve_is_the_interpreted_one(compile_small_blocks):
    from test_phases import leg

    solutions = []
    for compile in (False, True):
        mp = Program.from_phases(
            [HLGL(leg(0.0, 0.5, initial=(0.0, 0.0)), 100), HLGL(leg(0.5, 1.0, final=(1.0, 0.0)), 100)]
        )
        mp.compile = compile
        solutions.append(mp.solve(error_threshold=None))
        assert (mp.nlp.compiled is not None) == compile
    assert np.array_equal(solutions[0].nlp_result.w, solutions[1].nlp_result.w)
    assert solutions[1].objective == pytest.approx(6.0, rel=1e-9)
