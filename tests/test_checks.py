"""The notebooks' self-checks (compendium.checks): they fail loudly and print a line that is the same on every
machine (the contract's classes: notebooks/contract.toml)."""

import math
import re

import pytest

from compendium.checks import approx, check, check_true
from compendium.paths import notebooks_dir


def test_a_converged_value_prints_one_decade_above_its_tolerance(capsys):
    check("t_f", 481.20387231, 481.2038723, atol=1e-6, digits=10)
    check("t_f", 481.20387179, 481.2038723, atol=1e-6, digits=10)  # another machine's last digits
    check("mass", 17.9997, 18, rtol=1e-4, digits=6)
    check("residual", 1e-5, 0.0, atol=1e-3)  # a value below the tolerance prints as what the tolerance resolves
    check("residual", 4e-5, 0.0, atol=1e-3)
    check("altitude", 1234.5, 1230.0, atol=50.0)
    out = capsys.readouterr().out.splitlines()
    assert out[0] == out[1] == "t_f: 481.20387 (within 1e-06 of 481.2038723): ok"
    assert out[2] == "mass: 18.00 (within 0.0001 relative of 18): ok"
    assert out[3] == out[4] == "residual: 0.00 (within 0.001 of 0): ok"
    assert out[5] == "altitude: 1200 (within 50 of 1230): ok"


def test_exact_equality_is_stated(capsys):
    check("NLP parameters", 246, 246)
    assert capsys.readouterr().out == "NLP parameters: 246 (equal to 246): ok\n"


@pytest.mark.parametrize(
    "value, expected, kwargs",
    [
        (1.0 + 2e-6, 1.0, dict(atol=1e-6)),
        (1.1, 1.0, dict(rtol=0.05)),
        (0.2, 0.1, dict(how="at most")),
        (0.1, 0.2, dict(how="at least")),
        (math.nan, 0.0, dict(atol=1.0)),
        (math.nan, 1.0, dict(how="at most")),
    ],
)
def test_failures_raise_and_name_the_check(value, expected, kwargs):
    with pytest.raises(AssertionError, match="check failed: quantity"):
        check("quantity", value, expected, **kwargs)


def test_one_sided_bounds_include_the_slack_and_print_the_value_with_approx(capsys):
    check("error", 1.05e-8, 1e-8, rtol=0.1, how="at most", digits=2)
    check("order", 3.95, 4.0, atol=0.1, how="at least", digits=2, kind="order")
    check("saved", 0.25, 0.24, how="at least", kind="exact")
    out = capsys.readouterr().out.splitlines()
    assert out == [
        "error: ≈ 1e-08 (at most 1e-08 + 0.1 relative): ok",
        "order: ≈ 4 (at least 4 - 0.1): ok",
        "saved: 0.25 (at least 0.24): ok",
    ]
    with pytest.raises(ValueError, match="kind must be one of"):
        check("x", 1.0, 1.0, kind="nearly")


def _sanitize(text: str) -> str:
    """What nbval does to both sides before comparing them (notebooks/nbval_sanitize.cfg, nbval's own reader)."""
    from nbval.plugin import get_sanitize_patterns

    for regex, replace in get_sanitize_patterns((notebooks_dir() / "nbval_sanitize.cfg").read_text()):
        text = re.sub(regex, replace, text)
    return text


def test_nbval_compares_the_words_and_the_verdict_not_the_digits_after_approx(capsys):
    for error in (2.15e-10, 8.0e-16, 1.1e-15):
        check("re-integration error", error, 1e-8, how="at most")
    a, b, c = capsys.readouterr().out.splitlines()
    assert a != b and _sanitize(a) == _sanitize(b) == _sanitize(c) == "re-integration error: ≈ … (at most 1e-08): ok"
    assert (
        _sanitize(f"theta {approx(4.7)}, position {approx(5.8)} (n = 4..64)") == "theta ≈ …, position ≈ … (n = 4..64)"
    )
    assert _sanitize("t_f = 0.44664533, 246 parameters") == "t_f = 0.44664533, 246 parameters"


def test_quiet_asserts_without_printing(capsys):
    check("x", 1.0, 1.0, quiet=True)
    assert capsys.readouterr().out == ""
    with pytest.raises(AssertionError):
        check("x", 2.0, 1.0, quiet=True)


def test_unknown_relation_is_an_error():
    with pytest.raises(ValueError, match="how must be"):
        check("x", 1.0, 1.0, how="max")


def test_check_true(capsys):
    check_true("monotone", True)
    assert capsys.readouterr().out == "monotone: ok\n"
    with pytest.raises(AssertionError, match="check failed: monotone"):
        check_true("monotone", False)
