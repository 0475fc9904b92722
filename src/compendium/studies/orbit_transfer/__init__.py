"""The low-thrust GTO-GEO transfer of Martinon & Gergaud, end to end.

The slides' problem (``final="longitude"``, the default reading of
``data/problems/orbit_transfer.toml``) fixes the final longitude and leaves the final
time free; the fixed-time problem (``final="time"``, ``tf = 1.5 t_min``) is kept as
the second reading. The chain of solves:

1. Minimum time at a strong thrust: a direct Radau solve (thrust direction as two
   angles) whose costate estimates start the indirect minimum-time shooting.
2. Minimum time down to the weak thrusts by discrete continuation on the thrust. The
   problem has many local minima (one per way of phasing the final revolutions) and
   the path of extremals folds back in the thrust, so each step keeps the smallest
   converged final time of several predictors, and :func:`refine_minimum_time` then
   restarts each target thrust from every solution found at a thrust within a factor
   of ten of it.
3. The energy problem (lambda = 0): at the first thrust from scaled minimum-time
   costates at ``tf = 1.5 t_min``; for the slides' reading, a continuation on the final
   longitude (free tf) to ``Lf(Tmax)``, then on the thrust with Lf moving with it.
4. The L1 (fuel) shooting from the energy costates with every switching treatment,
   Jacobian and solver: the slides' experiment. No L1 run starts from an L1 answer.

Every continuation here (the thrust, the final longitude, the final time) is
:func:`ocpkit.shooting.follow` with a step rule (:class:`~ocpkit.shooting.Schedule` of
given values halved on failure, or :class:`~ocpkit.shooting.GeometricSteps` for the
minimum time) and the predictors of this problem (tf x Tmax nearly constant).

The package follows the chain, one module per section, each importing only those before it:
:mod:`~compendium.studies.orbit_transfer.systems` (the compiled Hamiltonian systems, the costates' names, the fuel),
:mod:`~compendium.studies.orbit_transfer.continuation` (a robust solve, a thrust schedule),
:mod:`~compendium.studies.orbit_transfer.minimum_time` (steps 1 and 2),
:mod:`~compendium.studies.orbit_transfer.energy` (step 3), :mod:`~compendium.studies.orbit_transfer.l1` (step 4 and
the horizon study), :mod:`~compendium.studies.orbit_transfer.low_thrust` (the slides' conclusion at low thrust: the
Jacobian along the Newton path, the noise floor of S against the integrator's tolerance), :mod:`~compendium.studies.orbit_transfer.cache` (the published record as cache, the 3-D track),
:mod:`~compendium.studies.orbit_transfer.chain` (the chain with its caches) and
:mod:`~compendium.studies.orbit_transfer.family` (the explorer's family along the thrust). Notebook 05 reads them all
from here (``from compendium.studies import orbit_transfer as study``).
"""

from .cache import CACHE_FORMAT, cartesian_track, read_cache
from .chain import SLIDES_CONVERGED, energy_solutions, energy_start_vector, minimum_times, versus_slides
from .continuation import solve_robustly, thrust_schedule
from .energy import (
    calibrate_multiplier,
    energy_longitude_continuation,
    energy_longitude_start,
    energy_start,
    energy_time_continuation,
)
from .family import thrust_family, thrust_magnitude
from .l1 import best_known_fuel, goal_met, horizon_branches, l1_runs, residual_noise
from .low_thrust import (
    jacobian_check,
    newton_path,
    reusable_runs,
    slides_conclusion,
    switching_approach,
    tolerance_runs,
)
from .minimum_time import (
    classify_on_scan,
    minimum_time_continuation,
    minimum_time_start,
    minimum_time_versus_longitude,
    refine_minimum_time,
    scan_minima,
)
from .systems import COSTATES, TOL, TransferSystems, fuel_kg, propellant_kg

__all__ = [
    "CACHE_FORMAT",
    "COSTATES",
    "SLIDES_CONVERGED",
    "TOL",
    "TransferSystems",
    "best_known_fuel",
    "calibrate_multiplier",
    "cartesian_track",
    "classify_on_scan",
    "energy_longitude_continuation",
    "energy_longitude_start",
    "energy_solutions",
    "energy_start",
    "energy_start_vector",
    "energy_time_continuation",
    "fuel_kg",
    "goal_met",
    "horizon_branches",
    "jacobian_check",
    "l1_runs",
    "minimum_time_continuation",
    "minimum_time_start",
    "minimum_time_versus_longitude",
    "minimum_times",
    "newton_path",
    "propellant_kg",
    "read_cache",
    "refine_minimum_time",
    "residual_noise",
    "scan_minima",
    "slides_conclusion",
    "solve_robustly",
    "switching_approach",
    "thrust_family",
    "thrust_magnitude",
    "thrust_schedule",
    "reusable_runs",
    "tolerance_runs",
    "versus_slides",
]
