"""Experiment: the predictive check's false-alarm rate on null logs, where the fitted model
is the one that made the data.

Bench kinds (a linear drift in temperature, its noise drawn here, independently of gyroid's
simulators):

* ``white``: Gaussian white noise, fitted with ``--noise white`` (closed-form folds);
* ``student_t``: white noise with Student-t (3 degrees of freedom) samples, fitted with
  ``--noise white`` (the check reads means, which are nearly Gaussian);
* ``gauss_markov``: white plus a Gauss-Markov bias, fitted with ``--noise white+gm``
  (folds refitted by the mode with the held-out rows masked);
* ``flicker``: white plus flicker (1/f) noise, fitted with ``--noise white+gm``: not a
  null for the noise model (one Gauss-Markov process cannot be flicker), reported to show
  how far the check tolerates that approximation.

Roll kind: paper B's ideal-stabiliser flight (gyroid's flight simulator), fitted with the
``ideal`` terms. Every fold's own p-value (uncorrected) is kept at each scale: under the
null they are uniform (exactly for the white kinds), which the KS statistic tests; the
check itself fails at a Bonferroni-corrected p below ``PREDICTIVE_P``.

    python experiments/predictive_nulls.py --seed 0 --datasets 40
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import flicker_noise, results_dir, save_run
from scipy import stats

import gyroid
from gyroid.bench import BenchOptions, BenchProblem
from gyroid.bench._predictive import bench_held_out
from gyroid.inference._predictive import PREDICTIVE_P, predictive_scales
from gyroid.io import BenchLog, RollLog
from gyroid.roll import RollProblem
from gyroid.roll._predictive import roll_held_out
from gyroid.simulation import FlightProfile, simulate_flight

ROWS = 2000
SAMPLE_S = 1.0
WHITE_SD = 0.3  # deg/h per sample
TRUTH = {"w0": 2.0, "w1": 0.05}  # deg/h, deg/h/degC


def _temperature(rng: np.random.Generator, n: int) -> np.ndarray:
    """A bench's slow temperature cycle, degC, with a random phase."""
    t = np.arange(n) * SAMPLE_S
    return 20.0 + 15.0 * np.sin(2 * np.pi * t / (n * SAMPLE_S) + rng.uniform(0, 2 * np.pi))


def _gauss_markov(rng, n, sd, tau_s):
    phi = np.exp(-SAMPLE_S / tau_s)
    out = np.empty(n)
    out[0] = rng.normal(0.0, sd)
    shocks = rng.normal(0.0, sd * np.sqrt(1 - phi**2), n)
    for k in range(1, n):
        out[k] = phi * out[k - 1] + shocks[k]
    return out


def _flicker(rng, n, sd):
    """1/f noise scaled to ``sd``."""
    series = flicker_noise(rng, n, SAMPLE_S, 1.0)
    return sd * series / series.std()


def _bench_log(kind: str, rng: np.random.Generator) -> tuple[BenchLog, str]:
    temperature = _temperature(rng, ROWS)
    drift = TRUTH["w0"] + TRUTH["w1"] * (temperature - 20.0)
    if kind == "student_t":
        noise = WHITE_SD * rng.standard_t(3, ROWS) / np.sqrt(3.0)  # sd WHITE_SD
    else:
        noise = rng.normal(0.0, WHITE_SD, ROWS)
    if kind == "gauss_markov":
        noise += _gauss_markov(rng, ROWS, 0.1, 120.0)
    if kind == "flicker":
        noise += _flicker(rng, ROWS, 0.1)
    columns = {"time_s": np.arange(ROWS) * SAMPLE_S, "drift_deg_h": drift + noise,
               "temperature_C": temperature}
    return BenchLog(columns=columns), "white" if kind in ("white", "student_t") else "white+gm"


def _folds(kind: str, seed: int):
    rng = np.random.default_rng(seed)
    if kind == "roll":
        flight = simulate_flight(params={"D0": 0.0, "Denc": 0.0},
                                 profile=FlightProfile(duration_s=40.0), seed=seed)
        problem = RollProblem.from_log(RollLog.from_columns(flight.columns), "ideal")
        return roll_held_out(problem, problem.mode())[0]
    log, noise = _bench_log(kind, rng)
    problem = BenchProblem.from_log(log, "bias,temperature", BenchOptions(noise=noise, t0_C=20.0))
    return bench_held_out(problem.density, np.asarray(problem.log.time_s))[0]


def run_kind(kind: str, seeds: list[int]) -> dict:
    failed, fold_p = 0, {}
    for seed in seeds:
        scales = predictive_scales(_folds(kind, seed))
        failed += any(s.p < PREDICTIVE_P for s in scales)
        for s in scales:
            fold_p.setdefault(s.group, []).extend(s.fold_p)
    per_scale = {}
    for group, p in sorted(fold_p.items()):
        p = np.asarray(p)
        per_scale[str(group)] = {
            "fold_p_values": int(p.size),
            "below_0.05": round(float(np.mean(p < 0.05)), 4),
            "below_0.001": round(float(np.mean(p < 0.001)), 4),
            "ks_vs_uniform": round(float(stats.kstest(p, "uniform").statistic), 4),
            "ks_p": float(stats.kstest(p, "uniform").pvalue),
        }
    rate = failed / len(seeds)
    low, high = stats.beta.ppf([0.025, 0.975], failed + 0.5, len(seeds) - failed + 0.5)
    return {"datasets": len(seeds), "check_failed": failed, "false_alarm_rate": rate,
            "rate_95_interval": [round(float(low), 4), round(float(high), 4)],
            "per_fold_p_by_parts_per_mean": per_scale}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--datasets", type=int, default=40)
    parser.add_argument("--kinds", default="white,student_t,gauss_markov,flicker,roll")
    args = parser.parse_args()
    gyroid.configure()
    started = time.time()
    seeds = [args.seed * 100_000 + k for k in range(args.datasets)]
    results = {"nominal_family_rate": PREDICTIVE_P}
    for kind in args.kinds.split(","):
        kind_started = time.time()
        results[kind] = run_kind(kind, seeds)
        results[kind]["seconds"] = round(time.time() - kind_started, 1)
        print(kind, results[kind]["check_failed"], "of", args.datasets, flush=True)
    save_run(results_dir("predictive_nulls"), seed=args.seed,
             config={"rows": ROWS, "sample_s": SAMPLE_S, "white_sd_deg_h": WHITE_SD,
                     "truth": TRUTH, "datasets": args.datasets, "kinds": args.kinds},
             results=results, started=started)


if __name__ == "__main__":
    main()
