"""Shared plumbing of the experiment scripts: where results go, and the run record."""

from __future__ import annotations

import json
import math
import shlex
import sys
import time
from pathlib import Path

import numpy as np

import gyroid
from gyroid.bench import BenchOptions
from gyroid.io import atomic_write_text, json_text

RESULTS = Path(__file__).resolve().parent / "results"


def results_dir(name: str) -> Path:
    folder = RESULTS / name
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def save_run(folder: Path, *, seed: int, config: dict, results: dict, started: float) -> None:
    """Write results.json with the command, config, seed, gyroid version and wall time."""
    record = {
        "command": " ".join(shlex.quote(a) for a in [sys.executable, *sys.argv]),
        "seed": seed,
        "config": config,
        "gyroid_version": gyroid.__version__,
        "seconds": round(time.time() - started, 1),
        "results": results,
    }
    atomic_write_text(folder / "results.json", json_text(record))
    print(json.dumps(results, indent=2)[:4000])


def fitted_thermal(seed: int):
    """A thermal bench simulated with paper A's truth, fitted (emcee), as a FittedDrift."""
    from gyroid.bench import fit_log
    from gyroid.inference import Emcee
    from gyroid.simulation import simulate_thermal_bench

    sim = simulate_thermal_bench(seed=seed)
    fit = fit_log(sim.log, "thermal", BenchOptions(noise="white"), seed=seed,
                  sampler=Emcee(progress=False))
    return fit.fitted_drift()


def gauss_markov_sum(rng: np.random.Generator, n: int, dt: float, taus, variance: float
                     ) -> np.ndarray:
    """The sum of first-order Gauss-Markov processes of correlation times ``taus`` (s), each
    of ``variance`` and started stationary, at ``n`` steps of ``dt`` (s)."""
    from scipy import signal

    out = np.zeros(n)
    for tau in taus:
        phi = math.exp(-dt / tau)
        start = math.sqrt(variance) * rng.standard_normal()
        steps = math.sqrt(variance * (1.0 - phi**2)) * rng.standard_normal(n)
        out += signal.lfilter([1.0], [1.0, -phi], steps, zi=[phi * start])[0]
    return out


def markov_flicker(rng: np.random.Generator, n: int, dt: float, b: float, shortest_s: float,
                   longest_s: float, processes: int = 6) -> np.ndarray:
    """Flicker of bias instability ``b`` (deg/h) as gyroid's noise model writes it (its
    docstring's construction, written here): ``processes`` Gauss-Markov processes,
    correlation times evenly spaced in log from ``shortest_s`` to ``longest_s``, each of
    variance ``b^2 ln(r) / pi`` (r the spacing ratio). Aperiodic, and with the model's
    power below the log's own frequencies."""
    taus = np.geomspace(shortest_s, longest_s, processes)
    return gauss_markov_sum(rng, n, dt, taus, b**2 * math.log(taus[1] / taus[0]) / math.pi)


def flicker_noise(rng: np.random.Generator, n: int, dt: float, b: float) -> np.ndarray:
    """Flicker (1/f) noise of bias instability ``b``: one-sided PSD ``b^2 / (pi f)`` (IEEE
    Std 952's floor ``0.664 b`` on the Allan deviation), by shaping white noise's spectrum by
    ``f^-1/2`` over twice the length (unit white noise has one-sided PSD ``2 dt``)."""
    spectrum = np.fft.rfft(rng.normal(size=2 * n))
    f = np.fft.rfftfreq(2 * n, dt)
    spectrum[1:] /= np.sqrt(f[1:])
    spectrum[0] = 0.0
    return b / math.sqrt(2.0 * math.pi * dt) * np.fft.irfft(spectrum)[:n]
