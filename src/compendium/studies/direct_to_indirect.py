"""From a direct solution to a certified extremal in one call (notebook 10).

Each case is a published problem, a direct solve (Radau) and the reference it is compared with: closed-form
junction times, a published junction table (``data/paper/goddard_control_toolbox.csv``), a published optimum
(``data/paper/beyond_the_seeds.csv``, ``goddard_cops.csv``) or the slides' transfer (``switching_detection.csv``:
its direct form states the thrust as a magnitude and two angles, and the extremal is shot on the problem as posed,
``|u| <= 1``); the unconstrained Rayleigh problem, for which no published optimum was found, is compared with the
direct method refined. :func:`run_case` solves it directly, calls :func:`ocpkit.indirect.to_extremal` and reports
the structure found, how the shooting was solved (its ``route``), the extremal's numbers against the reference,
|S|, the drift of H, the certificate and the gap to the direct solution, or, where the chain stops, its named error.
No user-written Hamiltonian, control law or shooting function appears anywhere.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ocpkit import HLGL, Program, Radau, Scheme, SolverError
from ocpkit.indirect import to_extremal
from ocpkit.structure import control_structure

from ..paper import paper_table
from ..problems import (
    catalyst_mixing,
    double_integrator_solution,
    double_integrator_thrusters,
    free_flying_robot,
    free_flying_robot_net,
    goddard_constants,
    goddard_rocket,
    miser3_state_constraint,
    orbit_raising,
    orbit_transfer,
    orbit_transfer_constants,
    rayleigh,
    rayleigh_mixed,
    tumour,
)
from ..problems.collection.classics import bryson_denham, bryson_denham_extremal, turnpike, turnpike_extremal
from ..problems.entry_landing import entry_landing
from ..problems.orbit_transfer import orbit_transfer_direct
from .orbit_transfer import propellant_kg


def _published(table: str, problem: str | None, quantity: str) -> float:
    df = paper_table(table)
    if problem is not None:
        df = df[df.problem == problem]
    return float(df.set_index("quantity").loc[quantity, "value"])


def _junctions(extremal) -> np.ndarray:
    return np.asarray(extremal.trajectory.breakpoints[1:-1], dtype=float)


@dataclass(frozen=True)
class Case:
    """A problem, its direct solve and its reference: ``reference()`` gives ``{quantity: published value}`` and
    ``measure(extremal)`` the extremal's values of the same quantities."""

    name: str
    what: str
    problem: Callable
    #: the direct scheme (``Radau(nodes=4, intervals=20)``, ``HLGL(intervals=40)``), configuration for the problem
    scheme: Scheme
    solve_options: dict
    reference: Callable[[], dict] = field(default=lambda: {})
    measure: Callable[[object], dict] = field(default=lambda e: {})
    #: the problem as posed, to shoot, where the direct one restates its controls (``to_extremal(problem=...)``)
    shoot: Callable | None = None
    control_set: str = "box"
    #: further keywords of ``to_extremal`` (``integrator_tol``, ``method``, ``min_share``)
    options: dict = field(default_factory=dict)

    def transcription(self) -> Program:
        """The case's direct transcription of its problem: the program of its scheme."""
        return Program(self.problem(), self.scheme)


def _di_reference() -> dict:
    exact = double_integrator_solution()
    return {"t1": exact.t1, "t2": exact.t2}


def _goddard_ct_reference() -> dict:
    table = paper_table("goddard_control_toolbox").set_index("quantity")
    return {q: float(table.loc[q, "value"]) for q in ("t1", "t2", "t3", "tf")}


def _transfer_thrust() -> float:
    return float(orbit_transfer_constants()["thrusts_N"][0])


def _slides_reference() -> dict:
    """The slides' 5 N transfer: the fuel and the number of switchings (slide 12, switching detection)."""
    table = paper_table("switching_detection")
    row = table[
        np.isclose(table.thrust_N, _transfer_thrust()) & (table.detection == "detection") & (table.jacobian == "fd")
    ]
    return {"fuel_kg": float(row.objective_kg.iloc[0]), "switchings": float(row.switchings.iloc[0])}


def _transfer_measure(e) -> dict:
    tr = e.trajectory
    return {"fuel_kg": propellant_kg(tr.state(tr.tf)[6]), "switchings": float(e.shooting.integration.switchings)}


def _rayleigh_reference() -> dict:
    """No published optimum of the unconstrained Rayleigh problem was found: its reference is the direct method's
    own, Radau refined to a mesh tolerance of 1e-9 (a smooth optimum: the estimate is the error)."""
    return {"objective": Radau(rayleigh(), 4, 20).solve(mesh_tolerance=1e-9).objective}


def _arcs_measure(e) -> dict:
    """The arc method's junction times ``t1, t2, ...``, costate jumps ``jump1, ...`` (in time order) and cost."""
    out = {f"t{k + 1}": t for k, t in enumerate(_junctions(e))}
    out |= {f"jump{k + 1}": nu for k, (_, _, nu) in enumerate(e.shooting.jumps)}
    return out | {"objective": e.objective}


def _goddard_ct_measure(e) -> dict:
    t = _junctions(e)
    return {"t1": t[0], "t2": t[1], "t3": t[2], "tf": e.trajectory.tf} if t.size == 3 else {}


CASES = {
    c.name: c
    for c in [
        Case(
            "double_integrator",
            "minimum fuel, two thrusters: bang-off-bang",
            double_integrator_thrusters,
            Radau(nodes=4, intervals=20),
            {"error_threshold": None},
            _di_reference,
            lambda e: dict(zip(("t1", "t2"), _junctions(e))),
        ),
        Case(
            "goddard_speed_limit",
            "Goddard with v <= 0.1 (control-toolbox): bang, singular, boundary, off",
            lambda: goddard_rocket(v_max=goddard_constants()["v_max"]),
            Radau(nodes=4, intervals=20),
            {"mesh_tolerance": 1e-6},
            _goddard_ct_reference,
            _goddard_ct_measure,
        ),
        Case(
            "goddard_cops",
            "Goddard (COPS 3.0): bang, singular, off",
            goddard_rocket,
            Radau(nodes=4, intervals=20),
            {"mesh_tolerance": 1e-6},
            lambda: {"final_altitude": _published("goddard_cops", None, "final_altitude")},
            lambda e: {"final_altitude": float(e.trajectory.state(e.trajectory.tf)[0])},
        ),
        Case(
            "goddard_cops_hlgl",
            "Goddard (COPS 3.0) from HLGL: costates from its defect multipliers",
            goddard_rocket,
            HLGL(intervals=40),
            {"error_threshold": None},
            lambda: {"final_altitude": _published("goddard_cops", None, "final_altitude")},
            lambda e: {"final_altitude": float(e.trajectory.state(e.trajectory.tf)[0])},
        ),
        Case(
            "catalyst_mixing",
            "catalyst mixing (COPS 3.0): bang, singular, bang",
            catalyst_mixing,
            Radau(nodes=4, intervals=30),
            {"error_threshold": None},
            lambda: {"objective": _published("beyond_the_seeds", "catalyst_mixing", "objective")},
            lambda e: {"objective": e.trajectory.objective},
        ),
        Case(
            "orbit_raising",
            "orbit raising (Bryson & Ho): regular, time-dependent mass, boundary equality",
            orbit_raising,
            Radau(nodes=4, intervals=20),
            {"mesh_tolerance": 1e-6},
            lambda: {"final_radius": _published("beyond_the_seeds", "orbit_raising", "final_radius")},
            lambda e: {"final_radius": float(e.trajectory.state(e.trajectory.tf)[0])},
        ),
        Case(
            "rayleigh_mixed",
            "Rayleigh, u + x1/6 <= 0: boundary arcs of a mixed constraint",
            rayleigh_mixed,
            Radau(nodes=4, intervals=30),
            {"mesh_tolerance": 1e-6},
            lambda: {"objective": _published("beyond_the_seeds", "rayleigh_mixed", "objective")},
            lambda e: {"objective": e.trajectory.objective},
        ),
        Case(
            "rayleigh",
            "Rayleigh, no constraint: its flow blows up from the direct costates (multiple shooting)",
            rayleigh,
            Radau(nodes=4, intervals=20),
            {"error_threshold": None},
            _rayleigh_reference,
            lambda e: {"objective": e.trajectory.objective},
        ),
        Case(
            "gto_geo_5N",
            "GTO-GEO at 5 N (the slides' transfer): thrust bounded in norm, bang-off-bang over 10 revolutions",
            lambda: orbit_transfer_direct(_transfer_thrust(), "fuel"),
            Radau(nodes=4, intervals=160),
            {"error_threshold": None, "ipopt_options": {"max_iter": 3000}},
            _slides_reference,
            _transfer_measure,
            shoot=lambda: orbit_transfer(_transfer_thrust()),
            control_set="ball",
        ),
        Case(
            "entry_landing",
            "the seeds' entry landing (Radau, refined)",
            entry_landing,
            Radau(nodes=4, intervals=20),
            {"mesh_tolerance": 1e-6},
        ),
        Case(
            "miser3_state_constraint",
            "MISER3: a state constraint on a regular control",
            miser3_state_constraint,
            Radau(nodes=4, intervals=30),
            {"mesh_tolerance": 1e-6},
            lambda: {"objective": _published("beyond_the_seeds", "miser3_state_constraint", "objective")},
            lambda e: {"objective": e.objective},
        ),
        Case(
            "bryson_denham_boundary_arc",
            "Bryson-Denham, x <= 0.1: a boundary arc of order two, the costate jumping at entry and exit",
            lambda: bryson_denham("boundary_arc"),
            Radau(nodes=4, intervals=20),
            {"mesh_tolerance": 1e-6},
            lambda: bryson_denham_extremal("boundary_arc"),
            _arcs_measure,
            options={"integrator_tol": 1e-14},
        ),
        Case(
            "bryson_denham_touch_point",
            "Bryson-Denham, x <= 0.2: a touch point of order two, the costate jumping there",
            lambda: bryson_denham("touch_point"),
            Radau(nodes=4, intervals=20),
            {"mesh_tolerance": 1e-6},
            lambda: bryson_denham_extremal("touch_point"),
            _arcs_measure,
            options={"integrator_tol": 1e-14},
        ),
        Case(
            "turnpike",
            "the turnpike (OptimalControl.jl): bang, singular, bang",
            turnpike,
            Radau(nodes=4, intervals=20),
            {"mesh_tolerance": 1e-7},
            turnpike_extremal,
            _arcs_measure,
            options={"integrator_tol": 1e-14},
        ),
        Case(
            "tumour_anti_angiogenesis",
            "tumour anti-angiogenesis: a drug budget only the final state can reach (its terminal condition)",
            tumour,
            Radau(nodes=4, intervals=60),
            {"error_threshold": None},
            lambda: {
                "final_tumour_volume": _published("beyond_the_seeds", "tumour_anti_angiogenesis", "final_tumour_volume")
            },
            lambda e: {"final_tumour_volume": float(e.trajectory.state(e.trajectory.tf)[0])},
        ),
        Case(
            "free_flying_robot",
            "free-flying robot: thruster pairs solved directly, shot on their net thrusts (L1-singular arcs)",
            free_flying_robot,
            HLGL(intervals=600),
            {"error_threshold": None},
            lambda: {"objective": _published("beyond_the_seeds", "free_flying_robot", "objective")},
            lambda e: {"objective": e.objective},
            shoot=free_flying_robot_net,
            # arcs read in the net thrusts; its singular arcs are shorter than the default shortest arc
            options={"method": "arcs", "min_share": 0.005},
        ),
    ]
}


def slides_norm_S(thrust_N: float) -> float:
    """The slides' |S| of the L1 transfer at ``thrust_N``, switchings corrected, variational Jacobian (slide 18)."""
    table = paper_table("switching_detection")
    row = table[
        np.isclose(table.thrust_N, thrust_N) & (table.detection == "correction") & (table.jacobian == "variational")
    ]
    return float(row.norm_S.iloc[0])


def low_thrust_by_multiple_shooting(
    thrust_N: float, *, segments: int, tol: float, slides_tol: float = 1e-8
) -> tuple[pd.DataFrame, dict]:
    """The slides' L1 transfer at a low thrust, from the energy-homotopy solution (notebook 05's published costates,
    ``data/derived/orbit_transfer_energy.csv``): single shooting (damped Newton, the variational Jacobian) with the
    integrator at the slides' tolerance and at ``tol``, then multiple shooting
    (:class:`ocpkit.shooting.multiple.MultipleShooting`, ``segments`` equal shares of the horizon, at ``tol``) from
    the second. One row per run: its conditions ``norm_S`` (the slides' |S|: final state and H(tf)), for multiple
    shooting the relative continuity defect and ``norm_R`` (both together), the level below which the residual is
    chance (``noise``: what the exact Jacobian does not explain of a change of relative size 1e-12), switchings,
    fuel and tf. Returns ``(table, runs)``, ``runs`` keyed by ``("single" | "multiple", integrator tolerance)``."""
    from ocpkit.shooting.multiple import MultipleShooting

    from .orbit_transfer import TransferSystems, energy_start_vector, fuel_kg, read_cache, residual_noise

    energy = read_cache("orbit_transfer_energy")
    if energy is None:
        raise FileNotFoundError("the energy solutions of notebook 05 (data/derived/orbit_transfer_energy.csv)")
    start = energy_start_vector(energy, "longitude", thrust_N)
    systems, rows, runs = TransferSystems(), [], {}
    for integrator_tol in (slides_tol, tol):
        shooting = systems.shooting("fuel", thrust_N, tol=integrator_tol)
        r = shooting.solve(start, solver="newton", maxfev=300, raise_on_failure=False)
        if r.integration is None:
            raise SolverError(
                "shooting", r.detail, r.evaluations, f"{thrust_N} N, integrator tolerance {integrator_tol}"
            )
        runs[("single", integrator_tol)] = r
        rows.append(
            {
                "shooting": "single",
                "segments": 1,
                "integrator_tol": integrator_tol,
                "norm_S": r.norm,
                "continuity": np.nan,
                "norm_R": r.norm,
                "noise": residual_noise(shooting, r.z),
                "switchings": r.integration.switchings,
                "fuel_kg": fuel_kg(r),
                "tf_h": r.tf,
            }
        )
    multiple = MultipleShooting(shooting, segments)
    m = multiple.solve(r.z, tol=1e-10, raise_on_failure=False)
    runs[("multiple", tol)] = m
    rows.append(
        {
            "shooting": "multiple",
            "segments": segments,
            "integrator_tol": tol,
            "norm_S": m.terminal,
            "continuity": m.continuity,
            "norm_R": m.norm,
            "noise": multiple.noise(np.concatenate([m.z, m.nodes.ravel()])),
            "switchings": m.switchings,
            "fuel_kg": propellant_kg(m.integrations[-1].y[6]),
            "tf_h": m.tf,
        }
    )
    table = pd.DataFrame(rows)
    table.insert(0, "thrust_N", thrust_N)
    table["slides_norm_S"] = slides_norm_S(thrust_N)
    return table, runs


def run_case(case: Case, tol: float = 1e-10) -> tuple[list[dict], dict, object]:
    """The case's rows (one per compared quantity, or one saying where the chain stopped), its timings and its
    extremal (None where the chain stopped)."""
    start = time.perf_counter()
    direct = case.transcription().solve(**case.solve_options)
    direct_s = time.perf_counter() - start
    base = {"problem": case.name, "what": case.what}
    timings = {"problem": case.name, "direct_s": direct_s}
    try:
        shoot = case.shoot() if case.shoot is not None else None
        extremal = to_extremal(direct, problem=shoot, control_set=case.control_set, tol=tol, **case.options)
    except (ValueError, SolverError) as exc:
        timings["chain_s"] = time.perf_counter() - start - direct_s
        words = _words(control_structure(direct), direct.problem.control_names)
        return [{**base, "verdict": "stopped", "reason": str(exc).split(";")[0], "structure": words}], timings, None
    timings.update(extremal.timings)
    cert = extremal.certificate
    verdict = cert.second_order
    common = {
        **base,
        "verdict": "certified",
        "reason": "",
        "structure": _in_words(extremal),
        "route": extremal.route,
        "norm_S": extremal.shooting.norm,
        "hamiltonian_drift": cert["hamiltonian_constant"].value if _has(cert, "hamiltonian_constant") else np.nan,
        "objective_gap": cert["objective_gap"].value,
        "second_order": verdict.verdict + (f" ({verdict.route})" if verdict.route else ""),
    }
    reference, measured = case.reference(), case.measure(extremal)
    rows = [{**common, "quantity": q, "reference": reference[q], "value": measured.get(q, np.nan)} for q in reference]
    for r in rows:
        r["error"] = abs(r["value"] - r["reference"])
    return rows or [common], timings, extremal


def _in_words(extremal) -> str:
    """The arcs of every control, without times; a control with no arcs (unbounded, no active inequality) is
    regular throughout. For a thrust bounded in norm (a restated direct problem: its controls are not the
    extremal's), the extremal's own: the norm on or off, alternating at each switching (the direct solution's
    reading depends on which local minimum its solve stopped in)."""
    law = getattr(getattr(extremal.shooting, "system", None), "law", None)  # the switching method's
    if law is not None and law.control_set == "ball":
        tr = extremal.trajectory
        on = bool(np.linalg.norm(tr.control(np.array([tr.t0]))[0]) > 0.5 * law.radius)
        kinds = ["on" if (k % 2 == 0) == on else "off" for k in range(extremal.shooting.integration.switchings + 1)]
        return f"|u|: {', '.join(kinds)}"
    controls = extremal.direct.problem.control_names
    if any(a.control not in controls for a in extremal.structure.arcs):  # read in a restatement's controls
        controls = extremal.trajectory.problem.control_names
    return _words(extremal.structure, controls)


def _words(structure, controls) -> str:
    """Each control's arcs without times (a control with none is regular throughout), and the touch points."""
    lines = structure.describe(times=False).splitlines()
    arcs = dict(line.split(": ", 1) for line in lines if not line.startswith("touch point"))
    words = "; ".join(f"{c}: {arcs.get(c, 'regular')}" for c in controls)
    return "; ".join([words, *(line for line in lines if line.startswith("touch point"))])


def _has(certificate, name: str) -> bool:
    return any(c.name == name for c in certificate.checks)


__all__ = ["CASES", "Case", "low_thrust_by_multiple_shooting", "run_case", "slides_norm_S"]
