"""The statement of an optimal control problem, independent of any transcription.

One module per idea: :mod:`~ocpkit.statement.bounds` (boundary conditions and guesses as given, and their parsers),
:mod:`~ocpkit.statement.variables` (states, controls, free parameters and their NLP scaling),
:mod:`~ocpkit.statement.times` (free initial and final times, durations), :mod:`~ocpkit.statement.constraints`
(path and boundary constraints), :mod:`~ocpkit.statement.functions` (the compiled functions and the Hamiltonian),
:mod:`~ocpkit.statement.symbols` (compiling the user's callables), :mod:`~ocpkit.statement.problem` (the
single-phase problem), :mod:`~ocpkit.statement.guess` (an initial guess) and :mod:`~ocpkit.statement.phases`
(several phases, their links and the trajectory's cost, constraints and parameters).
"""

from .bounds import Bound, GuessSpec, fixed_value, guess_function
from .constraints import Constraint, ConstraintSet
from .functions import Hamiltonian, ProblemFunctions
from .guess import Guess
from .problem import OptimalControlProblem
from .times import Duration, FreeFinalTime, FreeInitialTime
from .variables import (
    AffineScaling,
    Control,
    FreeParameter,
    State,
    Variable,
    declared_turn,
    unwrap_periodic,
    wrap_periodic,
)

__all__ = [
    "AffineScaling",
    "Bound",
    "Constraint",
    "ConstraintSet",
    "Control",
    "Duration",
    "FreeFinalTime",
    "FreeInitialTime",
    "FreeParameter",
    "Guess",
    "GuessSpec",
    "Hamiltonian",
    "OptimalControlProblem",
    "ProblemFunctions",
    "State",
    "Variable",
    "declared_turn",
    "fixed_value",
    "guess_function",
    "unwrap_periodic",
    "wrap_periodic",
]
