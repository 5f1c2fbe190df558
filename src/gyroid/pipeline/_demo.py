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
from pathlib import Path

from gyroid._config import enable_float64, one_core_environment, use_compilation_cache
from gyroid.io._outputs import output_dir
from gyroid.pipeline._demo_report import SECTIONS, Report
from gyroid.pipeline._demo_study import DemoSize, Study


def _side_steps(stage: Path, seed: int, size: DemoSize, cache: str | None) -> dict:
    """The steps that need no fit (discrepancy, pooling), run in a second process: JAX set
    up as in the first (float64, its compilation cache), silent; returns their results."""
    enable_float64()
    if cache:
        use_compilation_cache(cache)
    study = Study(stage, seed, size, lambda _message: None)
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
        study = Study(stage, seed, size, echo)
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


def _run_in_two_processes(study: Study) -> None:
    """The discrepancy workflow and the pooled lot in a spawned process on one core
    (:func:`gyroid._config.one_core_environment`), the other steps here. If no
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
        with pool:
            study.echo("[4/6] and [6/6] (the discrepancy workflow and the pooled lot) run "
                       "in a second process ...")
            before = set(multiprocessing.active_children())
            # The one-core environment for the child only: it is spawned inside submit and
            # keeps the environment it started with. Left set while this process compiles,
            # it put XLA_FLAGS that this process's XLA (started earlier) does not run with
            # into the keys of the programs it cached, for a process that does run with them
            # to load (the likely cause of a segmentation fault seen under pytest-xdist).
            with one_core_environment():
                side = pool.submit(_side_steps, study.stage, study.seed, study.size,
                                   jax.config.values["jax_compilation_cache_dir"])
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
