"""What a gyro is made of: the effect registries (bench and roll), the drift and roll-loop
physics, derived inputs, priors.

Importing this package (as every computing part of gyroid does) turns on JAX's float64:
see :mod:`gyroid._config`.
"""

from gyroid._config import enable_float64 as _enable_float64
from gyroid._lazy import attach

_enable_float64()

__getattr__, __dir__, __all__ = attach(__name__, {
    "_derived": [
        "HYSTERESIS_DEADBAND_UT", "RATE_WINDOW_S", "lagged_temperature",
        "temperature_rate_deg_c_per_h",
    ],
    "_change_signs": ["field_change_sign", "temperature_change_sign"],
    "_design": ["BLOCK_ROWS", "least_squares_from_r", "row_blocks", "with_rows"],
    "_drift": ["DriftModel"],
    "_effects": [
        "CANDIDATES", "EFFECTS", "EXTRA_PREFIX", "PARAMETERS", "Effect", "Parameter", "effect",
        "parameter",
    ],
    "_inputs": [
        "FIELD_COLUMNS", "H0_UT", "T0_C", "DriftInputs", "build_inputs", "inputs_from_arrays",
    ],
    "_paper_b": ["G"],
    "_priors": ["Flat", "HalfNormal", "LogNormal", "Normal", "Prior"],
    "_roll": [
        "Flight", "RollParams", "constant_flight", "correction_coefficients", "navigation_errors",
        "run_loop",
    ],
    "_roll_effects": ["ROLL_EFFECTS", "ROLL_PRESETS", "resolve_roll_terms"],
    "_terms": ["PRESETS", "resolve_terms"],
})
