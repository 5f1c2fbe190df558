"""Experiment (issue 43): what the compensation's ``window_bands`` check costs where the fit
describes the gyro. A FOG thermal bench with the noise every real FOG has (written
independently of gyroid: ``fog_thermal_bench.fog_log``, white + flicker + a rate random
walk, a noisy thermometer) is fitted with every default; a second run of the same gyro (the
same truth, new noise, its own walk) is compensated with that fit. Each compensation's
window means (10 minutes) are held against their 95 % bands: the share inside, and whether
``window_bands`` (fewer than 80 % inside: an error) and the whitened ``predictive`` check
pass. A refusal here is a false alarm: the fit is right about the gyro, and the second run
differs only by its noise.

    python experiments/window_bands.py --seed 0 --pairs 8
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import results_dir, save_run
from fog_thermal_bench import fog_log

import gyroid
from gyroid.bench import BenchOptions, fit_log
from gyroid.inference import Emcee, Importance
from gyroid.io import BenchLog
from gyroid.workflows import compensate


def one(seed: int, profile: str) -> dict:
    started = time.time()
    train = fog_log(seed, profile)
    train.pop("w0_over_the_log")
    test = fog_log(seed + 10_000, profile)
    test.pop("w0_over_the_log")
    # every default: IEEE 952 noise, importance sampling (emcee where its weights fail)
    fit = fit_log(BenchLog(train), "thermal", BenchOptions(noise="auto"), seed=seed,
                  sampler=Importance(fallback=Emcee(progress=False)))
    result = compensate(BenchLog(test), fit.fitted_drift(), seed=seed)
    w = result.window_means
    inside = (w["drift_mean_deg_h"] >= w["band95_lo_deg_h"]) & (
        w["drift_mean_deg_h"] <= w["band95_hi_deg_h"])
    checks = {c.name: c.passed for c in result.checks.checks}
    return {"seed": seed, "profile": profile, "noise_used": fit.problem.noise.name,
            "fit_trustworthy": fit.trustworthy,
            "inside": round(float(inside.mean()), 3), "windows": int(inside.size),
            "window_bands": checks["window_bands"], "predictive": checks["predictive"],
            "compensation_trustworthy": result.checks.trustworthy,
            "median_offset_deg_h": float(np.median(w["drift_mean_deg_h"]
                                                   - w["model_mean_deg_h"])),
            "median_band_half_deg_h": float(np.median(w["band95_hi_deg_h"]
                                                      - w["band95_lo_deg_h"]) / 2),
            "seconds": round(time.time() - started, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--pairs", type=int, default=8)
    parser.add_argument("--profile", default="smooth")
    args = parser.parse_args()
    gyroid.configure()
    started = time.time()
    runs = []
    for k in range(args.pairs):
        runs.append(one(args.seed + k, args.profile))
        print(runs[-1], flush=True)
    usable = [r for r in runs if r["fit_trustworthy"]]
    results = {"runs": runs, "pairs": len(runs), "fits_trustworthy": len(usable),
               "window_bands_refused": sum(not r["window_bands"] for r in usable),
               "predictive_refused": sum(not r["predictive"] for r in usable),
               "inside_median": float(np.median([r["inside"] for r in runs]))}
    save_run(results_dir("window_bands"), seed=args.seed,
             config={"pairs": args.pairs, "profile": args.profile}, results=results,
             started=started)


if __name__ == "__main__":
    main()
