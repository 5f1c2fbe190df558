"""What a gyro is made of: the effect registries (bench and roll), the drift and roll-loop
physics, derived inputs, priors.

Importing this package (as every computing part of gyroid does) turns on JAX's float64:
see :mod:`gyroid._config`.
"""

from gyroid._config import enable_float64 as _enable_float64

_enable_float64()

from gyroid.models._derived import (  # noqa: E402
    HYSTERESIS_DEADBAND_UT,
    RATE_WINDOW_S,
    field_change_sign,
    lagged_temperature,
    temperature_rate_deg_c_per_h,
)
from gyroid.models._design import (  # noqa: E402
    BLOCK_ROWS,
    least_squares_from_r,
    row_blocks,
    with_rows,
)
from gyroid.models._drift import (  # noqa: E402
    DriftModel,
)
from gyroid.models._effects import (  # noqa: E402
    CANDIDATES,
    EFFECTS,
    EXTRA_PREFIX,
    PARAMETERS,
    Effect,
    Parameter,
    effect,
    parameter,
)
from gyroid.models._inputs import (  # noqa: E402
    FIELD_COLUMNS,
    H0_UT,
    T0_C,
    DriftInputs,
    build_inputs,
    inputs_from_arrays,
)
from gyroid.models._paper_b import (  # noqa: E402
    G,
)
from gyroid.models._priors import (  # noqa: E402
    Flat,
    HalfNormal,
    LogNormal,
    Normal,
    Prior,
)
from gyroid.models._roll import (  # noqa: E402
    Flight,
    RollParams,
    constant_flight,
    correction_coefficients,
    navigation_errors,
    run_loop,
)
from gyroid.models._roll_effects import (  # noqa: E402
    ROLL_EFFECTS,
    ROLL_PRESETS,
    resolve_roll_terms,
)
from gyroid.models._terms import (  # noqa: E402
    PRESETS,
    resolve_terms,
)

__all__ = [
    "BLOCK_ROWS",
    "CANDIDATES",
    "DriftInputs",
    "DriftModel",
    "EFFECTS",
    "EXTRA_PREFIX",
    "Effect",
    "FIELD_COLUMNS",
    "Flat",
    "Flight",
    "G",
    "H0_UT",
    "HYSTERESIS_DEADBAND_UT",
    "HalfNormal",
    "LogNormal",
    "Normal",
    "PARAMETERS",
    "PRESETS",
    "Parameter",
    "Prior",
    "RATE_WINDOW_S",
    "ROLL_EFFECTS",
    "ROLL_PRESETS",
    "RollParams",
    "T0_C",
    "build_inputs",
    "constant_flight",
    "correction_coefficients",
    "effect",
    "field_change_sign",
    "inputs_from_arrays",
    "lagged_temperature",
    "least_squares_from_r",
    "navigation_errors",
    "parameter",
    "resolve_roll_terms",
    "resolve_terms",
    "row_blocks",
    "run_loop",
    "temperature_rate_deg_c_per_h",
    "with_rows",
]
