"""Small array helpers used on the build path."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def unique(values: ArrayLike) -> np.ndarray:
    """The sorted distinct entries of ``values`` (flattened), as ``np.unique(values)``.

    NumPy 2.4's ``np.unique`` imports ``numpy.ma`` on its first plain call (about 20 ms, once per process), which
    is most of what separates a short solve by ocpkit from the same NLP in plain CasADi; this sort-and-compare
    does not. Unlike ``np.unique`` it keeps every NaN (NaN differs from itself); its callers' values are integers
    and finite numbers.
    """
    a = np.sort(np.asarray(values).ravel())
    if a.size == 0:
        return a
    keep = np.empty(a.size, dtype=bool)
    keep[0] = True
    np.not_equal(a[1:], a[:-1], out=keep[1:])
    return a[keep]
