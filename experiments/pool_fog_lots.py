"""Experiment (issues 42 and 43): lots of FOG thermal runs whose coefficients do not differ,
pooled under white noise (the pool's old default) and under ``--noise auto`` (each run
fitted under IEEE 952 noise, its posterior pooled). A pool says whether the runs differ;
on these lots they do not (but for ``w0``: each run's bias over its log carries its own
walk's mean), so a run-to-run test at p < 0.01 on ``w1``, ``w2`` or ``wD`` is a false
alarm, and the population's 95 % intervals must hold paper A's coefficients.

Each run is ``experiments/fog_thermal_bench.py``'s log (written there, independently of
gyroid's simulator: 10 h at 1 Hz, the smooth profile, white noise 0.005 deg/sqrt(h),
flicker 0.01 deg/h, a rate random walk 0.005 deg/h/sqrt(h), a 0.01 degC thermometer); lot
``k`` holds the runs of seeds ``seed + 3k``, ``seed + 3k + 1``, ``seed + 3k + 2``.

    python experiments/pool_fog_lots.py --seed 100 --lots 10 --workers 2
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from _common import results_dir, save_run
from fog_thermal_bench import TRUTH, fog_log

RUNS_PER_LOT = 3
ALARM_P = 0.01


def one_lot(seeds: tuple[int, ...]) -> dict:
    """Pool the lot's runs under white and under auto noise: trust, run-to-run p-values,
    the population's intervals against the truth, the time."""
    import gyroid
    from gyroid.bench import BenchOptions
    from gyroid.io import BenchLog
    from gyroid.pool import fit_pool

    gyroid.configure()
    logs, w0_truths = [], []
    for seed in seeds:
        columns = fog_log(seed, "smooth")
        w0_truths.append(float(columns.pop("w0_over_the_log")))
        logs.append(BenchLog({k: np.asarray(v) for k, v in columns.items()},
                             source=f"seed {seed}"))
    truth = {**TRUTH, "w0": float(np.mean(w0_truths))}
    record: dict = {"seeds": list(seeds), "w0_truths": w0_truths}
    for noise in ("white", "auto"):
        begun = time.time()
        result = fit_pool(logs, [f"seed{s}" for s in seeds], "thermal", BenchOptions(noise=noise),
                          seed=seeds[0])
        pool = result.to_json()
        record[noise] = {
            "seconds": round(time.time() - begun, 1),
            "trustworthy": result.trustworthy,
            "failed": [c.name for c in result.checks.checks if not c.passed],
            "cochran_q_p": {k: h["p_value"] for k, h in pool["heterogeneity"].items()},
            "population": {k: {"mean": pool["population"][k]["mean"],
                               "ci95": pool["population"][k]["ci95"]} for k in TRUTH},
            "covered": {k: bool(pool["population"][k]["ci95"][0] <= truth[k]
                                <= pool["population"][k]["ci95"][1]) for k in TRUTH},
        }
    return record


def summarise(lots: list[dict]) -> dict:
    summary = {}
    for noise in ("white", "auto"):
        rows = [lot[noise] for lot in lots]
        summary[noise] = {
            "trusted": sum(r["trustworthy"] for r in rows),
            "false_alarms_p_below_0_01": {
                k: sum(r["cochran_q_p"][k] < ALARM_P for r in rows) for k in ("w1", "w2", "wD")},
            "trusted_with_a_false_alarm": sum(
                r["trustworthy"] and any(r["cochran_q_p"][k] < ALARM_P
                                         for k in ("w1", "w2", "wD")) for r in rows),
            "covered95": {k: sum(r["covered"][k] for r in rows) for k in TRUTH},
            "median_seconds": float(np.median([r["seconds"] for r in rows])),
        }
    summary["lots"] = len(lots)
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=100)
    parser.add_argument("--lots", type=int, default=10)
    parser.add_argument("--workers", type=int, default=1)
    args = parser.parse_args()
    started = time.time()
    jobs = [tuple(args.seed + RUNS_PER_LOT * k + j for j in range(RUNS_PER_LOT))
            for k in range(args.lots)]
    if args.workers > 1:
        from gyroid._config import use_one_core

        use_one_core()  # each worker's XLA and BLAS on one core
    with ProcessPoolExecutor(args.workers) as pool:
        lots = []
        for lot in pool.map(one_lot, jobs):
            print({n: (lot[n]["trustworthy"], lot[n]["cochran_q_p"]) for n in ("white", "auto")},
                  flush=True)
            lots.append(lot)
    save_run(results_dir("pool_fog_lots"), seed=args.seed,
             config={"runs_per_lot": RUNS_PER_LOT, "profile": "smooth", "truth": TRUTH,
                     "alarm_p": ALARM_P},
             results={"summary": summarise(lots), "lots": lots}, started=started)


if __name__ == "__main__":
    main()
