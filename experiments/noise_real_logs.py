"""Experiment (issue 30): ``gyroid noise`` on real static logs, beside the Allan readings users
run today (the same two as ``noise_coverage.py``), with no truth to score against but one
check a truth-free real log allows: the seven static runs of one MPU6050 (dataset
``mpu6050_sunsided``) are one gyro, so each axis's angle random walk should agree across
the runs within what each fit says it knows.

The logger stamped samples in host bursts (gyroid noise refuses that clock), so each run's
time is taken as its sample index times its mean interval (the device samples at a fixed
rate), as a user who reads the log with allantools at a stated rate assumes too.

    GYROID_DATA=../shared/data/real python experiments/noise_real_logs.py
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import results_dir, save_run
from noise_coverage import allan_variance_package, slope_method
from scipy import stats

import gyroid
from gyroid.allan import fit_noise
from gyroid.io import dataset_logs

DATASET = "mpu6050_sunsided"
AXES = ("x", "y", "z")
TERMS = ("N", "B", "K")


def one(name: str, columns: dict, axis: str, seed: int) -> dict:
    time_s = np.asarray(columns["time_s"], dtype=float)
    step = (time_s[-1] - time_s[0]) / (time_s.size - 1)
    rate = np.asarray(columns[f"drift_{axis}_deg_h"], dtype=float)
    fit = fit_noise(rate, step, seed=seed, label=f"{name} {axis}")
    summary = fit.term_summaries()
    gyroid_answer = {}
    for term in TERMS:
        entry = summary[term]
        gyroid_answer[term] = (
            {"median": float(np.median(fit.draws(term))), "sd": entry["sd"],
             "ci90": entry["ci90"]} if entry["resolved"]
            else {"upper_bound_95": entry["upper_bound_95"]})
    slope = slope_method(rate, step)
    package = allan_variance_package(rate, step)
    return {"run": name, "axis": axis, "rows": int(rate.size), "seconds_logged":
            float(time_s[-1] - time_s[0]), "sample_s": float(step),
            "trustworthy": fit.trustworthy, "dispersion": fit.dispersion,
            "failed": [c.name for c in fit.checks.failed],
            "errors": [c.name for c in fit.checks.failed if c.severity == "error"],
            "gyroid": gyroid_answer, "slope": {t: slope[t] for t in TERMS},
            "allan_variance": {t: package[t] for t in TERMS}}


def agreement(rows: list[dict]) -> dict:
    """Per axis, over the runs gyroid trusts: gyroid's N against its own sds (chi-square of
    the spread about the weighted mean, and its p-value), and each method's spread (max /
    min) over the same runs; and how gyroid's N compares with each reading."""
    out = {}
    for axis in AXES:
        mine = [r for r in rows if r["axis"] == axis and r["trustworthy"]
                and "median" in r["gyroid"]["N"]]
        n = np.array([r["gyroid"]["N"]["median"] for r in mine])
        sd = np.array([r["gyroid"]["N"]["sd"] for r in mine])
        weights = 1.0 / sd**2
        mean = float(np.sum(weights * n) / np.sum(weights))
        chi2 = float(np.sum(((n - mean) / sd) ** 2))
        dof = n.size - 1
        every = mine
        out[axis] = {
            "runs": n.size, "gyroid_N_weighted_mean": mean, "chi2": chi2, "dof": dof,
            "p_value": float(stats.chi2.sf(chi2, dof)),
            "spread_max_over_min": {
                "gyroid": float(n.max() / n.min()),
                "slope": float(max(r["slope"]["N"] for r in every)
                               / min(r["slope"]["N"] for r in every)),
                "allan_variance": float(max(r["allan_variance"]["N"] for r in every)
                                        / min(r["allan_variance"]["N"] for r in every))}}
    trusted = [r for r in rows if r["trustworthy"]]
    out["trusted"] = len(trusted)
    out["series"] = len(rows)
    for method in ("slope", "allan_variance"):
        ratio = [r["gyroid"]["N"]["median"] / r[method]["N"] for r in trusted]
        out[f"N_over_{method}"] = [float(min(ratio)), float(max(ratio))]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    gyroid.configure()
    started = time.time()
    rows = []
    for k, (name, (columns, _)) in enumerate(dataset_logs(DATASET).items()):
        for axis in AXES:
            rows.append(one(name, columns, axis, args.seed + k))
            print(name, axis, rows[-1]["gyroid"]["N"], rows[-1]["slope"]["N"], flush=True)
    save_run(results_dir("noise_real_logs"), seed=args.seed,
             config={"dataset": DATASET, "time": "sample index x mean interval"},
             results={"agreement": agreement(rows), "runs": rows}, started=started)


if __name__ == "__main__":
    main()
