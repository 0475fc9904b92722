"""Indirect shooting: Hamiltonian flows, a compiled Dormand-Prince integrator with switching
detection and correction, variational Jacobians, and a shooting solver."""

from .compiled import DETECTION_MODES, CompiledSystem, Integration
from .hamiltonian import ControlLaw, HamiltonianSystem, control_law
from .shooting import JACOBIANS, SOLVERS, Shooting, ShootingResult, homotopy

__all__ = [
    "DETECTION_MODES",
    "JACOBIANS",
    "SOLVERS",
    "CompiledSystem",
    "ControlLaw",
    "HamiltonianSystem",
    "Integration",
    "Shooting",
    "ShootingResult",
    "control_law",
    "homotopy",
]
