"""Public names of :mod:`gyroid.workflows` for type checkers; at run time the package reads this
file (lazy_loader) and imports each name on first use."""

from ._allan import AllanDeviation as AllanDeviation
from ._allan import allan_deviation as allan_deviation
from ._compensate import Compensation as Compensation
from ._compensate import compensate as compensate
from ._discrepancy import find_discrepancies as find_discrepancies
from ._discrepancy_report import DiscrepancyReport as DiscrepancyReport
from ._propagate import Propagation as Propagation
from ._propagate import propagate as propagate
from ._residual_structure import where_largest as where_largest
from ._roll_discrepancy import find_roll_discrepancies as find_roll_discrepancies
from ._scenarios import SCENARIOS as SCENARIOS
from ._scenarios import Scenario as Scenario
from ._scenarios import load_scenario as load_scenario
from ._sensitivity import sobol_indices as sobol_indices
