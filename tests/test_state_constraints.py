"""State constraints in the direct-to-indirect chain (ocpkit.shooting.arcs, ocpkit.structure): boundary arcs and
touch points of order two with the costate's jumps, entry into a boundary arc of order one from a bang arc, and a
state constraint on a regular control, each against its closed form or published values."""

import casadi as ca
import numpy as np
import pytest

from ocpkit import Constraint, Control, FreeFinalTime, OptimalControlProblem, Radau, State
from ocpkit.indirect import to_extremal
from ocpkit.shooting.arcs import ArcFlows, ArcType
from ocpkit.structure import control_structure, inequalities

from compendium.paper import paper_table
from compendium.problems import miser3_state_constraint
from compendium.problems.collection.classics import bryson_denham, bryson_denham_cost


def test_the_order_of_a_state_constraint_and_its_derivative_of_that_order():
    orders = {q.name: (q.order, q.controls) for q in inequalities(bryson_denham("touch_point"))}
    assert orders == {"x_max.upper": (2, (0,))}
    race = _race()
    assert {q.name: q.order for q in inequalities(race)} == {"v.lower": 1, "v.upper": 1}


@pytest.mark.parametrize("regime", ["touch_point", "boundary_arc"])
def test_bryson_denham_against_its_closed_form(regime):
    """l = 0.2: a touch point at t = 1/2 where lambda_x jumps by 9.6, J = 2.24; l = 0.1: a boundary arc of order
    two on [3l, 1 - 3l], lambda_x jumps by 2 / (9 l^2) at entry and exit, J = 4 / (9 l) (Bryson & Ho, Sec. 3.11)."""
    direct = Radau(bryson_denham(regime), 4, 20).solve(mesh_tolerance=1e-6)
    structure = control_structure(direct)
    extremal = to_extremal(direct, integrator_tol=1e-14)
    limit = 0.2 if regime == "touch_point" else 0.1
    assert bryson_denham(regime).path_constraints[0].upper == limit
    junctions = [0.5] if regime == "touch_point" else [3 * limit, 1 - 3 * limit]
    jumps = [9.6] if regime == "touch_point" else [2 / (9 * limit**2)] * 2
    if regime == "touch_point":
        assert [t.constraint for t in structure.touches] == ["x_max.upper"] and structure.kinds("u") == ["regular"]
    else:
        assert not structure.touches and structure.kinds("u") == ["regular", "boundary", "regular"]
    assert extremal.certificate.passed and extremal.norm <= 1e-10
    assert np.asarray(extremal.trajectory.breakpoints[1:-1]) == pytest.approx(junctions, abs=1e-10)
    assert [j[2] for j in extremal.shooting.jumps] == pytest.approx(jumps, rel=1e-9)
    assert extremal.objective == pytest.approx(bryson_denham_cost(regime), abs=1e-12)
    assert extremal.certificate.second_order.verdict == "passed"


def _race(limit: float = 0.6) -> OptimalControlProblem:
    """Minimum time over a unit distance from rest to rest, |u| <= 1, v <= limit: full thrust to the limit, the limit
    held, full braking; tf = 2 limit + (1 - limit^2) / limit."""
    return OptimalControlProblem(
        "race",
        [State("x", initial=0.0, final=1.0), State("v", -1.0, limit, initial=0.0, final=0.0)],
        [Control("u", -1.0, 1.0)],
        lambda x, u, t: [x["v"], u["u"]],
        tf=FreeFinalTime(0.5, 5.0, 1.5),
        mayer=lambda x0, xf, t0, tf: tf,
    )


def test_a_boundary_arc_of_order_one_entered_from_a_bang_arc():
    """The costate is continuous at a junction of order one where the control jumps (Maurer 1977): the conditions
    are c = 0 and the switching function's zero, and the speed limit is held on [0.6, 5/3]."""
    extremal = to_extremal(Radau(_race(), 4, 20).solve(error_threshold=None))
    assert extremal.structure.kinds("u") == ["upper", "boundary", "lower"]
    assert extremal.certificate.passed and not extremal.shooting.jumps
    assert np.asarray(extremal.trajectory.breakpoints) == pytest.approx([0.0, 0.6, 5 / 3, 2.6 - 1 / 3], abs=1e-10)
    assert extremal.objective == pytest.approx(1.2 + 0.64 / 0.6, abs=1e-10)
    assert extremal.certificate.second_order.verdict == "not applicable"  # a free final time


def test_a_state_constraint_on_a_regular_control_miser3():
    """MISER3's ceiling on x2, a constraint of order one whose boundary control u = -x2' ... is regular: no
    published value is converged (MISER3 0.1698180, PROPT 0.169824306); the extremal lies between them and agrees
    with the direct solution to its mesh tolerance, and is a global minimum (convex)."""
    direct = Radau(miser3_state_constraint(), 4, 30).solve(mesh_tolerance=1e-6)
    extremal = to_extremal(direct)
    assert extremal.structure.kinds("u") == ["regular", "boundary", "regular"]
    assert extremal.certificate.passed and extremal.norm <= 1e-10
    published = paper_table("beyond_the_seeds").set_index(["problem", "quantity"]).value
    low, high = (
        published["miser3_state_constraint", "objective"],
        published["miser3_state_constraint", "objective_propt"],
    )
    assert low < extremal.objective < high
    assert extremal.objective == pytest.approx(direct.objective, rel=1e-6)
    assert extremal.certificate.second_order.route == "convexity"


def _second_order_state_constraint(affine: bool, order: int) -> OptimalControlProblem:
    """x^(order) = u with x <= 0.1: order ``order``; the cost u^2 (regular) or |u| with |u| <= 1 (affine)."""

    def dynamics(x, u, t):
        return [x[k + 1] for k in range(order - 1)] + [u[0]]

    return OptimalControlProblem(
        "chain",
        [State(f"x{k}", initial=0.0) for k in range(order)],
        [Control("u", -1.0, 1.0)],
        dynamics,
        tf=1.0,
        lagrange=(lambda x, u, t: ca.fabs(u[0])) if affine else (lambda x, u, t: u[0] ** 2),
        path_constraints=[Constraint("x_max", lambda x, u, t: x[0], upper=0.1)],
    )


def test_what_is_not_derived_is_named():
    flows = ArcFlows(_second_order_state_constraint(affine=True, order=2))
    with pytest.raises(
        ValueError, match=r"H is affine in 'u' and 'x_max.upper' is a state constraint of order 2.*Robbins"
    ):
        flows.flow(ArcType(("boundary",), "x_max.upper"))
    flows = ArcFlows(_second_order_state_constraint(affine=False, order=3))
    with pytest.raises(
        ValueError, match=r"'x_max.upper' is a state constraint of order 3: boundary arcs of orders one"
    ):
        flows.flow(ArcType(("boundary",), "x_max.upper"))


def test_two_touch_points_of_one_constraint_stay_two_junctions():
    from ocpkit.shooting.arcs import arc_sequence
    from ocpkit.structure import Structure, Touch

    problem = bryson_denham("touch_point")
    arcs = arc_sequence(Structure((), (Touch("x_max.upper", 0.3), Touch("x_max.upper", 0.7))), problem, 0.0, 1.0)
    assert [(kind.touch, a, b) for kind, a, b in arcs] == [
        (None, 0.0, 0.3),
        ("x_max.upper", 0.3, 0.7),
        ("x_max.upper", 0.7, 1.0),
    ]
