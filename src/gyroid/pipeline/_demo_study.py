"""The demo's study (:class:`Study`): each step of `gyroid demo` (simulate, fit, propagate,
discrepancy, compensate and reproduce, pool) writing its files and keeping its results
for the report (:mod:`gyroid.pipeline._demo_report`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from gyroid.bench._fit import fit_log
from gyroid.inference._importance import Importance
from gyroid.io._fitted import FittedDrift
from gyroid.io._log_writer import bench_log_text
from gyroid.io._outputs import json_text
from gyroid.models._derived import RATE_WINDOW_S
from gyroid.papers._classic import magnetic_k
from gyroid.plotting import (
    magnetic_sweep,
    save,
    thermal_run,
)
from gyroid.pool._fit import fit_pool
from gyroid.reports._reproduction import write_reproduction
from gyroid.reports._write import write
from gyroid.simulation._bench import (
    ThermalProtocol,
    simulate_magnetic_bench,
    simulate_thermal_bench,
)
from gyroid.simulation._lot import simulate_lot
from gyroid.workflows._compensate import compensate
from gyroid.workflows._discrepancy import find_discrepancies
from gyroid.workflows._propagate import propagate
from gyroid.workflows._scenarios import SCENARIOS


@dataclass(frozen=True)
class DemoSize:
    """How much work the demo does (the test suite runs a reduced one)."""

    propagate_draws: int = 2000
    sobol_samples: int = 1000
    discrepancy: bool = True
    lot_runs: int = 6  # runs of the pooled lot


@dataclass
class Study:
    """What the demo computed, step by step (each step writes its files in its folder)."""

    stage: Path
    seed: int
    size: DemoSize
    echo: Callable[[str], None]
    benches: dict = field(default_factory=dict)
    fits: dict = field(default_factory=dict)
    results: dict = field(default_factory=dict)

    def folder(self, name: str) -> Path:
        (self.stage / name).mkdir(parents=True, exist_ok=True)
        return self.stage / name

    def simulate(self) -> None:
        self.echo("[1/6] simulating paper A's benches ...")
        self.benches = {"thermal": simulate_thermal_bench(seed=self.seed),
                        "magnetic": simulate_magnetic_bench(seed=self.seed + 1)}
        for name, sim in self.benches.items():
            (self.folder(name) / "bench.csv").write_text(bench_log_text(sim.log.columns,
                                                                        sim.log.comments))
            (self.stage / name / "truth.json").write_text(json_text(sim.truth))
        thermal = self.benches["thermal"]
        save(thermal_run(thermal.log, np.asarray(thermal.log.inputs().rate_C_h),
                         thermal.true_drift_deg_h, rate_window_s=RATE_WINDOW_S),
             self.stage / "fig_thermal_run")

    def fit(self) -> None:
        self.echo("[2/6] fitting both benches (optimistix + importance sampling) ...")
        for name, terms in (("thermal", "thermal"), ("magnetic", "magnetic")):
            sim = self.benches[name]
            self.fits[name] = fit_log(sim.log, terms, seed=self.seed,
                                      sampler=Importance())
            write(self.folder(f"{name}/fit"), self.fits[name], truth=sim.truth["parameters"])
        magnetic, fit = self.benches["magnetic"], self.fits["magnetic"]
        # the model at the point estimate on every logged row (a fit of block means
        # predicts the means)
        theta = jnp.asarray([fit.point.value[name] for name in fit.model_names])
        model = fit.problem.model.predict(theta, magnetic.log.inputs(t0_C=fit.t0_C))
        save(magnetic_sweep(magnetic.log, np.asarray(model)), self.stage / "fig_magnetic_sweep")
        self.results["classic_k"] = {axis: magnetic_k(magnetic.log, axis) for axis in "xyz"}

    def propagate(self) -> None:
        self.echo("[3/6] propagating the thermal fit to paper B's dK ...")
        fitted = FittedDrift.from_dir(self.stage / "thermal" / "fit")
        self.results["fitted"] = fitted
        self.results["scenario"] = SCENARIOS["paper_b_worked"]
        propagation = propagate(fitted, self.results["scenario"],
                                draws=self.size.propagate_draws, seed=self.seed,
                                sobol_n=self.size.sobol_samples)
        write(self.folder("propagate"), propagation)
        self.results["propagation"] = propagation

    def discrepancy(self) -> None:
        if not self.size.discrepancy:
            self.echo("[4/6] discrepancy workflow skipped (reduced demo)")
            return
        self.echo("[4/6] discrepancy workflow on a log with a hidden effect ...")
        hidden = simulate_magnetic_bench(
            seed=self.seed + 2,
            effects={"magnetic_hysteresis": {"hys_x": 0.0, "hys_y": 0.04, "hys_z": 0.06}})
        report = find_discrepancies(hidden.log, "magnetic")
        folder = self.folder("discrepancy")
        (folder / "bench.csv").write_text(bench_log_text(hidden.log.columns,
                                                         hidden.log.comments))
        write(folder, report)
        self.results["discrepancy"] = report

    def compensate_and_reproduce(self) -> None:
        self.echo("[5/6] compensating a second thermal run and reproducing both papers ...")
        second = simulate_thermal_bench(
            seed=self.seed + 3, protocol=ThermalProtocol(setpoints_C=(28.0, 36.0, 44.0, 52.0)))
        self.results["compensation"] = compensate(second.log, self.results["fitted"])
        write(self.folder("compensate"), self.results["compensation"])
        self.results["reproduction"] = write_reproduction(self.folder("reproduce"))

    def pool(self) -> None:
        runs = self.size.lot_runs
        self.echo(f"[6/6] pooling a lot of {runs} magnetic runs ...")
        lot = simulate_lot("magnetic", runs, seed=self.seed + 4, hours=0.5)
        pooled = fit_pool([r.log for r in lot.runs], lot.labels, "magnetic", seed=self.seed)
        write(self.folder("pool"), pooled, title=f"{runs} simulated magnetic runs pooled",
              truth=lot.truth())
        (self.stage / "pool" / "lot.json").write_text(json_text(lot.truth()))
        self.results["lot"], self.results["pooled"] = lot, pooled
