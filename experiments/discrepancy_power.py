"""Experiment: the discrepancy workflow's detection rate against effect size (in noise
units) for every candidate effect, and its false-positive rate on null logs with white and
with correlated noise.

Effect size in noise units: the RMS of the hidden effect's contribution over the log,
divided by the white-noise sd of a 60 s mean (0.3 deg/h / sqrt(60) = 0.039 deg/h).

    python experiments/discrepancy_power.py --seed 0 --seeds-per-point 5
"""

from __future__ import annotations

import argparse
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from _common import results_dir, save_run  # noqa: E402

from gyroid import GyroNoise  # noqa: E402
from gyroid.simulation import simulate_magnetic_bench, simulate_thermal_bench  # noqa: E402
from gyroid.workflows import find_discrepancies  # noqa: E402

#: (bench, effect, parameters as a function of a scale s in [0.25, 2]).
CASES = {
    "warmup": ("thermal", lambda s: {"w_warmup": 1.0 * s, "tau_warmup_min": 20.0}),
    "time_trend": ("magnetic", lambda s: {"w_trend": 0.04 * s}),
    "temperature_cubic": ("thermal", lambda s: {"w3": 2e-5 * s}),
    "thermal_lag": ("thermal", lambda s: {"tau_lag_min": 8.0 * s}),
    "magnetic_hysteresis": ("magnetic", lambda s: {"hys_x": 0.0, "hys_y": 0.03 * s,
                                                   "hys_z": 0.05 * s}),
}
SCALES = (0.25, 0.5, 1.0, 2.0)
NOISE_UNIT = 0.3 / np.sqrt(60.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--seeds-per-point", type=int, default=5)
    args = parser.parse_args()
    started = time.time()
    rng = np.random.default_rng(args.seed)
    results: dict = {"detection": {}, "false_positive": {}}
    fig, ax = plt.subplots(figsize=(6, 4))
    for marker, (effect, (bench, params)) in zip("osd^v", CASES.items(), strict=True):
        simulate = simulate_thermal_bench if bench == "thermal" else simulate_magnetic_bench
        rows = []
        for scale in SCALES:
            hits, missed, extra, sizes = 0, 0, 0, []
            for _ in range(args.seeds_per_point):
                seed = int(rng.integers(2**31))
                sim = simulate(seed=seed, effects={effect: params(scale)})
                base = simulate(seed=seed)
                sizes.append(float(np.sqrt(np.mean((sim.true_drift_deg_h
                                                     - base.true_drift_deg_h) ** 2))) / NOISE_UNIT)
                report = find_discrepancies(sim.log, bench)
                hits += report.added == [effect]
                missed += effect not in report.added
                extra += effect in report.added and len(report.added) > 1
            n = args.seeds_per_point
            rows.append({"scale": scale, "size_noise_units": float(np.mean(sizes)),
                         "exact_detection_rate": hits / n,
                         # the two ways to miss "exactly": not found, or found with another
                         "missed_rate": missed / n, "found_with_extra_rate": extra / n})
        results["detection"][effect] = rows
        ax.plot([r["size_noise_units"] for r in rows], [r["exact_detection_rate"] for r in rows],
                marker + "-", color="0.0", ms=4, label=effect)
    for bench in ("thermal", "magnetic"):
        simulate = simulate_thermal_bench if bench == "thermal" else simulate_magnetic_bench
        for label, noise in (("white", GyroNoise()),
                             ("correlated", GyroNoise(bias_instability_deg_h=0.1,
                                                      correlation_time_s=300.0))):
            added = 0
            for _ in range(args.seeds_per_point * 2):
                report = find_discrepancies(simulate(seed=int(rng.integers(2**31)),
                                                     noise=noise).log, bench)
                added += bool(report.added)
            results["false_positive"][f"{bench}_{label}"] = added / (args.seeds_per_point * 2)
    ax.set_xscale("log")
    ax.set_xlabel("hidden effect RMS / sd of a 60 s mean, dimensionless")
    ax.set_ylabel("exact detection rate, fraction")
    ax.legend(frameon=False, fontsize=7)
    fig.tight_layout()
    out = results_dir("discrepancy_power")
    fig.savefig(out / "discrepancy_power.png", dpi=150)
    save_run(out, seed=args.seed, config={"scales": SCALES, "seeds_per_point":
                                          args.seeds_per_point}, results=results,
             started=started)


if __name__ == "__main__":
    main()
