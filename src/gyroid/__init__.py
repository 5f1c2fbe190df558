"""gyroid: Bayesian identification of gyroscope error models.

Paper A's fibre-optic-gyro drift as a sum of named effects (temperature, its rate, magnetic
field, and candidate effects) and paper B's roll-gyro scale-factor correction loop: benches
and flights simulated with known truth, fits that check themselves, compensation,
propagation to the correction coefficient's error, and the discrepancy workflow. All models
run in JAX with float64.

``import gyroid`` loads nothing heavy and changes no global setting: each public name is
imported on first use, from the subpackage that holds it (``gyroid.models``,
``gyroid.io``, ``gyroid.simulation``, ``gyroid.inference``, ``gyroid.workflows``,
``gyroid.reports``, ...). Using a computing name turns on JAX's float64;
:func:`configure` also turns on the persistent compilation cache.
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version

#: Public name -> the subpackage it is imported from on first use.
_PUBLIC = {
    "configure": "gyroid._config",
    "GyroidInputError": "gyroid.errors",
    "UntrustworthyResult": "gyroid.errors",
    # effects and models
    "CANDIDATES": "gyroid.models", "EFFECTS": "gyroid.models", "PRESETS": "gyroid.models",
    "Effect": "gyroid.models", "Parameter": "gyroid.models", "DriftModel": "gyroid.models",
    "DriftInputs": "gyroid.models", "build_inputs": "gyroid.models",
    "resolve_terms": "gyroid.models", "ROLL_EFFECTS": "gyroid.models",
    "resolve_roll_terms": "gyroid.models",
    # logs
    "BenchLog": "gyroid.io", "load_bench_log": "gyroid.io", "write_bench_log": "gyroid.io",
    "RollLog": "gyroid.io", "load_roll_log": "gyroid.io", "FittedDrift": "gyroid.io",
    # simulation
    "simulate_thermal_bench": "gyroid.simulation", "simulate_magnetic_bench": "gyroid.simulation",
    "simulate_lot": "gyroid.simulation", "SimulatedBench": "gyroid.simulation",
    "SimulatedLot": "gyroid.simulation", "ThermalProtocol": "gyroid.simulation",
    "MagneticProtocol": "gyroid.simulation", "GyroNoise": "gyroid.simulation",
    # fits: one problem abstraction, one fit, interchangeable samplers, frozen results
    "fit": "gyroid.inference", "AbstractProblem": "gyroid.inference",
    "BenchProblem": "gyroid.inference", "RollProblem": "gyroid.inference",
    "PoolProblem": "gyroid.inference", "Emcee": "gyroid.inference", "Nuts": "gyroid.inference",
    "Importance": "gyroid.inference",
    "BenchFit": "gyroid.inference", "RollFit": "gyroid.inference", "PoolFit": "gyroid.inference",
    "fit_log": "gyroid.inference", "fit_roll_log": "gyroid.inference",
    "fit_pool": "gyroid.inference",
    # workflows
    "compensate": "gyroid.workflows", "propagate": "gyroid.workflows",
    "Propagation": "gyroid.workflows", "find_discrepancies": "gyroid.workflows",
    "Compensation": "gyroid.workflows", "DiscrepancyReport": "gyroid.workflows",
    "find_roll_discrepancies": "gyroid.workflows", "Scenario": "gyroid.workflows",
    "SCENARIOS": "gyroid.workflows",
    # writing results
    "write": "gyroid.reports",
}

__all__ = sorted(_PUBLIC)


def __getattr__(name: str):
    if name in _PUBLIC:
        value = getattr(importlib.import_module(_PUBLIC[name]), name)
        globals()[name] = value  # once imported, an ordinary attribute
        return value
    raise AttributeError(f"module 'gyroid' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_PUBLIC})


try:
    __version__ = version("gyroid")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"
