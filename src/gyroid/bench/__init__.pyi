"""Public names of :mod:`gyroid.bench` for type checkers; at run time the package reads this
file (lazy_loader) and imports each name on first use."""

from ._density import BenchDensity as BenchDensity
from ._fit import fit_log as fit_log
from ._options import BenchOptions as BenchOptions
from ._problem import BenchProblem as BenchProblem
from ._rate_window import choose_rate_window as choose_rate_window
from ._result import BenchFit as BenchFit
from ._starts import START_MULTIPLES as START_MULTIPLES
from ._starts import grid_points as grid_points
from ._starts import start_grid as start_grid
