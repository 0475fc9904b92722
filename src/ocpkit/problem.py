"""The single-phase problem and its parts, by their names before :mod:`ocpkit.statement` split them by idea.

Every name here is its :mod:`ocpkit.statement` module's (``from ocpkit.problem import State`` keeps working); new
code imports from ``ocpkit`` or :mod:`ocpkit.statement`.
"""

from .statement.bounds import Bound as Bound
from .statement.bounds import GuessSpec as GuessSpec
from .statement.bounds import fixed_value as fixed_value
from .statement.bounds import guess_function as guess_function
from .statement.constraints import Constraint as Constraint
from .statement.constraints import ConstraintSet as ConstraintSet
from .statement.constraints import checked_constraints as checked_constraints
from .statement.functions import Hamiltonian as Hamiltonian
from .statement.functions import ProblemFunctions as ProblemFunctions
from .statement.guess import Guess as Guess
from .statement.problem import OptimalControlProblem as OptimalControlProblem
from .statement.symbols import StatementSymbols as StatementSymbols
from .statement.times import Duration as Duration
from .statement.times import FreeFinalTime as FreeFinalTime
from .statement.times import FreeInitialTime as FreeInitialTime
from .statement.variables import AffineScaling as AffineScaling
from .statement.variables import Control as Control
from .statement.variables import FreeParameter as FreeParameter
from .statement.variables import State as State
from .statement.variables import Variable as Variable
from .statement.variables import unwrap_periodic as unwrap_periodic
