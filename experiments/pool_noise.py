"""Experiment (issue 43): a lot whose runs' noise is correlated, pooled as white noise (the
pool's default) and with ``--noise auto`` (each run fitted under IEEE 952 noise, its
posterior pooled): what each says about the runs' spread, whether it trusts itself, and
what it costs.

The lot is gyroid's own simulated thermal lot, as a user makes it (``gyroid simulate
thermal --runs 3 --hours 2 --seed 3``: paper A's coefficients spread between runs, the
simulator's default noise with its bias instability), read back from its CSV files.

    python experiments/pool_noise.py --seed 3
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import results_dir, save_run

import gyroid
from gyroid.bench import BenchOptions
from gyroid.io import load_bench_log
from gyroid.pool import fit_pool


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--hours", type=float, default=2.0)
    args = parser.parse_args()
    gyroid.configure()
    started = time.time()
    with tempfile.TemporaryDirectory() as folder:
        lot = Path(folder) / "lot"
        subprocess.run([sys.executable, "-m", "gyroid", "simulate", "thermal", "--runs",
                        str(args.runs), "--hours", str(args.hours), "--out", str(lot),
                        "--seed", str(args.seed)], check=True, capture_output=True)
        truth = json.loads((lot / "lot.json").read_text())
        labels = tuple(truth["runs"])
        logs = [load_bench_log(lot / label / "bench.csv") for label in labels]
    pools = {}
    for noise in ("white", "auto"):
        begun = time.time()
        result = fit_pool(logs, labels, "thermal", BenchOptions(noise=noise), seed=args.seed)
        record = result.to_json()
        checks = result.checks.checks
        pools[noise] = {
            "seconds": round(time.time() - begun, 1),
            "trustworthy": result.trustworthy,
            "failed": [c.name for c in checks if not c.passed],
            "whiteness_inflation": next(c.value for c in checks
                                        if c.name == "residual_whiteness"),
            "cochran_q_p": {name: h["p_value"] for name, h in record["heterogeneity"].items()},
            "between_run_sd": {name: record["between_run_sd"][name]
                               for name in result.coefficient_names},
            "population": {name: record["population"][name]
                           for name in result.coefficient_names},
        }
    save_run(results_dir("pool_noise"), seed=args.seed,
             config={"runs": args.runs, "hours": args.hours,
                     "truth_between_run_sd": truth["between_run_sd"],
                     "truth_population_mean": truth["population_mean"]},
             results=pools, started=started)


if __name__ == "__main__":
    main()
