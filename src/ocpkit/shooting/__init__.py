"""Indirect shooting: Hamiltonian flows, a compiled Dormand-Prince integrator with switching
detection and correction, variational Jacobians, single and multiple shooting, solvers and continuation."""

from .compiled import CompiledSystem, Integration
from .continuation import ContinuationPath, GeometricSteps, Schedule, Toward, arclength, follow, homotopy
from .hamiltonian import ControlLaw, HamiltonianSystem, control_law
from .multiple import MultipleShooting, MultipleShootingResult
from .result import IndirectResult
from .shooting import Shooting, ShootingResult
from .strategies import (
    JACOBIANS,
    SOLVERS,
    SWITCHING_MODES,
    DampedNewton,
    FiniteDifferences,
    MinpackHybrid,
    Variational,
)
from .trajectory import ShootingTrajectory

__all__ = [
    "JACOBIANS",
    "SOLVERS",
    "SWITCHING_MODES",
    "CompiledSystem",
    "ContinuationPath",
    "ControlLaw",
    "DampedNewton",
    "FiniteDifferences",
    "GeometricSteps",
    "HamiltonianSystem",
    "IndirectResult",
    "Integration",
    "MinpackHybrid",
    "MultipleShooting",
    "MultipleShootingResult",
    "Schedule",
    "Shooting",
    "ShootingResult",
    "ShootingTrajectory",
    "Toward",
    "Variational",
    "arclength",
    "control_law",
    "follow",
    "homotopy",
]


def __getattr__(name: str) -> tuple[str, ...]:
    if name == "DETECTION_MODES":
        from .._deprecation import renamed

        renamed("ocpkit.shooting.DETECTION_MODES", "SWITCHING_MODES")
        return SWITCHING_MODES
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
