"""The solve policy, by its module's name before the program (:class:`~ocpkit.program.Program`) owned it: it is
:mod:`ocpkit.program.solve` (its :class:`MeshIteration` and stall constants are re-exported here)."""

from ..program.solve import STALL_FALL as STALL_FALL
from ..program.solve import STALL_GROWTH as STALL_GROWTH
from ..program.solve import STALL_MESHES as STALL_MESHES
from ..program.solve import MeshIteration as MeshIteration
