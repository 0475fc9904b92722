"""Indirect shooting: Hamiltonian flows, a compiled Dormand-Prince integrator with switching
detection and correction, variational Jacobians, shooting solvers and continuation."""

from .compiled import CompiledSystem, Integration
from .continuation import GeometricSteps, Schedule, arclength, follow, homotopy
from .hamiltonian import ControlLaw, HamiltonianSystem, control_law
from .shooting import Shooting, ShootingResult
from .strategies import (
    DETECTION_MODES,
    JACOBIANS,
    SOLVERS,
    DampedNewton,
    FiniteDifferences,
    MinpackHybrid,
    Variational,
)
from .trajectory import ShootingTrajectory

__all__ = [
    "DETECTION_MODES",
    "JACOBIANS",
    "SOLVERS",
    "CompiledSystem",
    "ControlLaw",
    "DampedNewton",
    "FiniteDifferences",
    "GeometricSteps",
    "HamiltonianSystem",
    "Integration",
    "MinpackHybrid",
    "Schedule",
    "Shooting",
    "ShootingResult",
    "ShootingTrajectory",
    "Variational",
    "arclength",
    "control_law",
    "follow",
    "homotopy",
]
