"""The explorer's family: the slides' L1 transfer along the thrust, for :func:`compendium.explorer.explore`."""

from __future__ import annotations

import numpy as np

from ocpkit.shooting import ShootingResult

from ...problems.orbit_transfer import final_longitude
from .systems import TransferSystems, fuel_kg


def thrust_family(systems: TransferSystems, first: ShootingResult, thrust_N: float, *, rtol: float = 1e-8):
    """The slides' L1 transfer as a family over the thrust, for :func:`compendium.explorer.explore`.

    ``first``: the converged L1 extremal at ``thrust_N`` (final longitude ``Lf(Tmax)``, free tf). Each thrust's
    shooting (correction, variational Jacobian, tolerances ``rtol``) has its own ``Lf(Tmax)``, and starts from the
    nearest extremal solved, its costates kept and its tf scaled by the thrust ratio (tf x Tmax nearly constant,
    as every continuation of this package predicts). The status line names the objective, the L1 cost, by what it
    is, the time under full thrust (h), and adds the fuel, the switchings and tf.
    """
    from ...explorer import ShootingFamily

    def build(values):
        T = values["thrust_N"]
        return systems.shooting("fuel", T, final="longitude", longitude=final_longitude(T), tol=rtol)

    def predict(start, z, values):
        return np.concatenate([z[:-1], [z[-1] * start["thrust_N"] / values["thrust_N"]]])

    def note(result):
        return f"fuel {fuel_kg(result):.3f} kg · {result.integration.switchings} switchings · tf {result.tf:.1f} h"

    return ShootingFamily(
        build, first, {"thrust_N": float(thrust_N)}, predict=predict, note=note, objective_label="∫|u|dt (h)"
    )


def thrust_magnitude(trajectory, t) -> np.ndarray:
    """|u| along a transfer's trajectory (1: full thrust, 0: coasting)."""
    return np.linalg.norm(trajectory.control(t), axis=1)
