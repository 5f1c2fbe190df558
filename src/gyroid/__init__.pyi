"""Public names of :mod:`gyroid` for type checkers; at run time the package reads this file
(lazy_loader) and imports each name on first use, from the subpackage that holds it."""

from ._config import configure as configure
from .errors import GyroidInputError as GyroidInputError
from .errors import UntrustworthyResult as UntrustworthyResult
from .inference import AbstractProblem as AbstractProblem
from .inference import BenchFit as BenchFit
from .inference import BenchOptions as BenchOptions
from .inference import BenchProblem as BenchProblem
from .inference import Emcee as Emcee
from .inference import Importance as Importance
from .inference import Nuts as Nuts
from .inference import PoolFit as PoolFit
from .inference import PoolProblem as PoolProblem
from .inference import RollFit as RollFit
from .inference import RollProblem as RollProblem
from .inference import fit as fit
from .inference import fit_log as fit_log
from .inference import fit_pool as fit_pool
from .inference import fit_roll_log as fit_roll_log
from .io import BenchLog as BenchLog
from .io import FittedDrift as FittedDrift
from .io import RollLog as RollLog
from .io import load_bench_log as load_bench_log
from .io import load_roll_log as load_roll_log
from .io import write_bench_log as write_bench_log
from .models import CANDIDATES as CANDIDATES
from .models import EFFECTS as EFFECTS
from .models import PRESETS as PRESETS
from .models import ROLL_EFFECTS as ROLL_EFFECTS
from .models import DriftInputs as DriftInputs
from .models import DriftModel as DriftModel
from .models import Effect as Effect
from .models import Parameter as Parameter
from .models import build_inputs as build_inputs
from .models import resolve_roll_terms as resolve_roll_terms
from .models import resolve_terms as resolve_terms
from .reports import write as write
from .simulation import GyroNoise as GyroNoise
from .simulation import MagneticProtocol as MagneticProtocol
from .simulation import SimulatedBench as SimulatedBench
from .simulation import SimulatedLot as SimulatedLot
from .simulation import ThermalProtocol as ThermalProtocol
from .simulation import simulate_lot as simulate_lot
from .simulation import simulate_magnetic_bench as simulate_magnetic_bench
from .simulation import simulate_thermal_bench as simulate_thermal_bench
from .workflows import SCENARIOS as SCENARIOS
from .workflows import Compensation as Compensation
from .workflows import DiscrepancyReport as DiscrepancyReport
from .workflows import Propagation as Propagation
from .workflows import Scenario as Scenario
from .workflows import compensate as compensate
from .workflows import find_discrepancies as find_discrepancies
from .workflows import find_roll_discrepancies as find_roll_discrepancies
from .workflows import propagate as propagate

__version__: str
