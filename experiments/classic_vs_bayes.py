"""Paper A's classic magnetic K against gyroid's Bayesian estimate, over many seeds.

For each seed a Helmholtz-sweep log is simulated with paper A's device 2 (test 1); the
classic estimator uses only the +/-300 uT dwells, gyroid's fit every sample. Reported: bias,
spread, the mean reported sd, and 95 % coverage of each.

    python experiments/classic_vs_bayes.py --seed 0 --runs 100
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import results_dir, save_run

from gyroid import GyroNoise
from gyroid.bench import BenchOptions, BenchProblem
from gyroid.papers import magnetic_k
from gyroid.simulation import PAPER_A_DEVICE_2, simulate_magnetic_bench


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--bias-instability", type=float, default=0.0)
    args = parser.parse_args()
    started = time.time()
    rng = np.random.default_rng(args.seed)
    noise = GyroNoise(bias_instability_deg_h=args.bias_instability)
    rows = {"classic": {a: [] for a in "xyz"}, "bayes": {a: [] for a in "xyz"}}
    for _ in range(args.runs):
        sim = simulate_magnetic_bench(noise=noise, seed=int(rng.integers(2**31)))
        point = BenchProblem.from_log(sim.log, "magnetic", BenchOptions(noise="white")).mode()
        for axis in "xyz":
            k = magnetic_k(sim.log, axis)
            rows["classic"][axis].append((k.signed, k.sd))
            rows["bayes"][axis].append((point.value[f"w{axis}"], point.sd[f"w{axis}"]))
    results = {}
    for method, per_axis in rows.items():
        results[method] = {}
        for axis, values in per_axis.items():
            est, sd = np.asarray(values).T
            truth = PAPER_A_DEVICE_2[f"w{axis}"]
            results[method][f"w{axis}"] = {
                "bias": float(est.mean() - truth),
                "spread_sd": float(est.std(ddof=1)),
                "mean_reported_sd": float(sd.mean()),
                "coverage95": float(np.mean(np.abs(est - truth) <= 1.96 * sd)),
            }
    save_run(results_dir("classic_vs_bayes"), seed=args.seed, config=vars(args),
             results=results, started=started)


if __name__ == "__main__":
    main()
