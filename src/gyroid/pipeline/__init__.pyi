"""Public names of :mod:`gyroid.pipeline` for type checkers; at run time the package reads this
file (lazy_loader) and imports each name on first use."""

from ._batch import BatchResult as BatchResult
from ._batch import LogOutcome as LogOutcome
from ._batch import run_batch as run_batch
from ._demo import run_demo as run_demo
from ._demo_study import DemoSize as DemoSize
from ._fit_file import FitOptions as FitOptions
from ._fit_file import fit_file as fit_file
