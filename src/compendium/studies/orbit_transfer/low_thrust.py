"""The slides' conclusion at low thrust (slides 18-19: switching correction with the variational Jacobian converges
best): the Jacobian checked along the Newton path, the noise floor of S against the integrator's tolerance, and the
reading that reproduces the slides' |S|.

Measured here (notebook 05): at 0.2 N, MINPACK with correction and the variational Jacobian at the slides'
tolerance 1e-8 stalls with |S| = 1e-2 because the iteration loses a short coast arc of the extremal (600 switchings
for 602) and stops where the switching function only touches zero: a grazing switching, where S is not
differentiable. The Jacobian itself is right along the whole path (central differences at 1e-12 agree with it to
the integrator's accuracy).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from ocpkit.shooting import Shooting, ShootingResult
from ocpkit.shooting.grazing import closest_approach
from ocpkit.shooting.result import noise_floor
from ocpkit.shooting.strategies import FiniteDifferences, Variational
from ocpkit.shooting.trajectory import ShootingTrajectory

from ...progress import progress
from .l1 import MAXFEV, l1_row, l1_runs, residual_noise
from .systems import COSTATES, TransferSystems

#: the integrator tolerance of the reference derivatives (central differences) of the Jacobian check
REFERENCE_TOL = 1e-12
#: the relative steps of those central differences: 1e-5 resolves the strong columns, 1e-4 the weak ones (ey, hy:
#: |dS/dz| about 1e-4 of the others), whose differences at 1e-5 are the noise of S divided by the step
REFERENCE_STEPS = (1e-5, 1e-4)
#: a column of central differences is resolved where its norm is at least this many times the noise of S divided by
#: twice the step: the noise then changes it by at most 1e-3 of itself
RESOLVED = 1000.0


class RecordingJacobian:
    """The variational Jacobian, remembering every point it is asked at: the Newton (MINPACK) path."""

    name = "variational"

    def __init__(self):
        self.points: list[np.ndarray] = []

    def __call__(self, shooting: Shooting, z: np.ndarray, P: np.ndarray, S0=None):
        self.points.append(np.array(z, dtype=float))
        return Variational()(shooting, z, P, S0)


def newton_path(systems: TransferSystems, thrust_N: float, z_energy, *, rtol: float = 1e-8, maxfev: int = 300):
    """The slides' run (correction, variational Jacobian, MINPACK from the energy costates) at ``rtol``:
    ``(result, points)``, ``points`` the ``("iterate", z)`` of each Jacobian evaluation and ``("end", z)`` where the
    run stopped (where that is not the last of them), as :func:`jacobian_check` takes them."""
    recorder = RecordingJacobian()
    shooting = systems.shooting("fuel", thrust_N, switching="correction", jacobian=recorder, tol=rtol)
    result = shooting.solve(z_energy, solver="hybr", maxfev=maxfev, raise_on_failure=False)
    points = [("iterate", z) for z in recorder.points]
    if not np.array_equal(result.z, recorder.points[-1]):  # MINPACK's last steps take no new Jacobian
        points.append(("end", np.array(result.z, dtype=float)))
    return result, points


def switching_approach(shooting: Shooting, z) -> tuple[float, float]:
    """``(t, g)``: where the switching function comes nearest zero without crossing it along the integration from
    ``z`` (:func:`ocpkit.shooting.grazing.closest_approach`); NaN where it never turns back before zero, or where the
    integration's history is cut at its capacity. A ``g`` near zero is a grazing switching: an arc about to appear
    (or just vanished), where S is not differentiable."""
    try:
        approach = closest_approach(ShootingTrajectory(shooting.integrate(z, record=True), shooting.compiled.system))
    except ValueError:
        approach = None
    return (float("nan"), float("nan")) if approach is None else (approach.t, approach.g)


def _column_errors(J: np.ndarray, references: list[np.ndarray]) -> np.ndarray:
    """Per column, ``|J_j - D_j| / |D_j|`` against the nearest of the central differences ``references``
    (one per step): agreement at one step is what a right column shows, and no step agrees with a wrong one."""
    errors = [np.linalg.norm(J - D, axis=0) / np.linalg.norm(D, axis=0) for D in references]
    return np.min(errors, axis=0)


def jacobian_check(
    systems: TransferSystems,
    thrust_N: float,
    points,
    *,
    rtol: float = 1e-8,
    reference_tol: float = REFERENCE_TOL,
    steps=REFERENCE_STEPS,
) -> pd.DataFrame:
    """The variational Jacobian at ``points``, column by column, against central differences of S integrated at
    ``reference_tol`` (switchings corrected), for the Jacobian integrated at ``rtol`` and at ``reference_tol``.

    ``points``: ``(label, z)`` pairs (a Newton path: ``"iterate"`` at each Jacobian evaluation, ``"end"`` where the
    run stopped, ``"solution"`` a converged point), numbered in their order from 0 (``iterate``; a solution -1). One row per point
    and column: ``error`` and ``error_reference_tol`` (relative column errors), the column's norm and the
    Jacobian's condition number (both at ``reference_tol``), ``difference_noise`` (the noise of S at
    ``reference_tol``, :func:`~ocpkit.shooting.result.noise_floor` at the last point, over twice the larger step)
    and ``resolved`` (the differences' column at least :data:`RESOLVED` times that: a column the check can judge,
    decided by the differences alone), and for the point |S| at ``reference_tol``, the
    switchings at ``rtol`` and at ``reference_tol``, and the switching function's closest approach to zero without
    crossing it (time and value)."""
    coarse = systems.shooting("fuel", thrust_N, switching="correction", tol=rtol)
    fine = systems.shooting("fuel", thrust_N, switching="correction", tol=reference_tol)
    names = [*COSTATES, "tf"]
    rows = []
    # the noise of S at reference_tol (no Jacobian in it), measured once at the last point: a difference column is
    # resolved where its norm is RESOLVED times what that noise does to a difference of the larger step
    noise = noise_floor(fine.residual, np.asarray(points[-1][1], dtype=float))
    bar = progress(total=len(points), desc=f"Jacobian check, {thrust_N:g} N", unit="point")
    numbers = iter(range(len(points)))
    for label, z in points:
        bar.update()
        k = -1 if label == "solution" else next(numbers)
        _, J_coarse = coarse.jacobian_matrix(z, method="variational")
        S, J_fine = fine.jacobian_matrix(z, method="variational")
        references = [fine.jacobian_matrix(z, method=FiniteDifferences(central=True, step=h), S0=S)[1] for h in steps]
        e_coarse, e_fine = _column_errors(J_coarse, references), _column_errors(J_fine, references)
        t_touch, g_touch = switching_approach(fine, z)
        common = {
            "thrust_N": thrust_N,
            "iterate": k,
            "point": label,
            "norm_S_reference_tol": float(np.linalg.norm(S)),
            "switchings": coarse.integrate(z).switchings,
            "switchings_reference_tol": fine.integrate(z).switchings,
            "closest_approach_t_h": t_touch,
            "closest_approach_g": g_touch,
            "condition": float(np.linalg.cond(J_fine)),
        }
        norms = np.linalg.norm(J_fine, axis=0)
        z = np.asarray(z, dtype=float)
        difference_noise = noise / (2 * max(steps) * np.maximum(np.abs(z), 1.0))
        reference_norms = np.linalg.norm(references[int(np.argmax(steps))], axis=0)
        for j, name in enumerate(names):
            rows.append(
                {
                    **common,
                    "column": name,
                    "column_norm": norms[j],
                    "difference_noise": difference_noise[j],
                    "resolved": bool(reference_norms[j] >= RESOLVED * difference_noise[j]),
                    "error": e_coarse[j],
                    "error_reference_tol": e_fine[j],
                }
            )
    bar.close()
    return pd.DataFrame(rows)


def tolerance_runs(
    systems: TransferSystems,
    thrust_N: float,
    z_energy,
    rtols,
    *,
    switchings=("detection", "correction"),
    maxfev: int = MAXFEV,
    reuse: Mapping[tuple[str, float], ShootingResult] | None = None,
) -> tuple[pd.DataFrame, dict]:
    """The slides' L1 shooting (MINPACK from the energy costates, variational Jacobian) with each switching
    treatment at each integrator tolerance of ``rtols``, and the noise of S at each end point
    (:func:`~compendium.studies.orbit_transfer.residual_noise`, at that tolerance): the floor |S| can reach.
    ``reuse``: runs already made, keyed by ``(switching, rtol)``, as :func:`~compendium.studies.orbit_transfer.l1_runs`
    makes them at that tolerance from ``z_energy`` with ``maxfev`` (:func:`reusable_runs`): taken as they are, not
    solved again. Returns ``(table, results)``, ``results`` keyed by ``(switching, rtol)``."""
    reuse = dict(reuse or {})
    tables, results = [], {}
    for rtol in rtols:
        taken = {s: reuse[(s, rtol)] for s in switchings if (s, rtol) in reuse}
        for s, r in taken.items():
            if (r.switching, r.jacobian) != (s, "variational"):
                raise ValueError(
                    f"reuse[({s!r}, {rtol:g})] is a run with switching {r.switching!r} and the {r.jacobian} Jacobian, "
                    f"not {s!r} with the variational one"
                )
        left = [s for s in switchings if s not in taken]
        made = {}
        if left:
            _, made = l1_runs(
                systems,
                thrust_N,
                z_energy,
                combinations=[(s, "variational") for s in left],
                rtol=rtol,
                maxfev=maxfev,
            )
        runs = {s: taken[s] if s in taken else made[("hybr", s, "variational")] for s in switchings}
        table = pd.DataFrame([l1_row(thrust_N, "hybr", r) for r in runs.values()])
        noises = []
        for switching, r in runs.items():
            results[(switching, rtol)] = r
            noises.append(residual_noise(systems.shooting("fuel", thrust_N, switching=switching, tol=rtol), r.z))
        table.insert(2, "integrator_tol", rtol)
        table["noise_of_S"] = noises
        tables.append(table)
    return pd.concat(tables, ignore_index=True), results


def reusable_runs(results: Mapping[tuple, ShootingResult], thrust_N: float, rtol: float) -> dict:
    """The runs of notebook 05's L1 table that :func:`tolerance_runs` makes at ``rtol``, keyed for its ``reuse``:
    ``results`` keyed ``(thrust_N, solver, detection, jacobian)``, made by
    :func:`~compendium.studies.orbit_transfer.l1_runs` at ``rtol`` from the same start with ``MAXFEV``; its
    MINPACK runs with the variational Jacobian, where the table has them."""
    runs = {s: results.get((thrust_N, "hybr", s, "variational")) for s in ("detection", "correction")}
    return {(s, rtol): r for s, r in runs.items() if r is not None}


def slides_conclusion(runs: pd.DataFrame, slides: pd.DataFrame) -> pd.DataFrame:
    """Per thrust, the slides' conclusion (correction with the variational Jacobian converges with |S| at or below
    theirs) against ``runs`` (:func:`tolerance_runs` rows, correction and variational among them): the loosest
    integrator tolerance at which it holds (NaN where none does: then the run with the smallest |S|), with |S|, the
    noise of S there, Jacobians, fuel and switchings beside the slides' (their fuel and switchings: the detection
    run, the only one they print them for), and whether it converged at the loosest tolerance of ``runs`` (the
    slides' 1e-8)."""
    sl = slides.set_index(["thrust_N", "detection", "jacobian"])
    rows = []
    ours = runs[(runs.detection == "correction") & (runs.jacobian == "variational")]
    for T, sub in ours.groupby("thrust_N", sort=False):
        cv, det = sl.loc[(T, "correction", "variational")], sl.loc[(T, "detection", "fd")]
        sub = sub.sort_values("integrator_tol", ascending=False)
        held = sub[sub.converged & (sub.norm_S <= cv.norm_S)]
        row = held.iloc[0] if len(held) else sub.sort_values("norm_S").iloc[0]
        rows.append(
            {
                "thrust_N": T,
                "reproduced": bool(len(held)),
                "integrator_tol": row.integrator_tol,
                "converged": bool(row.converged),
                "norm_S": row.norm_S,
                "norm_S_slides": cv.norm_S,
                "noise_of_S": row.noise_of_S,
                "n_jac": row.n_jac,
                "n_jac_slides": cv.n_jac,
                "fuel_kg": row.fuel_kg,
                "fuel_kg_slides": det.objective_kg,
                "switchings": row.switchings,
                "switchings_slides": det.switchings,
                "cpu_s": row.cpu_s,
                "cpu_s_slides": cv.cpu_s,
                "converged_at_the_slides_tol": bool(sub.iloc[0].converged),
            }
        )
    return pd.DataFrame(rows)


__all__ = [
    "REFERENCE_STEPS",
    "REFERENCE_TOL",
    "RESOLVED",
    "RecordingJacobian",
    "jacobian_check",
    "newton_path",
    "slides_conclusion",
    "switching_approach",
    "reusable_runs",
    "tolerance_runs",
]
