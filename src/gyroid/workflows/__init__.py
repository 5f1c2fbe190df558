"""What a user runs on a fit or a log: discrepancy (bench and roll, one loop), compensation,
propagation to dK, sensitivity, Allan deviation.
"""

from gyroid.workflows._allan import (
    AllanDeviation,
    allan_deviation,
)
from gyroid.workflows._compensate import (
    Compensation,
    compensate,
)
from gyroid.workflows._discrepancy import (
    find_discrepancies,
)
from gyroid.workflows._discrepancy_report import (
    DiscrepancyReport,
)
from gyroid.workflows._propagate import (
    Propagation,
    propagate,
)
from gyroid.workflows._residual_structure import (
    where_largest,
)
from gyroid.workflows._roll_discrepancy import (
    find_roll_discrepancies,
)
from gyroid.workflows._scenarios import (
    PRESETS as SCENARIOS,
)
from gyroid.workflows._scenarios import (
    Scenario,
    load_scenario,
)
from gyroid.workflows._sensitivity import (
    sobol_indices,
)

__all__ = [
    "AllanDeviation",
    "Compensation",
    "DiscrepancyReport",
    "Propagation",
    "SCENARIOS",
    "Scenario",
    "allan_deviation",
    "compensate",
    "find_discrepancies",
    "find_roll_discrepancies",
    "load_scenario",
    "propagate",
    "sobol_indices",
    "where_largest",
]
