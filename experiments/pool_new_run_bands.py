"""Experiment: a new run compensated with a pool of its unit's earlier runs, against a
truth the pool never saw. Do the bands ``gyroid compensate --fit POOL --another-run``
states for a new run's window means hold them, when every run has the flicker and random
walk a real FOG has and its own turn-on bias?

Each run is ``experiments/fog_thermal_bench.py``'s log (simulated there, independently of
gyroid: 10 h at 1 Hz, the smooth profile, white noise 0.005 deg/sqrt(h), flicker 0.01
deg/h, a rate random walk 0.005 deg/h/sqrt(h), a 0.01 degC thermometer) with a turn-on
bias added, drawn per run from N(0, ``--turn-on-sd``) (deg/h). Lot ``k`` pools the runs of
seeds ``seed + 5k`` .. ``seed + 5k + 3`` (``gyroid pool --terms thermal``, every default:
each run fitted under IEEE 952 noise, the posteriors pooled) and compensates the run of
seed ``seed + 5k + 4`` with it, in windows of ``--window`` s. Per lot: the exit codes, the
pool's failed checks (warnings included), the ``window_bands`` check, the share of the new
run's window means inside their 95 % bands, and each window's error over its band's sd
(a z-score: about N(0, 1) where the bands are right, but correlated within a run: its walk
and turn-on bias are shared by every window).

    python experiments/pool_new_run_bands.py --seed 500 --lots 16 --workers 2
"""

from __future__ import annotations

import argparse
import csv
import json
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from _common import results_dir, save_run
from fog_thermal_bench import fog_log

POOLED_RUNS = 4
Z95 = 1.959964


def one_lot(seed0: int, turn_on_sd: float, window_s: float) -> dict:
    """Pool four runs, compensate the fifth, score its window means against its bands."""
    import gyroid
    from gyroid.cli import main as gyroid_main
    from gyroid.io._log_writer import write_bench_log

    gyroid.configure()
    seeds = list(range(seed0, seed0 + POOLED_RUNS + 1))
    offsets = [float(np.random.default_rng([s, 952]).normal(0.0, turn_on_sd)) for s in seeds]
    started = time.time()
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        paths = []
        for seed, offset in zip(seeds, offsets, strict=True):
            columns = fog_log(seed, "smooth")
            columns.pop("w0_over_the_log")
            columns["drift_deg_h"] = columns["drift_deg_h"] + offset
            paths.append(folder / f"run{seed}.csv")
            write_bench_log(paths[-1], columns, ())
        pool_code = gyroid_main(["pool", *map(str, paths[:-1]), "--terms", "thermal",
                                 "--out", str(folder / "pool"), "--seed", str(seed0), "-q"])
        record = {"seeds": seeds, "turn_on_deg_h": offsets, "pool_exit": pool_code}
        if pool_code not in (0, 3):
            return record | {"seconds": round(time.time() - started, 1)}
        checks = json.loads((folder / "pool" / "pool.json").read_text())["checks"]
        record["pool_failed_checks"] = sorted(n for n, c in checks.items() if not c["passed"])
        code = gyroid_main(["compensate", str(paths[-1]), "--fit", str(folder / "pool"),
                            "--out", str(folder / "comp"), "--window", str(window_s),
                            "--another-run", "--seed", str(seed0), "-q"])
        record["compensate_exit"] = code
        if code in (0, 3):
            report = json.loads((folder / "comp" / "compensate.json").read_text())
            bands = report["checks"]["window_bands"]
            record["window_bands_passed"] = bool(bands["passed"])
            rows = list(csv.DictReader(open(folder / "comp" / "compensated_means.csv")))
            value = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}
            measured, low, high = (value[k] for k in ("drift_mean_deg_h", "band95_lo_deg_h",
                                                      "band95_hi_deg_h"))
            centre, sd = 0.5 * (low + high), (high - low) / (2.0 * Z95)
            record.update(windows=int(measured.size),
                          in_band=float(np.mean((measured >= low) & (measured <= high))),
                          z=[round(float(z), 3) for z in (measured - centre) / sd],
                          band_halfwidth_deg_h=float(np.median(high - low) / 2.0))
    return record | {"seconds": round(time.time() - started, 1)}


def summarise(lots: list[dict]) -> dict:
    """In-band shares over the lots, the z-scores' spread, the check's verdicts."""
    scored = [lot for lot in lots if "in_band" in lot]
    shares = np.array([lot["in_band"] for lot in scored])
    z = np.concatenate([lot["z"] for lot in scored]) if scored else np.zeros(0)
    means = np.array([np.mean(lot["z"]) for lot in scored])
    return {
        "lots": len(lots), "scored": len(scored),
        "pool_exit": [lot["pool_exit"] for lot in lots],
        "compensate_exit": [lot.get("compensate_exit") for lot in lots],
        "in_band_mean": float(shares.mean()) if scored else None,
        "in_band_median": float(np.median(shares)) if scored else None,
        "in_band_min": float(shares.min()) if scored else None,
        "lots_at_least_80_percent": int(np.sum(shares >= 0.8)),
        "window_bands_refused": int(sum(not lot["window_bands_passed"] for lot in scored)),
        "pool_failed_checks": {name: sum(name in lot.get("pool_failed_checks", ())
                                         for lot in lots)
                               for name in sorted({n for lot in lots
                                                   for n in lot.get("pool_failed_checks", ())})},
        "z_sd_all_windows": float(np.std(z)) if z.size else None,
        "z_lot_means_sd": float(np.std(means)) if scored else None,
        "windows": int(z.size),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=500)
    parser.add_argument("--lots", type=int, default=16)
    parser.add_argument("--turn-on-sd", type=float, default=0.02, help="deg/h")
    parser.add_argument("--window", type=float, default=1800.0, help="s")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    started = time.time()
    starts = [args.seed + (POOLED_RUNS + 1) * k for k in range(args.lots)]
    with ProcessPoolExecutor(args.workers) as pool:
        lots = list(pool.map(one_lot, starts, [args.turn_on_sd] * args.lots,
                             [args.window] * args.lots))
    for lot in lots:
        print({k: v for k, v in lot.items() if k != "z"}, flush=True)
    summary = summarise(lots)
    print(json.dumps(summary, indent=2))
    save_run(results_dir("pool_new_run_bands"), seed=args.seed,
             config={"lots": args.lots, "turn_on_sd_deg_h": args.turn_on_sd,
                     "window_s": args.window, "pooled_runs": POOLED_RUNS},
             results={"summary": summary, "lots": lots}, started=started)


if __name__ == "__main__":
    main()
