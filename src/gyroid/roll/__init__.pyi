"""Public names of :mod:`gyroid.roll` for type checkers; at run time the package reads this
file (lazy_loader) and imports each name on first use."""

from ._density import ALL_PARAMETERS as ALL_PARAMETERS
from ._fit import fit_roll_log as fit_roll_log
from ._problem import RollProblem as RollProblem
from ._result import RollFit as RollFit
