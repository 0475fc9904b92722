"""The seeds' test problems and published problems beyond them, each reading its constants from ``data/problems``."""

from ._data import load_problem_data
from .attitude_ascent import attitude_ascent
from .beyond_the_seeds import (
    catalyst_mixing,
    free_flying_robot,
    free_flying_robot_net,
    miser3_state_constraint,
    orbit_raising,
    rayleigh,
    rayleigh_mixed,
    tumour,
)
from .bryson_denham import bryson_denham, bryson_denham_solution
from .cops_gasoil import gasoil, gasoil_fit, gasoil_measurements
from .delta3 import delta3_constants, delta3_guesses, delta3_mass_drops, delta3_phases
from .entry_landing import entry_landing, entry_landing_constants, minimum_downrange_bound
from .flat_moon import flat_moon_ascent, linear_tangent_solution
from .goddard import goddard_constants, goddard_rocket
from .hang_glider import hang_glider
from .hanging_chain import catenary, hanging_chain
from .hyper_sensitive import hyper_sensitive
from .lunar_ascent import lunar_ascent, lunar_ascent_constants
from .minimum_fuel import (
    double_integrator,
    double_integrator_solution,
    double_integrator_thrusters,
    harmonic_oscillator,
)
from .orbit_transfer import (
    final_longitude,
    minimum_longitude,
    orbit_transfer,
    orbit_transfer_constants,
    thrust_units,
)
from .shuttle_reentry import shuttle_heating, shuttle_reentry, shuttle_reentry_constants

__all__ = [
    "attitude_ascent",
    "catalyst_mixing",
    "free_flying_robot",
    "free_flying_robot_net",
    "miser3_state_constraint",
    "orbit_raising",
    "rayleigh",
    "rayleigh_mixed",
    "shuttle_heating",
    "shuttle_reentry",
    "shuttle_reentry_constants",
    "hang_glider",
    "hanging_chain",
    "catenary",
    "tumour",
    "bryson_denham",
    "gasoil",
    "gasoil_fit",
    "gasoil_measurements",
    "bryson_denham_solution",
    "delta3_constants",
    "delta3_guesses",
    "delta3_mass_drops",
    "delta3_phases",
    "final_longitude",
    "minimum_longitude",
    "orbit_transfer",
    "orbit_transfer_constants",
    "thrust_units",
    "double_integrator",
    "double_integrator_solution",
    "double_integrator_thrusters",
    "harmonic_oscillator",
    "entry_landing",
    "entry_landing_constants",
    "minimum_downrange_bound",
    "flat_moon_ascent",
    "goddard_constants",
    "goddard_rocket",
    "hyper_sensitive",
    "linear_tangent_solution",
    "load_problem_data",
    "lunar_ascent",
    "lunar_ascent_constants",
]
