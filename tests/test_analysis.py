"""Convergence orders (ocpkit.analysis)."""

import numpy as np
import pytest

from ocpkit.analysis import convergence_order


def test_order_of_a_power_law():
    n = np.array([4, 8, 16, 32])
    assert convergence_order(n, 3.0 * n**-5.0) == pytest.approx(5.0, abs=1e-12)


def test_non_positive_and_non_finite_errors_are_ignored():
    n = [4, 8, 16, 32]
    assert convergence_order(n, [4.0**-4, 0.0, np.nan, 32.0**-4]) == pytest.approx(4.0, abs=1e-12)


def test_fewer_than_two_usable_points_is_an_error():
    with pytest.raises(ValueError, match="at least two positive errors"):
        convergence_order([4, 8], [1e-3, 0.0])
