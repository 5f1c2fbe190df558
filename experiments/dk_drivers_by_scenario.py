"""Experiment (c): which input's uncertainty dominates dK in which scenario.

A thermal bench is simulated and fitted (seed-derived); its posterior is propagated through
every scenario preset; the total Sobol indices of dK are tabulated per scenario.

    python experiments/dk_drivers_by_scenario.py --seed 0
"""

from __future__ import annotations

import argparse
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from _common import fitted_thermal, results_dir, save_run  # noqa: E402

from gyroid.workflows import SCENARIOS as PRESETS  # noqa: E402
from gyroid.workflows import propagate  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--sobol", type=int, default=1000)
    args = parser.parse_args()
    started = time.time()
    fitted = fitted_thermal(args.seed)
    results = {}
    for name, scenario in PRESETS.items():
        result = propagate(fitted, scenario, draws=500, seed=args.seed,
                           sobol_n=args.sobol).to_json()
        results[name] = {"dK": result["dK"], "drivers_total": result["drivers_total"],
                         "dominant": max(result["drivers_total"],
                                         key=result["drivers_total"].get)}
    names = list(next(iter(results.values()))["drivers_total"])
    fig, ax = plt.subplots(figsize=(7, 3.8))
    width = 0.8 / len(results)
    hatches = ["", "//", "..", "xx"]
    for k, (scenario, row) in enumerate(results.items()):
        ax.bar(np.arange(len(names)) + k * width, [row["drivers_total"][n] for n in names],
               width, color="white" if k else "0.3", edgecolor="0.0", hatch=hatches[k % 4],
               label=scenario)
    ax.set_xticks(np.arange(len(names)) + 0.4 - width / 2, names, rotation=25, fontsize=7)
    ax.set_ylabel("total Sobol index of dK, fraction")
    ax.legend(frameon=False, fontsize=7)
    fig.tight_layout()
    out = results_dir("dk_drivers_by_scenario")
    fig.savefig(out / "dk_drivers_by_scenario.png", dpi=150)
    save_run(out, seed=args.seed, config={"sobol": args.sobol, "scenarios": list(PRESETS)},
             results=results, started=started)


if __name__ == "__main__":
    main()
