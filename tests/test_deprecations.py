"""Renamed public names (issue 23) work for one release, each use warning with the new spelling."""

import casadi as ca
import numpy as np
import pytest

from ocpkit import HLGL, Control, MultiRateHLGL, OptimalControlProblem, Outcome, State
from ocpkit.shooting import SWITCHING_MODES, DampedNewton, MinpackHybrid, MultipleShooting, Shooting, control_law


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


def minimum_energy_shooting():
    problem = double_integrator()
    return Shooting(problem, control_law(problem, "box", regularized=True), rtol=1e-10, atol=1e-10)


START = np.array([0.5, 1.5])  # initial costates from which the minimum-energy shooting converges


def test_stol_is_now_tol():
    """One name for the residual tolerance of every indirect solve (to_extremal, ArcShooting and certify had it)."""
    shooting = minimum_energy_shooting()
    with pytest.warns(DeprecationWarning, match=r"Shooting.solve\(stol=...\) is deprecated; use tol=..."):
        old = shooting.solve(START, stol=1e-9)
    assert old.tol == 1e-9 and old.converged
    with pytest.raises(TypeError, match=r"Shooting.solve: give tol= only"):
        shooting.solve(START, tol=1e-9, stol=1e-9)
    multiple = MultipleShooting(shooting, segments=2)
    with pytest.warns(DeprecationWarning, match=r"MultipleShooting.solve\(stol=...\) is deprecated; use tol=..."):
        assert multiple.solve(old.z, stol=1e-9).tol == 1e-9


def test_a_root_solvers_stol_is_now_tol():
    """The root-solver protocol passes tol=; a solver of the user's that takes stol= is still called, with a
    warning, and the built-in solvers take stol= with a warning."""
    shooting = minimum_energy_shooting()
    seen = []

    def old_solver(fun, jac, z0, *, stol, maxfev):
        seen.append(stol)
        return DampedNewton()(fun, jac, z0, tol=stol, maxfev=maxfev)

    with pytest.warns(DeprecationWarning, match="a root solver's keyword stol is deprecated; use tol"):
        assert shooting.solve(START, solver=old_solver, tol=1e-9).converged
    assert seen == [1e-9]
    fun, jac = (lambda z: z - 1.0), (lambda z: np.eye(z.size))
    for solver in (DampedNewton(), MinpackHybrid()):
        with pytest.warns(DeprecationWarning, match=rf"{type(solver).__name__}.__call__\(stol=...\) is deprecated"):
            z, _, outcome = solver(fun, jac, np.zeros(2), stol=1e-9, maxfev=20)
        assert z == pytest.approx([1.0, 1.0]) and outcome is Outcome.CONVERGED


def test_message_and_counts_are_now_detail_evaluations_and_iterations():
    """The shooting results share the field names of one contract (ocpkit.shooting.result.IndirectResult)."""
    from ocpkit.shooting.arcs import ArcResult

    shooting = minimum_energy_shooting()
    single = shooting.solve(START)
    multiple = MultipleShooting(shooting, segments=2).solve(single.z)
    arcs = ArcResult(
        z=single.z,
        residual=single.residual,
        norm=single.norm,
        tol=1e-10,
        converged=True,
        status=Outcome.CONVERGED,
        detail="converged",
        iterations=3,
        evaluations=5,
        cpu_s=0.0,
        objective=single.objective,
        times=np.array([0.0, 3.0]),
        multipliers=np.zeros(0),
        arcs=[],
    )
    for result in (single, multiple, arcs):
        name = type(result).__name__
        with pytest.warns(DeprecationWarning, match=rf"{name}.message is deprecated; use {name}.detail"):
            assert result.message == result.detail
        with pytest.warns(DeprecationWarning, match=rf"{name}.n_shooting is deprecated; use {name}.evaluations"):
            assert result.n_shooting == result.evaluations > 0
        with pytest.warns(DeprecationWarning, match=rf"{name}.n_jacobian is deprecated; use {name}.iterations"):
            assert result.n_jacobian == result.iterations > 0


def test_a_continuation_paths_message_is_now_detail():
    from ocpkit.indirect import ExtremalPath
    from ocpkit.shooting.continuation import ContinuationPath

    for path in (ContinuationPath("p", detail="reached the end"), ExtremalPath("p", detail="reached the end")):
        name = type(path).__name__
        with pytest.warns(DeprecationWarning, match=rf"{name}.message is deprecated; use {name}.detail"):
            assert path.message == "reached the end"


def test_to_extremals_strict_is_now_raise_on_failure():
    from ocpkit.indirect import to_extremal

    with pytest.warns(DeprecationWarning, match=r"to_extremal\(strict=...\) is deprecated; use raise_on_failure=..."):
        with pytest.raises(ValueError, match="needs the direct solution's costate estimates"):
            to_extremal(object(), strict=False)
    with pytest.raises(TypeError, match="to_extremal: give raise_on_failure= only"):
        to_extremal(object(), strict=False, raise_on_failure=False)


def test_the_names_before_the_program_owned_the_nlp():
    """MultiPhase(transcriptions) is a program of linked phases, MultiPhaseSolution the one Solution, Solution.raw its
    typed fields, SolveLoop.meshed its program."""
    import ocpkit
    from ocpkit import Link, MultiPhase, Program, Solution

    def half(t0, tf, **ends):
        return double_integrator().replace(name=f"di{t0}", t0=t0, tf=tf, states=[State("x", **ends), State("v")])

    legs = [HLGL(half(0.0, 1.5, initial=1.0), 4), HLGL(half(1.5, 3.0, final=0.0), 4)]
    with pytest.warns(DeprecationWarning, match=r"MultiPhase\(transcriptions, links, ...\) is deprecated; use Program"):
        old = MultiPhase(legs, [Link(0, 1)])
    assert isinstance(old, Program) and old.names == ["di0.0", "di1.5"]
    with pytest.warns(DeprecationWarning, match="MultiPhase.split is deprecated; use Program.split"):
        assert isinstance(MultiPhase.split(double_integrator(), [1.5], lambda p: HLGL(p, 4)), Program)
    with pytest.warns(DeprecationWarning, match="MultiPhaseSolution is deprecated; use ocpkit.Solution"):
        assert ocpkit.MultiPhaseSolution is Solution
    sol = old.solve(error_threshold=None)
    with pytest.warns(DeprecationWarning, match="Solution.raw is deprecated; use Solution.nlp_result"):
        raw = sol.raw
    assert raw["transcription"] is sol.program and np.array_equal(raw["w"], sol.nlp_result.w)
    loop = old.loop()
    with pytest.warns(DeprecationWarning, match="SolveLoop.meshed is deprecated; use SolveLoop.program"):
        assert loop.meshed is old


def test_each_deprecation_points_at_the_caller():
    import ocpkit
    import ocpkit.shooting
    from ocpkit import MultiPhase
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
    from ocpkit.indirect import to_extremal
    from ocpkit.shooting.continuation import ContinuationPath

    energy = minimum_energy_shooting()
    solved = energy.solve(START)

    def old_solver(fun, jac, z0, *, stol, maxfev):
        return DampedNewton()(fun, jac, z0, tol=stol, maxfev=maxfev)

    def refused(use):
        def run():
            with pytest.raises(ValueError):
                use()

        return run

    uses += [
        lambda: energy.solve(START, stol=1e-9),
        lambda: MultipleShooting(energy, segments=2).solve(solved.z, stol=1e-9),
        lambda: energy.solve(START, solver=old_solver),
        lambda: DampedNewton()(lambda z: z, lambda z: np.eye(z.size), np.ones(1), stol=1e-9, maxfev=5),
        lambda: solved.message,
        lambda: solved.n_shooting,
        lambda: solved.n_jacobian,
        refused(lambda: to_extremal(object(), strict=False)),
        lambda: ContinuationPath("p").message,
        lambda: HLGL(problem, 4).solve(error_threshold=None).raw,
        lambda: HLGL(problem, 4).loop().meshed,
        lambda: ocpkit.MultiPhaseSolution,
        lambda: MultiPhase([HLGL(problem, 4)]),
    ]
    for use in uses:
        with pytest.warns(DeprecationWarning) as record:
            use()
        assert record[0].filename == __file__, (record[0].message, record[0].filename)
