"""Mistakes a user makes in a problem statement, each an error that names the input and the fix (issue 41, item 2):
a callable written for the other signature, a free parameter or a control that no function reads, ``x.v`` for
``x["v"]``, a callable of the wrong arity given to ``value`` or ``sample``."""

import re

import numpy as np
import pytest

from ocpkit import (
    HLGL,
    Constraint,
    Control,
    FreeParameter,
    MultiPhaseProblem,
    OptimalControlProblem,
    Program,
    State,
)


def double_integrator(controls=None, dynamics=None, lagrange=None, **extra):
    """min int u^2 of x'' = u from (0, 0) to (1, 0) in t = 1 (J = 12, u = 6 - 12 t)."""
    return OptimalControlProblem(
        "di",
        [State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        [Control("u")] if controls is None else controls,
        dynamics or (lambda x, u, t: [x["v"], u["u"]]),
        tf=1.0,
        lagrange=lagrange or (lambda x, u, t: u["u"] ** 2),
        **extra,
    )


# -- a callable written for the other signature -------------------------------------------------------------------
def test_a_boundary_signature_in_path_constraints_is_named():
    """The issue's example: read as (x, u, t, p), ``xf[0]`` was the control, and the solve found another optimum
    (0.24054 for 0.23066) with no word."""
    for fn in (lambda x0, xf, t0, tf: xf[0], lambda x0, xf, t0, tf, p: xf["x"]):
        cap = Constraint("cap", fn, upper=0.45)
        with pytest.raises(
            TypeError,
            match=r"path constraint 'cap' takes \(x0, xf, t0, tf(, p)?\), a function of the ends, but is called as a "
            r"function of time, \(x, u, t\) .*: write it as \(x, u, t\) for a constraint along the path, or move it "
            r"to boundary_constraints=",
        ):
            double_integrator(path_constraints=[cap])
    # the same constraint among the boundary ones is what was meant
    assert double_integrator(boundary_constraints=[Constraint("cap", lambda x0, xf, t0, tf: xf[0], upper=0.45)])


def test_a_path_signature_in_boundary_constraints_is_named():
    """(x, u, t, p) among the boundary constraints was read as (x0, xf, t0, tf) silently; (x, u, t) was Python's
    'takes 3 positional arguments but 4 were given'."""
    for fn in (lambda x, u, t, p: x["v"], lambda x, u, t: x["v"]):
        with pytest.raises(
            TypeError,
            match=r"boundary constraint 'slow' takes \(x, u, t(, p)?\), a function of time, but is called as a "
            r"function of the ends, \(x0, xf, t0, tf\) .*: write it as \(x0, xf, t0, tf\) for a constraint on the "
            r"ends, or move it to path_constraints=",
        ):
            double_integrator(boundary_constraints=[Constraint("slow", fn, upper=0.5)])


def test_costs_written_for_the_other_signature_are_named():
    with pytest.raises(TypeError, match=r"mayer takes \(x, u, t\), a function of time.*a running cost is lagrange="):
        double_integrator(mayer=lambda x, u, t: x["x"])
    with pytest.raises(TypeError, match=r"lagrange takes \(x0, xf, t0, tf\), a function of the ends.*is mayer="):
        double_integrator(lagrange=lambda x0, xf, t0, tf: xf["x"])
    with pytest.raises(TypeError, match=r"dynamics takes \(x0, xf, t0, tf\).*write the dynamics as f\(x, u, t\)"):
        double_integrator(dynamics=lambda x0, xf, t0, tf: [xf["v"], xf["x"]])


def test_a_callable_with_too_few_arguments_is_named():
    with pytest.raises(
        TypeError,
        match=r"dynamics takes 2 arguments \(x, u\); it is called with 3 \(x, u, t\), or 4 with the parameters p last",
    ):
        double_integrator(dynamics=lambda x, u: [x["v"], u["u"]])
    with pytest.raises(
        TypeError, match=r"mayer takes 1 argument \(xf\); it is called with 4 \(x0, xf, t0, tf\), or 5 with"
    ):
        double_integrator(mayer=lambda xf: xf["x"])


# -- a free parameter or a control that no function reads ------------------------------------------------------------
def test_a_free_parameter_no_function_reads_is_named_when_the_program_is_built():
    """It used to be "estimated" at the middle of its bounds (IPOPT's barrier alone moves it), silently."""
    problem = double_integrator(free_parameters=[FreeParameter("k", 1.0, 20.0, guess=3.0)])
    with pytest.raises(
        ValueError,
        match=r"free parameter 'k' of 'di' is read by no function .*: use it \(p\['k'\]\) in one of them, or give it "
        r"a value \(parameters=\{'k': \.\.\.\}\), or remove it from free_parameters=",
    ):
        HLGL(problem, 10).solve()
    # read by the Mayer term alone, it is read
    read = double_integrator(
        free_parameters=[FreeParameter("k", 1.0, 20.0, guess=3.0)], mayer=lambda x0, xf, t0, tf, p: (p["k"] - 2) ** 2
    )
    assert HLGL(read, 10).solve().parameters["k"] == pytest.approx(2.0, abs=1e-6)


def test_a_free_parameter_that_the_trajectory_or_another_phase_reads_is_read():
    """In a trajectory of phases a phase declares a parameter that only the trajectory's cost, or only another phase,
    reads: no error. One that nothing reads is named with the phases that declare it."""

    def leg(t0, tf, uses_k, ends):
        dynamics = (lambda x, u, t, p: [x["v"], p["k"] * u["u"]]) if uses_k else (lambda x, u, t: [x["v"], u["u"]])
        return OptimalControlProblem(
            f"leg{t0}",
            [State("x", **ends[0]), State("v", **ends[1])],
            [Control("u")],
            dynamics,
            t0=t0,
            tf=tf,
            lagrange=lambda x, u, t: u["u"] ** 2 / 2,
            free_parameters=[FreeParameter("k", 0.5, 4.0, guess=1.0)],
        )

    first = leg(0.0, 0.5, True, ({"initial": 0.0}, {"initial": 0.0}))
    second = leg(0.5, 1.0, False, ({"final": 1.0}, {"final": 0.0}))
    sol = Program.from_phases([HLGL(first, 6), HLGL(second, 6)]).solve()  # shared: the first phase reads it
    assert sol.parameters["k"] == pytest.approx(4.0, abs=1e-6)  # the larger the gain, the less control it costs
    idle = leg(0.0, 0.5, False, ({"initial": 0.0}, {"initial": 0.0}))
    cost = MultiPhaseProblem([idle, second], cost=lambda e, p: (p["k"] - 2.0) ** 2)
    assert cost.shared_parameters == ["k"]
    linked = MultiPhaseProblem(
        [idle, second],
        constraints=[Constraint("ks", lambda e: [e[0].p["k"] - 2.0, e[1].p["k"] - 1.0], lower=0.0, upper=0.0)],
        local_parameters=["k"],
    )
    assert linked.shared_parameters == []
    with pytest.raises(ValueError, match=r"free parameter 'k' of 'leg0.0', 'leg0.5' is read by no function"):
        MultiPhaseProblem([idle, second])
    with pytest.raises(ValueError, match=r"free parameter 'k' of 'leg0.0' is read by no function .*linkage"):
        MultiPhaseProblem([idle, leg(0.5, 1.0, True, ({}, {}))], local_parameters=["k"])


def test_a_control_no_function_reads_is_named_with_the_problem():
    with pytest.raises(
        ValueError,
        match=r"control 'w' of 'di' is read by no function \(neither the dynamics, the running cost nor a path "
        r"constraint\).*: use it \(u\['w'\]\) in one of them, or remove it from controls=",
    ):
        double_integrator(controls=[Control("u"), Control("w", -1.0, 1.0)])
    # read by a path constraint or the running cost alone, it is read
    both = [Control("u"), Control("w", -1.0, 1.0)]
    assert double_integrator(controls=both, path_constraints=[Constraint("w", lambda x, u, t: u["w"], upper=0.5)])
    assert double_integrator(controls=both, lagrange=lambda x, u, t: u["u"] ** 2 + u["w"] ** 2).nu == 2


# -- x.v for x["v"] ---------------------------------------------------------------------------------------------------
def test_a_name_read_as_an_attribute_is_named_with_the_fix():
    """It was "'Named' object has no attribute 'v'"."""
    with pytest.raises(
        AttributeError, match=r"dynamics: x\.v reads the state 'v' as an attribute: write x\['v'\]"
    ) as caught:
        double_integrator(dynamics=lambda x, u, t: [x.v, u["u"]])
    assert "attribute access is not offered" in str(caught.value)
    with pytest.raises(AttributeError, match=r"mayer: xf\.x reads the state 'x' as an attribute: write xf\['x'\]"):
        double_integrator(mayer=lambda x0, xf, t0, tf: xf.x)
    with pytest.raises(AttributeError, match=r"path constraint 'c': u\.u reads the control 'u'.*write u\['u'\]"):
        double_integrator(path_constraints=[Constraint("c", lambda x, u, t: u.u, upper=1.0)])
    with pytest.raises(AttributeError, match=r"lagrange: u has no attribute 'thrust': the controls are \['u'\]"):
        double_integrator(lagrange=lambda x, u, t: u.thrust**2)
    with pytest.raises(AttributeError, match=r"dynamics: p\.k reads the parameter 'k' as an attribute: write p\['k'\]"):
        double_integrator(dynamics=lambda x, u, t, p: [x["v"], p.k * u["u"]], parameters={"k": 2.0})
    phase = double_integrator()
    with pytest.raises(
        AttributeError, match=r"linkage constraint 'c': xf\.v reads the state 'v' as an attribute: write xf\['v'\]"
    ):
        MultiPhaseProblem([phase], constraints=[Constraint("c", lambda e: e[0].xf.v, upper=1.0)])
    # CasADi's own attributes stay CasADi's, and a dict's the parameters'
    double_integrator(dynamics=lambda x, u, t: [x.T[1], u.T[0]])
    double_integrator(dynamics=lambda x, u, t, p: [x["v"], u["u"] * p.get("k", 1.0)])


# -- value and sample -------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def solution():
    return HLGL(double_integrator(), 6).solve()


@pytest.mark.parametrize(
    "method, fn, message",
    [
        (
            "value",
            lambda xf: xf["x"],
            r"value's expression takes 1 argument \(xf\); it is called with 4 \(x0, xf, t0, ",
        ),
        ("value", lambda x, u, t: x["x"], r"value's expression takes \(x, u, t\), a function of time"),
        ("sample", lambda x: x["x"], r"sample's expression takes 1 argument \(x\); it is called with 3 \(x, u, t\)"),
        ("sample", lambda x0, xf, t0, tf: xf["x"], r"sample's expression takes \(x0, xf, t0, tf\), a function of "),
        ("sample", lambda a, b, c, d, e: a, r"sample's expression needs 5 arguments; it is given 3 \(x, u, t\)"),
    ],
)
def test_value_and_sample_name_the_signatures_they_accept(solution, method, fn, message):
    accepted = {
        "value": r"value takes a function of the ends, \(x0, xf, t0, tf\) or \(x0, xf, t0, tf, p\); a function of "
        r"time is sample\(lambda x, u, t: \.\.\.\)",
        "sample": r"sample takes a function of time, \(x, u, t\) or \(x, u, t, p\); a number of the ends is "
        r"value\(lambda x0, xf, t0, tf: \.\.\.\)",
    }[method]
    with pytest.raises(TypeError, match=message) as caught:
        getattr(solution, method)(fn)
    assert re.search(accepted, str(caught.value)), str(caught.value)


def test_value_and_sample_of_the_right_signature(solution):
    t, v = solution.sample(lambda x, u, t: x["v"], grid=np.linspace(0, 1, 5))
    assert np.allclose(v, 6 * t - 6 * t**2, atol=1e-9)
    assert solution.value(lambda x0, xf, t0, tf: xf["x"] - x0["x"]) == pytest.approx(1.0, abs=1e-12)


def test_an_argument_with_a_default_value_is_not_read_as_a_signature():
    """``lambda x, u, t, tf=tf: ...`` binds a loop's value (a common idiom): its ``tf`` is not the end's."""
    import casadi as ca

    from ocpkit import HLGL, Control, OptimalControlProblem, State

    tf = 2.0
    problem = OptimalControlProblem(
        "bound",
        states=[State("x", initial=0.0, final=1.0), State("v", initial=0.0, final=0.0)],
        controls=[Control("u", -10.0, 10.0)],
        dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=1.0,
        lagrange=lambda x, u, t, tf=tf: u[0] ** 2 / tf,
        mayer=lambda x0, xf, t0, tf, u=3.0: 0.0 * xf[0],
    )
    assert HLGL(problem, 4).solve(error_threshold=None).objective == pytest.approx(6.0, rel=1e-6)
