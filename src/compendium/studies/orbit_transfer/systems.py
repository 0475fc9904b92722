"""The transfer's compiled Hamiltonian systems, shared by every solve, its costates' names and its fuel."""

from __future__ import annotations

from ocpkit.shooting import CompiledSystem, HamiltonianSystem, Shooting, control_law

from ...problems.orbit_transfer import STATE_NAMES, orbit_transfer, orbit_transfer_constants

COSTATES = [f"p_{n}" for n in STATE_NAMES]
TOL = 1e-10  # integrator tolerance of the minimum-time and energy solves


class TransferSystems:
    """Compiled Hamiltonian systems of the transfer, shared by every thrust, reading and final time.

    The thrust and the cost weight are parameters of the compiled code; the final
    conditions (fixed time or fixed longitude) change the boundary-value problem, not the flows.
    """

    def __init__(self):
        self._cache = {}

    def _compiled(self, kind: str):
        if kind not in self._cache:
            if kind == "time":
                pr = orbit_transfer(1.0, objective="time")
                law = control_law(pr, "ball")
            elif kind in ("energy", "fuel"):
                pr = orbit_transfer(1.0, lam=0.0 if kind == "energy" else 1.0, final="time", tf=1.0)
                law = control_law(pr, "ball", regularized=kind == "energy")
            else:
                raise ValueError(f"kind must be 'time', 'energy' or 'fuel', got {kind!r}")
            self._cache[kind] = (law, CompiledSystem(HamiltonianSystem(pr, law)))
        return self._cache[kind]

    def shooting(
        self,
        kind: str,
        thrust_N: float,
        *,
        final: str | None = None,
        tf: float | None = None,
        longitude: float | None = None,
        switching: str = "correction",
        jacobian: str = "variational",
        tol: float = TOL,
        interior_check: bool = True,
    ) -> Shooting:
        """A shooting problem: ``kind`` is ``"time"``, ``"energy"`` or ``"fuel"``.

        ``final`` and ``longitude`` as :func:`~ocpkit.problems.orbit_transfer.orbit_transfer`
        (default: the reading of ``data/problems``); ``tf`` the fixed final time of the
        ``"time"`` reading.
        """
        law, compiled = self._compiled(kind)
        if kind == "time":
            pr = orbit_transfer(thrust_N, objective="time", final=final or "free", longitude=longitude)
        else:
            pr = orbit_transfer(thrust_N, lam=0.0 if kind == "energy" else 1.0, final=final, tf=tf, longitude=longitude)
        return Shooting(
            pr,
            law,
            switching=switching,
            jacobian=jacobian,
            rtol=tol,
            atol=tol,
            system=compiled,
            interior_check=interior_check,
        )


def fuel_kg(result) -> float:
    """Propellant used (kg) by a transfer: initial minus final mass."""
    return propellant_kg(result.integration.y[6])


def propellant_kg(final_mass) -> float:
    """Propellant used (kg) by a transfer that ends with ``final_mass``."""
    return orbit_transfer_constants()["initial"]["m"] - float(final_mass)
