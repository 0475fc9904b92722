"""Collocation constants, quadrature and interpolation (ocpkit.nodes)."""

import numpy as np
import pytest

from ocpkit import nodes


def hermite_eval(data, s):
    a = nodes.hermite_quintic_matrix() @ data
    return np.polyval(a[::-1], s), np.polyval(np.polyder(a[::-1]), s)


def test_interpolation_formulas_are_the_quintic_hermite_polynomial():
    rng = np.random.default_rng(0)
    for _ in range(5):
        xi, xc, xe, fi, fc, fe = rng.normal(size=6)
        data = np.array([xi, fi, xc, fc, xe, fe])
        xa, _ = hermite_eval(data, nodes.HLGL_COLLOCATION[0])
        xb, _ = hermite_eval(data, nodes.HLGL_COLLOCATION[1])
        assert nodes.HLGL_XA_X @ [xi, xc, xe] + nodes.HLGL_XA_F @ [fi, fc, fe] == pytest.approx(xa, abs=1e-13)
        assert nodes.HLGL_XB_X @ [xi, xc, xe] + nodes.HLGL_XB_F @ [fi, fc, fe] == pytest.approx(xb, abs=1e-13)


def test_defect_formulas_are_slope_mismatch_at_collocation_points():
    """C1 = (49/180) h (f_a - p'(t_a)), with h = 1 here."""
    rng = np.random.default_rng(1)
    xi, xc, xe, fi, fc, fe, fa, fb = rng.normal(size=8)
    data = np.array([xi, fi, xc, fc, xe, fe])
    _, dpa = hermite_eval(data, nodes.HLGL_COLLOCATION[0])
    _, dpb = hermite_eval(data, nodes.HLGL_COLLOCATION[1])
    c1 = nodes.HLGL_C1_X @ [xi, xc, xe] + nodes.HLGL_C1_F @ [fi, fa, fc, fe]
    c2 = nodes.HLGL_C2_X @ [xi, xc, xe] + nodes.HLGL_C2_F @ [fi, fb, fc, fe]
    assert c1 == pytest.approx(49 / 180 * (fa - dpa), abs=1e-13)
    assert c2 == pytest.approx(49 / 180 * (fb - dpb), abs=1e-13)


def test_lobatto_quadrature_exact_to_degree_7_only():
    s, w = nodes.HLGL_CONTROL_NODES, nodes.HLGL_QUADRATURE
    for k in range(8):
        assert w @ s**k == pytest.approx(1 / (k + 1), abs=1e-15)
    assert abs(w @ s**8 - 1 / 9) > 1e-6


def test_lagrange_and_differentiation_matrices_exact_for_polynomials():
    x = np.array([0.0, 0.1, 0.35, 0.7, 1.0])
    pts = np.linspace(0, 1, 17)
    P = nodes.lagrange_matrix(x, pts)
    D = nodes.differentiation_matrix(x)
    assert np.allclose(D.sum(axis=1), 0, atol=1e-12)
    for k in range(5):
        assert np.allclose(P @ x**k, pts**k, atol=1e-13)
        assert np.allclose(D @ x**k, k * x ** max(k - 1, 0) if k else 0 * x, atol=1e-11)
    assert not np.allclose(P @ x**5, pts**5, atol=1e-6)
    assert np.allclose(nodes.lagrange_matrix(x, x), np.eye(5))


def test_the_step_quintic_hermite_is_exact_on_quintics_and_sixth_order():
    rng = np.random.default_rng(3)
    c = rng.normal(size=6)
    p = np.polynomial.Polynomial(c)
    dp, ddp = p.deriv(), p.deriv(2)
    t0, h = 0.3, 0.7
    s = np.linspace(0.0, 1.0, 11)
    y = nodes.quintic_hermite(p(t0), dp(t0), ddp(t0), p(t0 + h), dp(t0 + h), ddp(t0 + h), h, s)
    assert y == pytest.approx(p(t0 + s * h), abs=1e-13)
    errors = []
    for h in (0.1, 0.05):  # exp: the error falls by 2^6 when the step halves
        y = nodes.quintic_hermite(1.0, 1.0, 1.0, np.exp(h), np.exp(h), np.exp(h), h, 0.5)
        errors.append(abs(y - np.exp(h / 2)))
    assert errors[0] / errors[1] == pytest.approx(64, rel=0.05)
