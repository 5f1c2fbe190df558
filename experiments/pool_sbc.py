"""Simulation-based calibration of the pooled (hierarchical) fit on lots of magnetic runs.

Per dataset: the population means and between-run sds drawn from the priors the fit uses,
each run's coefficients from the population, a short Helmholtz-coil sweep simulated per run
(white noise, level unknown to the fit), the lot pooled with ``fit_pool`` under white noise
(each run fitted on its own, its coefficients' posterior one Gaussian observation). Recorded: the
rank of each true population mean and between-run sd among the posterior draws, and
whether the central 50 / 90 / 95 % intervals cover it, for lots of 3, 8 and 30 runs.

    python experiments/pool_sbc.py --seed 0 --datasets 40 40 20
"""

from __future__ import annotations

import argparse
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from _common import results_dir, save_run  # noqa: E402
from scipy import stats  # noqa: E402

from gyroid.bench import BenchOptions
from gyroid.models import Normal  # noqa: E402
from gyroid.pool import fit_pool
from gyroid.simulation import (  # noqa: E402
    GyroNoise,  # noqa: E402
    MagneticProtocol,
    simulate_magnetic_bench,
)

LEVELS = (0.5, 0.9, 0.95)
LOT_SIZES = (3, 8, 30)
PROTOCOL = MagneticProtocol(dwell_s=60.0, sample_s=5.0, turn_gap_s=100.0)
NOISE = GyroNoise(arw_deg_rt_h=0.005)
#: The priors of the population means (also the truth's distribution), deg/h and deg/h per
#: 100 uT, and the half-normal scales of the between-run sds.
MEAN_PRIORS = {"w0": Normal(1.0, 0.5), "wx": Normal(0.0, 0.3), "wy": Normal(-0.3, 0.3),
               "wz": Normal(0.0, 0.3)}
SPREAD_SCALES = {"w0": 0.3, "wx": 0.05, "wy": 0.1, "wz": 0.05}


def one_dataset(rng: np.random.Generator, n_runs: int, seed: int) -> dict:
    names = list(MEAN_PRIORS)
    mean = {n: rng.normal(MEAN_PRIORS[n].loc, MEAN_PRIORS[n].scale) for n in names}
    spread = {n: abs(rng.normal(0.0, SPREAD_SCALES[n])) for n in names}
    logs = []
    for _ in range(n_runs):
        values = {n: mean[n] + spread[n] * rng.standard_normal() for n in names}
        logs.append(simulate_magnetic_bench(parameters=values, protocol=PROTOCOL, noise=NOISE,
                                            seed=int(rng.integers(2**31))).log)
    labels = tuple(f"run_{r + 1:02d}" for r in range(n_runs))
    started = time.time()
    result = fit_pool(logs, labels, "magnetic", BenchOptions(noise="white"), seed=seed,
                      priors=MEAN_PRIORS, spread_scales=SPREAD_SCALES)  # the white runs as they are
    seconds = time.time() - started
    out = {"n_runs": n_runs, "seconds": seconds, "trustworthy": result.trustworthy,
           "converged": bool(result.posterior.converged),
           "failed_errors": [c.name for c in result.checks.failed if c.severity == "error"],
           "params": {}}
    mean_draws = result.mean_draws.reshape(-1, len(names))
    tau_draws = result.posterior.draws.reshape(-1, result.posterior.draws.shape[-1])
    for k, n in enumerate(names):
        for kind, truth, draws in (("mean", mean[n], mean_draws[:, k]),
                                   ("between_sd", spread[n], tau_draws[:, k])):
            covered = {}
            for level in LEVELS:
                lo, hi = np.quantile(draws, [(1 - level) / 2, (1 + level) / 2])
                covered[str(level)] = bool(lo <= truth <= hi)
            out["params"][f"{kind}:{n}"] = {"truth": truth, "rank": float(np.mean(draws < truth)),
                                            "covered": covered}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--datasets", type=int, nargs=3, default=(40, 40, 20),
                        metavar=("N3", "N8", "N30"), help="datasets per lot size (3, 8, 30)")
    args = parser.parse_args()
    started = time.time()
    rng = np.random.default_rng(args.seed)
    records = []
    for n_runs, count in zip(LOT_SIZES, args.datasets, strict=True):
        for i in range(count):
            records.append(one_dataset(rng, n_runs, seed=args.seed * 1000 + i))
            r = records[-1]
            print(f"lot of {n_runs}: {i + 1}/{count} ({r['seconds']:.1f} s)", flush=True)
    results = summarise(records)
    out = results_dir("pool_sbc")
    figure(records, out / "pool_sbc.png")
    save_run(out, seed=args.seed, config={"datasets": list(args.datasets),
                                          "lot_sizes": list(LOT_SIZES),
                                          "mean_priors": {k: [v.loc, v.scale] for k, v in
                                                          MEAN_PRIORS.items()},
                                          "spread_scales": SPREAD_SCALES,
                                          "protocol": "magnetic, dwell 60 s, 5 s samples"},
             results=results, started=started)


def summarise(records: list[dict]) -> dict:
    """Coverage per lot size and kind, with binomial 99 % bands, and rank uniformity."""
    out = {}
    for n_runs in LOT_SIZES:
        group = [r for r in records if r["n_runs"] == n_runs]
        if not group:
            continue
        entry = {"datasets": len(group),
                 "seconds_median": float(np.median([r["seconds"] for r in group])),
                 "converged": sum(r["converged"] for r in group),
                 "trustworthy": sum(r["trustworthy"] for r in group),
                 "failed_errors": sorted({n for r in group for n in r["failed_errors"]})}
        for kind in ("mean", "between_sd"):
            keys = [k for k in group[0]["params"] if k.startswith(kind + ":")]
            ranks = np.array([r["params"][k]["rank"] for r in group for k in keys])
            coverage = {}
            for level in LEVELS:
                hits = [r["params"][k]["covered"][str(level)] for r in group for k in keys]
                n = len(hits)
                lo, hi = stats.binom.ppf([0.005, 0.995], n, level) / n
                coverage[str(level)] = {"observed": float(np.mean(hits)), "n": n,
                                        "band99": [float(lo), float(hi)]}
            entry[kind] = {"coverage": coverage,
                           "rank_ks_p": float(stats.kstest(ranks, "uniform").pvalue)}
        out[f"lot_{n_runs}"] = entry
    return out


def figure(records: list[dict], path) -> None:
    fig, axes = plt.subplots(2, len(LOT_SIZES), figsize=(9, 5), sharey="row")
    for j, n_runs in enumerate(LOT_SIZES):
        group = [r for r in records if r["n_runs"] == n_runs]
        for i, kind in enumerate(("mean", "between_sd")):
            ranks = [v["rank"] for r in group for k, v in r["params"].items()
                     if k.startswith(kind + ":")]
            ax = axes[i][j]
            ax.hist(ranks, bins=10, range=(0, 1), color="0.6", edgecolor="0.0")
            if ranks:
                expected = len(ranks) / 10
                band = stats.binom.ppf([0.005, 0.995], len(ranks), 0.1)
                ax.axhspan(band[0], band[1], color="0.9", zorder=0)
                ax.axhline(expected, color="0.0", ls="--", lw=0.8)
            ax.set_title(f"{kind.replace('_', '-')}s, lots of {n_runs}")
            ax.set_xlabel("rank of the truth among draws (fraction)")
            ax.set_ylabel("count (datasets x coefficients)")
    fig.tight_layout()
    fig.savefig(path, dpi=130)


if __name__ == "__main__":
    main()
