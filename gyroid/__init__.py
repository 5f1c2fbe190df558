"""gyroid: Bayesian identification of gyroscope error models.

Paper A's fibre-optic-gyro drift as a sum of named effects (temperature, its rate, magnetic
field, and candidate effects), paper A's benches simulated with known truth, and the tools
to fit, compensate and check them. All models run in JAX with float64.
"""

import jax

jax.config.update("jax_enable_x64", True)

from gyroid.bench import (  # noqa: E402
    MagneticProtocol,
    SimulatedBench,
    ThermalProtocol,
    simulate_magnetic_bench,
    simulate_thermal_bench,
)
from gyroid.drift import DriftModel  # noqa: E402
from gyroid.effects import CANDIDATES, EFFECTS, PRESETS, Effect, Parameter, resolve_terms  # noqa: E402
from gyroid.errors import GyroidInputError  # noqa: E402
from gyroid.inputs import DriftInputs, build_inputs  # noqa: E402
from gyroid.logs import BenchLog, load_bench_log, write_bench_log  # noqa: E402
from gyroid.noise import GyroNoise  # noqa: E402

__version__ = "0.1.0"

__all__ = [
    "CANDIDATES",
    "EFFECTS",
    "PRESETS",
    "BenchLog",
    "DriftInputs",
    "DriftModel",
    "Effect",
    "GyroNoise",
    "GyroidInputError",
    "MagneticProtocol",
    "Parameter",
    "SimulatedBench",
    "ThermalProtocol",
    "build_inputs",
    "load_bench_log",
    "resolve_terms",
    "simulate_magnetic_bench",
    "simulate_thermal_bench",
    "write_bench_log",
]
