"""Experiment (a): paper B's dK against the correction period dt and the roll rate, with
bands, and the best dt.

For each (dt, roll rate) the fitted gyro's posterior (a thermal fit made here from a
simulated bench, seed-derived) is propagated through the loop in paper B's worked-example
scenario; the spread over draws, encoder phases and periods gives the band. The best dt
minimises the RMS of dK (bias and spread together).

    python experiments/dk_vs_period_and_rate.py --seed 0
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from _common import fitted_thermal, results_dir, save_run  # noqa: E402

from gyroid.workflows import SCENARIOS as PRESETS  # noqa: E402
from gyroid.workflows import propagate  # noqa: E402

PERIODS_S = (1.0, 2.0, 3.0, 5.0, 8.0, 12.0, 20.0)
RATES_DEG_S = (900.0, 1800.0, 3600.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--draws", type=int, default=1000)
    args = parser.parse_args()
    started = time.time()
    fitted = fitted_thermal(args.seed)
    results: dict = {}
    fig, ax = plt.subplots(figsize=(6, 4))
    for marker, rate in zip("osd", RATES_DEG_S, strict=True):
        rows = []
        for period in PERIODS_S:
            scenario = replace(PRESETS["paper_b_worked"], roll_rate_deg_s=rate, period_s=period,
                               name=f"rate{rate:g}_dt{period:g}")
            dk = propagate(fitted, scenario, draws=args.draws, seed=args.seed,
                           sobol_n=50).samples["dK"]
            lo, hi = np.percentile(dk, [2.5, 97.5])
            rows.append({"period_s": period, "mean": float(dk.mean()), "sd": float(dk.std()),
                         "ci95": [float(lo), float(hi)],
                         "rms": float(np.sqrt(np.mean(dk**2)))})
        best = min(rows, key=lambda r: r["rms"])
        results[f"{rate:g}"] = {"by_period": rows, "best_period_s": best["period_s"]}
        x = [r["period_s"] for r in rows]
        ax.errorbar(x, [1e6 * r["mean"] for r in rows],
                    yerr=[[1e6 * (r["mean"] - r["ci95"][0]) for r in rows],
                          [1e6 * (r["ci95"][1] - r["mean"]) for r in rows]],
                    fmt=marker + "-", color="0.0", ms=4, capsize=2, label=f"{rate:g} deg/s")
    ax.set_xscale("log")
    ax.set_xlabel("correction period dt, s")
    ax.set_ylabel("dK, ppm (mean and 95 % band)")
    ax.legend(frameon=False)
    fig.tight_layout()
    out = results_dir("dk_vs_period_and_rate")
    fig.savefig(out / "dk_vs_period_and_rate.png", dpi=150)
    save_run(out, seed=args.seed, config={"periods_s": PERIODS_S, "rates_deg_s": RATES_DEG_S,
                                          "draws": args.draws}, results=results,
             started=started)


if __name__ == "__main__":
    main()
