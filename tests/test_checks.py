"""The notebooks' self-checks (compendium.checks): they fail loudly and print a stable line."""

import math

import pytest

from compendium.checks import check, check_true


def test_close_passes_and_prints_rounded(capsys):
    check("t_f", 481.20387231, 481.2038723, atol=1e-6, digits=10)
    assert capsys.readouterr().out == "t_f: 481.2038723 (within 1e-06 of 481.2038723): ok\n"


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


def test_one_sided_bounds_include_the_slack(capsys):
    check("error", 1.05e-8, 1e-8, rtol=0.1, how="at most", digits=2)
    check("order", 3.95, 4.0, atol=0.1, how="at least", digits=2)
    out = capsys.readouterr().out.splitlines()
    assert out == ["error: 1e-08 (at most 1e-08 + 0.1 relative): ok", "order: 4 (at least 4 - 0.1): ok"]


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
