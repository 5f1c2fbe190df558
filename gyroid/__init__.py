"""gyroid: Bayesian identification of gyroscope error models.

Paper A's fibre-optic-gyro drift as a sum of named effects (temperature, its rate, magnetic
field, and candidate effects) and paper B's roll-gyro scale-factor correction loop: benches
and flights simulated with known truth, fits that check themselves, compensation,
propagation to the correction coefficient's error, and the discrepancy workflow. All models
run in JAX with float64.

The public surface, by job (each name's module is where it lives):

* effects and models: ``EFFECTS``, ``PRESETS``, ``CANDIDATES``, ``Effect``, ``Parameter``,
  ``resolve_terms``, ``DriftModel``; ``ROLL_EFFECTS``, ``resolve_roll_terms``;
* logs: ``BenchLog``, ``load_bench_log``, ``write_bench_log``, ``RollLog``,
  ``load_roll_log``;
* simulation: ``simulate_thermal_bench``, ``simulate_magnetic_bench``, ``simulate_lot``,
  ``GyroNoise``;
* workflows: ``fit_log``, ``fit_roll_log``, ``fit_pool``, ``compensate``, ``propagate``
  (a ``Propagation``), ``find_discrepancies``, ``find_roll_discrepancies``;
* results read back: ``FittedDrift``; scenarios: ``Scenario``, ``SCENARIOS``.
"""

import os
from importlib.metadata import PackageNotFoundError, version

import jax

jax.config.update("jax_enable_x64", True)


def _persistent_compilation_cache() -> None:
    """JAX's persistent compilation cache in the user's cache folder, so that a command
    reuses the programs an earlier one compiled. ``GYROID_JAX_CACHE=off`` turns it off, a
    path moves it; JAX's own ``JAX_COMPILATION_CACHE_DIR`` wins when set."""
    setting = os.environ.get("GYROID_JAX_CACHE", "").strip()
    if setting.lower() in ("off", "0", "no", "false") or os.environ.get(
            "JAX_COMPILATION_CACHE_DIR"):
        return
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    jax.config.update("jax_compilation_cache_dir", setting or os.path.join(base, "gyroid", "jax"))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)


_persistent_compilation_cache()

from gyroid.errors import GyroidInputError  # noqa: E402
from gyroid.io.logs import BenchLog, load_bench_log, write_bench_log  # noqa: E402
from gyroid.io.roll_log import RollLog, load_roll_log  # noqa: E402
from gyroid.models.drift import DriftModel  # noqa: E402
from gyroid.models.effects import CANDIDATES, EFFECTS, Effect, Parameter  # noqa: E402
from gyroid.models.inputs import DriftInputs, build_inputs  # noqa: E402
from gyroid.models.roll_effects import ROLL_EFFECTS, resolve_roll_terms  # noqa: E402
from gyroid.models.terms import PRESETS, resolve_terms  # noqa: E402
from gyroid.simulation.bench import (  # noqa: E402
    MagneticProtocol,
    SimulatedBench,
    ThermalProtocol,
    simulate_magnetic_bench,
    simulate_thermal_bench,
)
from gyroid.simulation.lot import SimulatedLot, simulate_lot  # noqa: E402
from gyroid.simulation.noise import GyroNoise  # noqa: E402

#: Imported on first use (the workflows pull in emcee, ArviZ and plotting; the command line
#: stays quick to start): public name -> (module, name there).
_LAZY = {
    "compensate": ("gyroid.workflows.compensate", "compensate"),
    "find_discrepancies": ("gyroid.workflows.discrepancy", "find_discrepancies"),
    "fit_log": ("gyroid.inference.fit", "fit_log"),
    "fit_pool": ("gyroid.workflows.pool", "fit_pool"),
    "PoolResult": ("gyroid.workflows.pool_result", "PoolResult"),
    "Propagation": ("gyroid.workflows.propagate", "Propagation"),
    "FittedDrift": ("gyroid.io.fitted", "FittedDrift"),
    "propagate": ("gyroid.workflows.propagate", "propagate"),
    "find_roll_discrepancies": ("gyroid.workflows.roll_discrepancy", "find_roll_discrepancies"),
    "fit_roll_log": ("gyroid.inference.roll_fit", "fit_roll_log"),
    "SCENARIOS": ("gyroid.workflows.scenarios", "PRESETS"),
    "Scenario": ("gyroid.workflows.scenarios", "Scenario"),
}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        module, attribute = _LAZY[name]
        return getattr(importlib.import_module(module), attribute)
    raise AttributeError(f"module 'gyroid' has no attribute {name!r}")


try:
    __version__ = version("gyroid")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"

__all__ = [
    "CANDIDATES",
    "EFFECTS",
    "PRESETS",
    "ROLL_EFFECTS",
    "SCENARIOS",
    "BenchLog",
    "DriftInputs",
    "DriftModel",
    "Effect",
    "FittedDrift",
    "GyroNoise",
    "GyroidInputError",
    "MagneticProtocol",
    "Parameter",
    "PoolResult",
    "Propagation",
    "RollLog",
    "Scenario",
    "SimulatedBench",
    "SimulatedLot",
    "ThermalProtocol",
    "build_inputs",
    "compensate",
    "find_discrepancies",
    "find_roll_discrepancies",
    "fit_log",
    "fit_pool",
    "fit_roll_log",
    "load_bench_log",
    "load_roll_log",
    "propagate",
    "resolve_roll_terms",
    "resolve_terms",
    "simulate_lot",
    "simulate_magnetic_bench",
    "simulate_thermal_bench",
    "write_bench_log",
]
