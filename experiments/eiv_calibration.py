"""Experiment (issue 30): errors in variables on paper A's thermal bench (the demo's).

Each seed simulates the bench (1 Hz, white gyro noise, paper A's truth) with a noisy
thermometer, and fits ``thermal`` under white noise (the point estimate and its sd) in
three ways: the thermometer's noise carried through dT/dt (the default), left out
(``errors_in_variables=False``, the likelihood before issue 30), and carried with the rate
window fixed at the default 1200 s. Recorded per way: the z-scores of the four coefficients
(estimate minus truth, over sd), how often |z| > 1.96 (5 % when calibrated), and how often
the fit fails its whiteness check and is trusted.

    python experiments/eiv_calibration.py --seed 0 --datasets 30
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import results_dir, save_run

from gyroid.bench import BenchOptions, fit_log
from gyroid.simulation import GyroNoise, simulate_thermal_bench

WAYS = {"carried": {}, "left_out": {"errors_in_variables": False},
        "carried_window_1200s": {"rate_window_s": 1200.0}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--datasets", type=int, default=30)
    parser.add_argument("--thermometer-c", type=float, nargs="+", default=[0.01, 0.05])
    parser.add_argument("--noise", default="white",
                        help="the fits' noise model (white, or auto: IEEE 952's)")
    parser.add_argument("--results", default="eiv_calibration",
                        help="the folder under experiments/results")
    args = parser.parse_args()
    started = time.time()
    results = {}
    for thermometer in args.thermometer_c:
        z = {way: [] for way in WAYS}
        whiteness = {way: 0 for way in WAYS}
        trusted = {way: 0 for way in WAYS}
        for k in range(args.datasets):
            sim = simulate_thermal_bench(seed=args.seed + k,
                                         noise=GyroNoise(temperature_noise_C=thermometer))
            truth = sim.truth["parameters"]
            for way, options in WAYS.items():
                fit = fit_log(sim.log, "thermal", BenchOptions(noise=args.noise, **options),
                              sample=False)
                z[way].append([(fit.point.value[n] - v) / fit.point.sd[n]
                               for n, v in truth.items()])
                whiteness[way] += "residual_whiteness" in {c.name for c in fit.checks.failed}
                trusted[way] += fit.trustworthy
            print(f"{thermometer} degC: {k + 1}/{args.datasets}", flush=True)
        names = list(sim.truth["parameters"])
        results[f"thermometer_{thermometer:g}C"] = {
            way: {"z_mean": dict(zip(names, np.mean(z[way], axis=0).tolist(), strict=True)),
                  "z_sd": dict(zip(names, np.std(z[way], axis=0).tolist(), strict=True)),
                  "outside_95": dict(zip(names, np.mean(np.abs(z[way]) > 1.96,
                                                        axis=0).tolist(), strict=True)),
                  "whiteness_failed": whiteness[way] / args.datasets,
                  "trustworthy": trusted[way] / args.datasets}
            for way in WAYS}
    save_run(results_dir(args.results), seed=args.seed,
             config={"datasets": args.datasets, "thermometer_C": args.thermometer_c,
                     "noise": args.noise,
                     "ways": {w: {k: str(v) for k, v in o.items()} for w, o in WAYS.items()},
                     "bench": "simulate_thermal_bench (1 Hz, paper A's truth, white gyro "
                              "noise 0.3 deg/h)"},
             results=results, started=started)


if __name__ == "__main__":
    main()
