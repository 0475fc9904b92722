"""Indirect shooting: Hamiltonian flows, a compiled Dormand-Prince integrator with switching
detection and correction, variational Jacobians, and a shooting solver."""

from .compiled import DETECTION_MODES, CompiledSystem, Integration
from .hamiltonian import ControlLaw, HamiltonianSystem, control_law
from .shooting import JACOBIANS, SOLVERS, Shooting, ShootingResult, homotopy
from .study import ALL_COMBINATIONS, COMBINATIONS, compare_methods

__all__ = [
    "ALL_COMBINATIONS",
    "COMBINATIONS",
    "DETECTION_MODES",
    "JACOBIANS",
    "SOLVERS",
    "CompiledSystem",
    "ControlLaw",
    "HamiltonianSystem",
    "Integration",
    "Shooting",
    "ShootingResult",
    "compare_methods",
    "control_law",
    "homotopy",
]
