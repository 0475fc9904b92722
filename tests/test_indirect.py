"""From a direct solution to a certified extremal in one call (ocpkit.indirect), against closed forms."""

import numpy as np
import pytest
from test_shooting import gain_optimum, gain_problem
from test_structure import race, saturated  # closed forms: switch at 1, t_f = 2; J = 3/8 - sqrt(3)/12

from ocpkit import HLGL, Radau, SolverError
from ocpkit.indirect import Certificate, Check, to_extremal
from ocpkit.structure import control_structure


def test_a_bang_bang_extremal_from_radau_in_one_call():
    direct = Radau(race(), 4, 15).solve(error_threshold=None)  # the switch inside an interval: t_f off by 3e-4
    extremal = to_extremal(direct)
    assert extremal.certificate.passed and extremal.structure.kinds("u") == ["upper", "lower"]
    assert extremal.trajectory.tf == pytest.approx(2.0, abs=1e-12) and extremal.shooting.norm <= 1e-10
    assert control_structure(extremal.trajectory).junctions("u") == pytest.approx([1.0], abs=1e-10)
    assert abs(direct.tf - 2.0) > 1e-5  # the extremal is the closed form; the direct solution was not


def test_a_saturated_regular_extremal():
    """Minimum energy with |u| <= 0.5 from (1, 0) to rest in 3: J = 3/8 - sqrt(3)/12 (closed form)."""
    extremal = to_extremal(Radau(saturated(), 4, 16).solve(error_threshold=None))
    assert extremal.structure.kinds("u") == ["lower", "regular", "upper"]
    assert extremal.trajectory.objective == pytest.approx(3 / 8 - np.sqrt(3) / 12, abs=1e-12)
    assert extremal.certificate["hamiltonian_minimum"].value <= 1e-8


def test_an_extremal_with_a_free_parameter():
    """x'' = k u, min int u^2/2 + (k - 2)^2: the direct solution's k starts the shooting, which treats k as a state;
    k solves 12 / k^3 = 2 (k - 2)."""
    extremal = to_extremal(Radau(gain_problem(), 4, 4).solve(error_threshold=None))
    k = gain_optimum()
    assert extremal.shooting.free_parameters["k"] == pytest.approx(k, rel=1e-12) and extremal.certificate.passed


def test_a_solution_without_costates_is_named():
    with pytest.raises(ValueError, match="needs the direct solution's costate estimates: solve with Radau"):
        to_extremal(HLGL(race(), 10).solve(error_threshold=None))


def test_a_failed_certificate_raises_with_the_extremal(monkeypatch):
    import ocpkit.indirect as indirect

    failing = Certificate((Check("structure", 1.0, 0.0, "the direct solution's arcs"),))
    assert not failing.passed and failing.failed == ["structure"] and "FAIL structure" in failing.describe()
    monkeypatch.setattr(indirect, "certify", lambda *args, **kwargs: failing)
    direct = Radau(race(), 4, 15).solve(error_threshold=None)
    with pytest.raises(SolverError, match=r"failed checks \['structure'\]") as info:
        to_extremal(direct)
    assert info.value.result.certificate is failing
    assert to_extremal(direct, strict=False).certificate is failing
