"""The published record as the chain's cache (every digit kept), and a recorded transfer as a 3-D track."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ...paths import published_derived_dir
from ...problems.orbit_transfer import equinoctial_to_cartesian, orbit_transfer_constants

#: the caches keep every digit: a run from the cache continues from exactly the published solutions
CACHE_FORMAT = "%.17g"


def read_cache(name: str) -> pd.DataFrame | None:
    """A cached table of the published record, the repository's ``data/derived`` (None if absent)."""
    path = published_derived_dir() / f"{name}.csv"
    return pd.read_csv(path) if path.is_file() else None


def cartesian_track(trajectory, system, points: int = 20000):
    """A recorded transfer on a fine time grid: ``(t, positions (Mm), thrust_on)`` for plotting.

    The equinoctial elements, smooth between the recorded points, are interpolated
    linearly (the longitude too: it grows smoothly) and converted to Cartesian
    positions. The thrust switches on or off at each recorded switching (one switching
    function, |u| in {0, 1}); ``system`` (the :class:`HamiltonianSystem`) gives the
    control at the start.
    """
    mu = orbit_transfer_constants()["mu_Mm3_h2"]
    t_rec = trajectory.step_times
    t = np.linspace(t_rec[0], t_rec[-1], points)
    elements = np.array([np.interp(t, t_rec, trajectory.states[:, i]) for i in range(6)])
    pos = np.stack(equinoctial_to_cartesian(elements, mu)[0], axis=-1)
    y0, P = trajectory.states[0], trajectory.parameters
    on_at_start = float(np.linalg.norm(np.asarray(system.control(y0, system.mode_at(y0, P), P)))) > 0.5
    flips = np.searchsorted(trajectory.switching_times, t, side="right")
    return t, pos, (flips % 2 == 1) != on_at_start
