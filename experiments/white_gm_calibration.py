"""Experiment (issue 28): are ``--noise white+gm``'s posteriors calibrated on logs long
enough to be fitted as block means?

Each seed simulates paper A's thermal bench stretched to ``--rows`` rows with a
Gauss-Markov bias instability (0.05 deg/h, 600 s) beside the white noise and a 0.01 degC
thermometer, and fits ``thermal`` under white+gm (emcee, the command line's settings).
Recorded per parameter (the four coefficients, sigma_gm, tau_gm): the mean and rms of
z = (posterior mean - truth) / posterior sd, and how many truths lie inside their central
90 % intervals (27 of 30 when calibrated; 22-30 is the binomial 99 % band for 30).

    python experiments/white_gm_calibration.py --seed 200 --datasets 30 --rows 1e5
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import results_dir, save_run

from gyroid.bench import BenchOptions, fit_log
from gyroid.inference import Emcee
from gyroid.simulation import GyroNoise, ThermalProtocol, simulate_thermal_bench

#: The correlated noise every log carries (as benchmarks/scaling.py's --gm-rows).
GM = {"bias_instability_deg_h": 0.05, "correlation_time_s": 600.0}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=200)
    parser.add_argument("--datasets", type=int, default=30)
    parser.add_argument("--rows", type=float, default=1e5)
    args = parser.parse_args()
    started = time.time()
    protocol = ThermalProtocol()
    protocol = protocol.stretched(None, args.rows / protocol.duration_s)
    noise = GyroNoise(**GM)
    z, inside, trusted, warned, under_other = [], [], 0, 0, 0
    for k in range(args.datasets):
        sim = simulate_thermal_bench(seed=args.seed + k, protocol=protocol, noise=noise)
        truth = {**sim.truth["parameters"], "sigma_gm_deg_h": GM["bias_instability_deg_h"]
                 / 0.6174, "tau_gm_s": GM["correlation_time_s"]}
        fit = fit_log(sim.log, "thermal", BenchOptions(noise="white+gm"), seed=args.seed + k,
                      sampler=Emcee(progress=False))
        draws = {name: fit.posterior.flat(name) for name in truth}
        z.append([(draws[n].mean() - v) / draws[n].std() for n, v in truth.items()])
        inside.append([np.percentile(draws[n], 5) <= v <= np.percentile(draws[n], 95)
                       for n, v in truth.items()])
        trusted += fit.trustworthy
        # how often the intervals are said to rest on the noise levels' priors or on the
        # choice of white+gm over the default (the log not ruling the default out)
        check = next(c for c in fit.checks.checks if c.name == "noise_prior_dependence")
        warned += not check.passed
        under_other += (not check.passed and fit.allowed_noise is not None
                        and fit.allowed_noise.widest[0] in fit.allowed_noise.under_other)
        print(f"{k + 1}/{args.datasets}", flush=True)
    names = list(truth)
    z = np.asarray(z)
    results = {
        "z_mean": dict(zip(names, z.mean(axis=0).tolist(), strict=True)),
        "z_rms": dict(zip(names, np.sqrt((z**2).mean(axis=0)).tolist(), strict=True)),
        "inside_90": dict(zip(names, np.sum(inside, axis=0).tolist(), strict=True)),
        "datasets": args.datasets, "trustworthy": trusted,
        "noise_prior_dependence_warned": warned, "warned_under_other_model": under_other,
        "block_means": fit.block_means}
    save_run(results_dir("white_gm_calibration"), seed=args.seed,
             config={"datasets": args.datasets, "rows": args.rows, "gm": GM,
                     "thermometer_C": noise.temperature_noise_C,
                     "bench": "simulate_thermal_bench, paper A's truth and schedule"},
             results=results, started=started)


if __name__ == "__main__":
    main()
