"""Public names of :mod:`gyroid.pool` for type checkers; at run time the package reads this
file (lazy_loader) and imports each name on first use."""

from ._fit import fit_pool as fit_pool
from ._fit import pool_estimates as pool_estimates
from ._fit import pool_problem as pool_problem
from ._problem import PoolProblem as PoolProblem
from ._result import PoolFit as PoolFit
