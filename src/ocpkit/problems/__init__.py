"""Test problems, each reading its constants from ``data/problems``."""

from ._data import load_problem_data
from .flat_moon import flat_moon_ascent, linear_tangent_solution
from .lunar_ascent import lunar_ascent, lunar_ascent_constants, smoothing_study

__all__ = [
    "flat_moon_ascent",
    "linear_tangent_solution",
    "load_problem_data",
    "lunar_ascent",
    "lunar_ascent_constants",
    "smoothing_study",
]
