"""What a user runs on a fit or a log: discrepancy (bench and roll, one loop), compensation,
propagation to dK, sensitivity, Allan deviation.
"""

from gyroid._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "_allan": ["AllanDeviation", "allan_deviation"],
    "_compensate": ["Compensation", "compensate"],
    "_discrepancy": ["find_discrepancies"],
    "_discrepancy_report": ["DiscrepancyReport"],
    "_propagate": ["Propagation", "propagate"],
    "_residual_structure": ["where_largest"],
    "_roll_discrepancy": ["find_roll_discrepancies"],
    "_scenarios": ["PRESETS as SCENARIOS", "Scenario", "load_scenario"],
    "_sensitivity": ["sobol_indices"],
})
