"""Renamed public names (issue 23) work for one release, each use warning with the new spelling."""

import casadi as ca
import pytest

from ocpkit import HLGL, Control, MultiRateHLGL, OptimalControlProblem, State
from ocpkit.shooting import SWITCHING_MODES, Shooting, control_law


def double_integrator():
    return OptimalControlProblem(
        "di",
        states=[State("x", initial=1.0, final=0.0), State("v", initial=0.0, final=0.0)],
        controls=[Control("u", lower=-0.5, upper=0.5)],
        dynamics=lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=3.0,
        lagrange=lambda x, u, t: u[0] ** 2 / 2,
    )


def test_fast_interpolation_is_now_the_coupling():
    problem = double_integrator()
    with pytest.warns(DeprecationWarning, match=r"MultiRateHLGL\(fast_interpolation=...\) is deprecated; use coupling"):
        old = MultiRateHLGL(problem, 4, ratio=2, fast=["v"], fast_interpolation="galerkin")
    assert (
        old.coupling == "galerkin"
        and old.label == MultiRateHLGL(problem, 4, ratio=2, fast=["v"], coupling="galerkin").label
    )
    with pytest.warns(DeprecationWarning, match=r"MultiRateHLGL.fast_interpolation is deprecated; use .*coupling"):
        assert old.fast_interpolation == "galerkin"
    with pytest.raises(TypeError, match=r"MultiRateHLGL: give coupling= only"):
        MultiRateHLGL(problem, 4, ratio=2, fast=["v"], coupling="fine", fast_interpolation="fine")
    from ocpkit.transcription import multirate

    with pytest.warns(DeprecationWarning, match="FAST_INTERPOLATIONS is deprecated; use COUPLINGS"):
        assert multirate.FAST_INTERPOLATIONS == multirate.COUPLINGS


def test_detection_is_now_the_switching_treatment():
    problem = double_integrator()
    law = control_law(problem, "box", regularized=True)
    with pytest.warns(DeprecationWarning, match=r"Shooting\(detection=...\) is deprecated; use switching=..."):
        old = Shooting(problem, law, detection="none")
    assert old.switching == "none"
    with pytest.warns(DeprecationWarning, match="Shooting.detection is deprecated; use Shooting.switching"):
        assert old.detection == "none"
    with pytest.warns(DeprecationWarning, match=r"CompiledSystem.integrate\(detection=...\) is deprecated"):
        old.compiled.integrate([1.0, 0.0, 0.0, 1.0, 1.0], 0.0, 1.0, detection="detection", record=False)
    import ocpkit.shooting

    with pytest.warns(DeprecationWarning, match="DETECTION_MODES is deprecated; use SWITCHING_MODES"):
        assert ocpkit.shooting.DETECTION_MODES == SWITCHING_MODES


def test_nlp_parameters_is_now_decision_variables():
    sol = HLGL(double_integrator(), 4).solve(error_threshold=None)
    with pytest.warns(
        DeprecationWarning, match="Solution.nlp_parameters is deprecated; use Solution.decision_variables"
    ):
        assert sol.nlp_parameters == sol.decision_variables == sol.program.n_decision_variables


def test_block_and_mesh_parameters_are_now_constants():
    tr = HLGL(double_integrator(), 4)
    block = tr.nlp.blocks[0]
    with pytest.warns(DeprecationWarning, match="Block.parameters is deprecated; use Block.constants"):
        assert block.parameters is block.constants
    with pytest.warns(DeprecationWarning, match="Mesh.parameters is deprecated; use Mesh.block_constants"):
        assert (tr.mesh.parameters(tr.problem) == tr.mesh.block_constants(tr.problem)).all()


def test_segments_are_now_intervals():
    """One word for a mesh's pieces, as Radau's: HLGL(problem, intervals=...), MultiRateHLGL(..., intervals=...)."""
    problem = double_integrator()
    with pytest.warns(DeprecationWarning, match=r"HLGL\(segments=...\) is deprecated; use intervals=..."):
        old = HLGL(problem, segments=4)
    assert old.intervals == 4 and old.label == "HLGL(intervals=4)"
    with pytest.warns(DeprecationWarning, match="HLGL.segments is deprecated; use HLGL.intervals"):
        assert old.segments == 4
    with pytest.warns(DeprecationWarning, match=r"MultiRateHLGL\(segments=...\) is deprecated"):
        multi = MultiRateHLGL(problem, segments=3, ratio=2, fast=["v"])
    assert multi.intervals == 3 and multi.label.startswith("MultiRateHLGL(intervals=3, ratio=2")


def test_each_deprecation_points_at_the_caller():
    import ocpkit.shooting
    from ocpkit.transcription import multirate

    problem = double_integrator()
    law = control_law(problem, "box", regularized=True)
    uses = [
        lambda: HLGL(problem, segments=4),
        lambda: HLGL(problem, 4).segments,
        lambda: MultiRateHLGL(problem, 4, ratio=2, fast=["v"], fast_interpolation="fine"),
        lambda: MultiRateHLGL(problem, 4, ratio=2, fast=["v"]).fast_interpolation,
        lambda: multirate.FAST_INTERPOLATIONS,
        lambda: Shooting(problem, law, detection="none"),
        lambda: ocpkit.shooting.DETECTION_MODES,
        lambda: HLGL(problem, 4).solve(error_threshold=None).nlp_parameters,
    ]
    for use in uses:
        with pytest.warns(DeprecationWarning) as record:
            use()
        assert record[0].filename == __file__, (record[0].message, record[0].filename)
