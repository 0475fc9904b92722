"""The slides' conclusion at low thrust (slides 18-19: switching correction with the variational Jacobian converges
best): the Jacobian checked along the Newton path, the noise floor of S against the integrator's tolerance, and the
reading that reproduces the slides' |S|.

Measured here (notebook 05): at 0.2 N, MINPACK with correction and the variational Jacobian at the slides'
tolerance 1e-8 stalls with |S| = 1e-2 because the iteration loses a short coast arc of the extremal (600 switchings
for 602) and stops where the switching function only touches zero: a grazing switching, where S is not
differentiable. The Jacobian itself is right along the whole path (central differences at 1e-12 agree with it to
the integrator's accuracy wherever their steps keep the point's switchings; near the grazing switching, a step of the
differences can make the short arc appear, and they then measure S's jump, not its derivative).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from ocpkit.shooting import Shooting, ShootingResult
from ocpkit.shooting.grazing import closest_approach
from ocpkit.shooting.result import noise_floor
from ocpkit.shooting.strategies import Variational
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


def central_differences(shooting: Shooting, z, steps, switchings: int) -> tuple[list[np.ndarray], np.ndarray]:
    """Central differences of S at ``z``, one matrix per relative step of ``steps`` (unknown ``j`` moved by ``step
    max(|z_j|, 1)``, as :class:`~ocpkit.shooting.strategies.FiniteDifferences`), and ``kept[i, j]``: whether both
    points of step ``i`` in column ``j`` have the ``switchings`` of ``z``. Where they do not, an arc appears or
    vanishes inside the stencil (a grazing switching near ``z``) and the column measures S's jump, not dS/dz. The
    count is a necessary test, not a sufficient one: an arc that appears while another vanishes keeps it."""
    z = np.asarray(z, dtype=float)
    references, kept = [], np.zeros((len(steps), z.size), dtype=bool)
    for i, step in enumerate(steps):
        D = None
        for j in range(z.size):
            h = step * max(abs(z[j]), 1.0)
            sides = []
            for sign in (1.0, -1.0):
                moved = z.copy()
                moved[j] += sign * h
                flown = shooting.integrate(moved)
                sides.append((shooting.residual(moved, integration=flown), flown.switchings))
            (S_plus, n_plus), (S_minus, n_minus) = sides
            D = np.empty((S_plus.size, z.size)) if D is None else D
            D[:, j] = (S_plus - S_minus) / (2 * h)
            kept[i, j] = n_plus == n_minus == switchings
        references.append(D)
    return references, kept


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


def usable_steps(references: list[np.ndarray], kept: np.ndarray) -> np.ndarray:
    """``usable[i, j]``: step ``i`` can judge column ``j``, decided by the differences alone: its stencil keeps the
    point's switchings (``kept``, as :func:`central_differences`) and its column of differences is finite and not
    zero."""
    finite = np.array([np.isfinite(D).all(axis=0) & (np.linalg.norm(D, axis=0) > 0) for D in references])
    return kept & finite


def _column_errors(J: np.ndarray, references: list[np.ndarray], usable: np.ndarray) -> np.ndarray:
    """Per column, ``|J_j - D_j| / |D_j|`` against the nearest of the central differences ``references`` (one per
    step) whose step can judge it (``usable``, :func:`usable_steps`); NaN where none can, infinite where the
    Jacobian's column is not finite (a broken column fails the check): agreement at one step is what a right column
    shows, and no step agrees with a wrong one."""
    with np.errstate(divide="ignore", invalid="ignore"):  # the steps that cannot judge a column are dropped below
        errors = np.array([np.linalg.norm(J - D, axis=0) / np.linalg.norm(D, axis=0) for D in references])
    errors = np.where(np.isfinite(J).all(axis=0), errors, np.inf)
    nearest = np.where(usable, errors, np.inf).min(axis=0)
    return np.where(usable.any(axis=0), nearest, np.nan)


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
    ``reference_tol`` (switchings corrected; :func:`central_differences`), for the Jacobian integrated at ``rtol`` and
    at ``reference_tol``.

    ``points``: ``(label, z)`` pairs (a Newton path: ``"iterate"`` at each Jacobian evaluation, ``"end"`` where the
    run stopped, ``"solution"`` a converged point), numbered in their order from 0 (``iterate``; a solution -1). One
    row per point and column: ``error`` and ``error_reference_tol`` (relative column errors against the nearest
    differences of a step that can judge the column, :func:`usable_steps`: one that keeps the point's switchings on
    both sides, with a finite, nonzero column; NaN where no step can, infinite where the Jacobian's column is not
    finite), the column's norm and the Jacobian's condition number (both at ``reference_tol``), ``same_switchings``
    (some step keeps them: where none does, an arc appears or vanishes within the differences' steps, which then
    measure S's jump, not its derivative), ``difference_noise`` (the noise of S at ``reference_tol``,
    :func:`~ocpkit.shooting.result.noise_floor` at the last point, over twice the larger step that can judge the
    column) and ``resolved`` (some step can, and the differences' column of the larger such step is at least
    :data:`RESOLVED` times that noise: a column the check judges, decided by the differences alone), and for the
    point |S| at ``reference_tol``, the switchings at ``rtol`` and at ``reference_tol``, and the switching function's
    closest approach to zero without crossing it (time and value)."""
    coarse = systems.shooting("fuel", thrust_N, switching="correction", tol=rtol)
    fine = systems.shooting("fuel", thrust_N, switching="correction", tol=reference_tol)
    names = [*COSTATES, "tf"]
    steps = np.asarray(steps, dtype=float)
    rows = []
    # the noise of S at reference_tol (no Jacobian in it), measured once at the last point: a difference column is
    # resolved where its norm is RESOLVED times what that noise does to a difference of its larger usable step
    noise = noise_floor(fine.residual, np.asarray(points[-1][1], dtype=float))
    bar = progress(total=len(points), desc=f"Jacobian check, {thrust_N:g} N", unit="point")
    numbers = iter(range(len(points)))
    for label, z in points:
        bar.update()
        k = -1 if label == "solution" else next(numbers)
        z = np.asarray(z, dtype=float)
        _, J_coarse = coarse.jacobian_matrix(z, method="variational")
        S, J_fine = fine.jacobian_matrix(z, method="variational")
        n_fine = fine.integrate(z).switchings
        references, kept = central_differences(fine, z, steps, n_fine)
        usable = usable_steps(references, kept)
        e_coarse, e_fine = _column_errors(J_coarse, references, usable), _column_errors(J_fine, references, usable)
        t_touch, g_touch = switching_approach(fine, z)
        common = {
            "thrust_N": thrust_N,
            "iterate": k,
            "point": label,
            "norm_S_reference_tol": float(np.linalg.norm(S)),
            "switchings": coarse.integrate(z).switchings,
            "switchings_reference_tol": n_fine,
            "closest_approach_t_h": t_touch,
            "closest_approach_g": g_touch,
            "condition": float(np.linalg.cond(J_fine)),
        }
        norms = np.linalg.norm(J_fine, axis=0)
        for j, name in enumerate(names):
            judged = bool(usable[:, j].any())
            larger = int(np.flatnonzero(usable[:, j])[np.argmax(steps[usable[:, j]])]) if judged else None
            difference_noise = noise / (2 * steps[larger] * max(abs(z[j]), 1.0)) if judged else float("nan")
            rows.append(
                {
                    **common,
                    "column": name,
                    "column_norm": norms[j],
                    "same_switchings": bool(kept[:, j].any()),
                    "difference_noise": difference_noise,
                    "resolved": judged
                    and bool(np.linalg.norm(references[larger][:, j]) >= RESOLVED * difference_noise),
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
    "central_differences",
    "usable_steps",
    "jacobian_check",
    "newton_path",
    "slides_conclusion",
    "switching_approach",
    "reusable_runs",
    "tolerance_runs",
]
