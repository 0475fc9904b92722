"""Derivative blocks compiled to C equal the interpreted ones to the last bit; the assembly sums as before."""

import casadi as ca
import numpy as np
import pytest
from test_nlp import TRANSCRIPTIONS

from ocpkit import HLGL, MultiPhase
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
    assert np.array_equal(a.raw["w"], b.raw["w"]) and a.iterations == b.iterations
    phases = []
    for compile in (False, True):
        mp = MultiPhase([HLGL(lunar_ascent(), 100), HLGL(lunar_ascent(), 100)])
        mp.compile = compile
        phases.append(mp.nlp)
    w = np.random.default_rng(1).normal(size=phases[0].n_variables)
    assert np.array_equal(
        np.array(phases[0].jac_g(w, [])[1].nonzeros()), np.array(phases[1].jac_g(w, [])[1].nonzeros())
    )


def test_auto_compiles_large_nlps_only():
    small = HLGL(lunar_ascent(), 20)
    assert small.nlp.compiled is None  # below AUTO_INSTRUCTIONS
    large = HLGL(lunar_ascent(), 1000)
    assert large.nlp.compiled is not None


def test_a_missing_or_failing_compiler(monkeypatch, tmp_path):
    monkeypatch.setenv("OCPKIT_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(cb, "AUTO_INSTRUCTIONS", 0)
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
