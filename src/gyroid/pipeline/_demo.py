"""`gyroid demo`: the whole study on built-in data, written as a report a researcher reads.

Paper A's benches simulated with known truth and fitted (optimistix + emcee); paper A's
classic estimators beside the Bayesian ones; the fitted gyro pushed through paper B's
correction loop to dK; the discrepancy workflow on a log with a hidden effect; both papers'
tables reproduced and audited.

The steps that need no fit (the discrepancy workflow and the pooled lot) run in a second
process beside the others when the machine has two cores, each process on one core (their
thread pools otherwise contend: each step ran ~1.4x slower and the pair gained little).
Measured on two cores (``benchmarks/results_demo.json``): 64 s -> 52 s cold and
37 s -> 22 s warm, for 2.3 GB in the two processes together against 1.5 GB in one.
"""

from __future__ import annotations

import multiprocessing
import os
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from gyroid._config import enable_float64, one_core_environment, use_compilation_cache
from gyroid.inference._bench_fit import fit_log
from gyroid.inference._emcee import Emcee
from gyroid.inference._pool_fit import fit_pool
from gyroid.io._fitted import FittedDrift
from gyroid.io._log_writer import bench_log_text
from gyroid.io._outputs import json_text, output_dir
from gyroid.models._derived import RATE_WINDOW_S
from gyroid.papers._classic import magnetic_k
from gyroid.pipeline._demo_report import SECTIONS, Report
from gyroid.plotting import (
    magnetic_sweep,
    save,
    thermal_run,
)
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
from gyroid.workflows._scenarios import PRESETS


@dataclass(frozen=True)
class DemoSize:
    """How much work the demo does (the test suite runs a reduced one)."""

    propagate_draws: int = 2000
    sobol_samples: int = 1000
    discrepancy: bool = True


@dataclass
class _Study:
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
        self.echo("[2/6] fitting both benches (optimistix + emcee) ...")
        for name, terms in (("thermal", "thermal"), ("magnetic", "magnetic")):
            sim = self.benches[name]
            self.fits[name] = fit_log(sim.log, terms, seed=self.seed, noise="auto",
                                      sampler=Emcee(progress=False))
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
        self.results["scenario"] = PRESETS["paper_b_worked"]
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
        self.echo("[6/6] pooling a lot of six magnetic runs ...")
        lot = simulate_lot("magnetic", 6, seed=self.seed + 4, hours=0.5)
        pooled = fit_pool([r.log for r in lot.runs], lot.labels, "magnetic", seed=self.seed)
        write(self.folder("pool"), pooled, title="Six simulated magnetic runs pooled",
              truth=lot.truth())
        (self.stage / "pool" / "lot.json").write_text(json_text(lot.truth()))
        self.results["lot"], self.results["pooled"] = lot, pooled


def _side_steps(stage: Path, seed: int, size: DemoSize, cache: str | None) -> dict:
    """The steps that need no fit (discrepancy, pooling), run in a second process: JAX set
    up as in the first (float64, its compilation cache), silent; returns their results."""
    enable_float64()
    if cache:
        use_compilation_cache(cache)
    study = _Study(stage, seed, size, lambda _message: None)
    study.discrepancy()
    study.pool()
    return study.results


def run_demo(out: str | Path, *, seed: int = 0, echo: Callable[[str], None] = print,
             size: DemoSize | None = None, processes: int | None = None) -> Path:
    """Run the demo study into ``out``; returns the path of ``report.md``. ``processes``:
    2 runs the steps that need no fit in a second process (the default on a machine with
    two cores or more), 1 runs every step in this one."""
    out = Path(out)
    started = time.time()
    size = size or DemoSize()
    if processes is None:
        processes = 2 if (os.cpu_count() or 1) >= 2 else 1
    with output_dir(out) as stage:
        study = _Study(stage, seed, size, echo)
        if processes >= 2:
            _run_in_two_processes(study)
        else:
            for step in (study.simulate, study.fit, study.propagate, study.discrepancy,
                         study.compensate_and_reproduce, study.pool):
                step()
        report = Report()
        for section in SECTIONS:
            section(report, study)
        report.add("", f"*Run time {time.time() - started:.0f} s.*", "")
        (stage / "report.md").write_text(report.text())
    return out / "report.md"


def _run_in_two_processes(study: _Study) -> None:
    """The discrepancy workflow and the pooled lot in a spawned process, the other steps
    here, each process on one core (:func:`gyroid._config.one_core_environment`). If no
    second process can be started, or it dies (killed, out of memory), its steps run here;
    if a step here fails, the second process is stopped, not waited for."""
    import jax

    main_steps = (study.simulate, study.fit, study.propagate, study.compensate_and_reproduce)
    try:
        pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"))
    except (OSError, NotImplementedError, ImportError) as error:  # e.g. no POSIX semaphores
        study.echo(f"no second process ({error}); running every step here ...")
        pool = None
    if pool is not None:
        with one_core_environment(), pool:
            study.echo("[4/6] and [6/6] (the discrepancy workflow and the pooled lot) run "
                       "in a second process ...")
            before = set(multiprocessing.active_children())
            side = pool.submit(_side_steps, study.stage, study.seed, study.size,
                               jax.config.jax_compilation_cache_dir)
            try:
                for step in main_steps:
                    step()
            except BaseException:
                for child in set(multiprocessing.active_children()) - before:
                    child.terminate()
                raise
            try:
                study.results.update(side.result())
                return
            except BrokenProcessPool as error:
                study.echo(f"the second process stopped ({error}); running its steps here ...")
    else:
        for step in main_steps:
            step()
    study.discrepancy()
    study.pool()
