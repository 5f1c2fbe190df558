"""Lots of runs (or units) of one gyro type with a known population: each run's
coefficients drawn from ``N(mean, between_sd**2)``, then a bench log simulated with them
(:mod:`gyroid.simulation._bench`). What pooling (:mod:`gyroid.pool._fit`) is checked
against."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.simulation._bench import (
    MagneticProtocol,
    SimulatedBench,
    ThermalProtocol,
    preset_parameters,
    simulate_magnetic_bench,
    simulate_thermal_bench,
)
from gyroid.simulation._noise import GyroNoise

#: Default between-run sd as a fraction of each coefficient's magnitude.
DEFAULT_SPREAD = 0.2


@dataclass(frozen=True)
class SimulatedLot:
    """Simulated runs with the population they were drawn from."""

    bench: str
    runs: tuple[SimulatedBench, ...]
    labels: tuple[str, ...]
    population_mean: dict[str, float]
    between_run_sd: dict[str, float]
    seed: int

    def truth(self) -> dict:
        """The lot's truth (``lot.json``): population and each run's coefficients."""
        return {"bench": self.bench, "runs": list(self.labels),
                "population_mean": self.population_mean,
                "between_run_sd": self.between_run_sd,
                "per_run": {label: run.truth["parameters"]
                            for label, run in zip(self.labels, self.runs, strict=True)},
                "seed": self.seed}


def simulate_lot(
    bench: str,
    n_runs: int,
    *,
    mean: Mapping[str, float] | None = None,
    between_sd: Mapping[str, float] | None = None,
    spread: float = DEFAULT_SPREAD,
    noise: GyroNoise | None = None,
    seed: int = 0,
    hours: float | None = None,
    rate_hz: float | None = None,
    average_s: float | None = None,
) -> SimulatedLot:
    """Simulate ``n_runs`` runs of paper A's ``bench`` ('thermal' or 'magnetic').

    ``mean``: the population's coefficients (default: the paper's, the preset's terms);
    ``between_sd``: their between-run sds (default ``spread`` times each mean's magnitude).
    Every run has its own noise stream; the draws of coefficients and noise are
    reproducible from ``seed``.
    """
    if bench not in ("thermal", "magnetic"):
        raise GyroidInputError(f"bench must be 'thermal' or 'magnetic', not {bench!r}")
    if n_runs < 1:
        raise GyroidInputError("a lot needs at least one run")
    if spread < 0:
        raise GyroidInputError("--spread must be >= 0")
    population = dict(preset_parameters(bench) if mean is None else mean)
    sds = {k: spread * abs(v) for k, v in population.items()}
    for name, value in (between_sd or {}).items():
        if name not in population:
            raise GyroidInputError(f"between-run sd of {name!r}: the lot has "
                                   f"{', '.join(population)}")
        if value < 0:
            raise GyroidInputError(f"between-run sd of {name} must be >= 0")
        sds[name] = float(value)
    seeds = np.random.SeedSequence(seed).spawn(n_runs + 1)
    rng = np.random.default_rng(seeds[0])
    names = list(population)
    coefficients = rng.standard_normal((n_runs, len(names)))
    if bench == "thermal":
        simulator = partial(simulate_thermal_bench,
                            protocol=ThermalProtocol().stretched(hours, rate_hz))
    else:
        simulator = partial(simulate_magnetic_bench,
                            protocol=MagneticProtocol().stretched(hours, rate_hz))
    width = max(2, len(str(n_runs)))
    labels = tuple(f"run_{i + 1:0{width}d}" for i in range(n_runs))
    runs = []
    for i in range(n_runs):
        values = {n: population[n] + sds[n] * coefficients[i, k] for k, n in enumerate(names)}
        run_seed = int(seeds[i + 1].generate_state(1)[0])
        runs.append(simulator(parameters=values, noise=noise,
                              seed=run_seed, average_s=average_s))
    return SimulatedLot(bench=bench, runs=tuple(runs), labels=labels,
                        population_mean={k: float(v) for k, v in population.items()},
                        between_run_sd={k: float(v) for k, v in sds.items()}, seed=seed)
