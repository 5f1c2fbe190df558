"""Simulation-based calibration of the default fit (IEEE 952 noise, its noise levels
sampled by importance sampling, emcee where that fails): truths drawn from the fit's
priors, a 4 h log at 1 Hz simulated from the model's own noise process, the rank of each
truth among its posterior's draws.

The log: ``w0 + w1 (T - 21)`` with a temperature sine of +-15 degC over the 4 h, plus white
rate noise (per-sample sd ``60 N / sqrt(dt)`` deg/h), flicker as the model writes it (the
sum of Gauss-Markov processes of the fit's correlation times, each of variance
``B^2 ln(r)/pi``, started stationary, sampled exactly at 1 s) and a rate random walk
(diffusing ``(K/60)^2`` (deg/h)^2 per second, centred on its mean over the log, as the
model has no anchor for it: ``w0`` is the bias over the log). The priors are fixed here
(not chosen from the data, which SBC needs): ``w0 ~ N(0, 1)`` deg/h, ``w1 ~ N(0, 0.1)``
deg/h/degC, ``N ~ LogNormal(0.005, 0.5)``, ``B ~ LogNormal(0.01, 1)``,
``K ~ LogNormal(0.005, 1)``. The samples are a discrete-time version of the model's
continuous processes (the filter integrates them over each 15-sample block exactly); at
1 s against blocks of 15 s the two differ by a few per cent in the shortest flicker term.
``--substeps 10`` simulates the noise ten times finer and reports each sample as the mean
over its second, as a gyro's integrated output is.

    python experiments/sbc_ieee.py --seed 0 --datasets 200 --workers 2
    python experiments/sbc_ieee.py --seed 0 --datasets 200 --workers 2 --substeps 10 \
        --results sbc_ieee_substeps
"""

from __future__ import annotations

import argparse
import math
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from _common import gauss_markov_sum, results_dir, save_run
from scipy import stats

ROWS, DT = 14400, 1.0
TERMS = "bias,temperature"
LEVELS = (0.5, 0.9, 0.95)


def priors():
    from gyroid.models import LogNormal
    from gyroid.models._priors import Normal

    return {"w0": Normal(0.0, 1.0), "w1": Normal(0.0, 0.1),
            "N_deg_sqrt_h": LogNormal(0.005, 0.5), "B_deg_h": LogNormal(0.01, 1.0),
            "K_deg_h_sqrt_h": LogNormal(0.005, 1.0)}


def draw_truth(rng: np.random.Generator) -> dict[str, float]:
    out = {}
    for name, prior in priors().items():
        if hasattr(prior, "median"):
            out[name] = float(prior.median * math.exp(prior.log_sd * rng.standard_normal()))
        else:
            out[name] = float(prior.loc + prior.scale * rng.standard_normal())
    return out


def simulate(truth: dict[str, float], flicker_tau_s, flicker_unit_var: float,
             rng: np.random.Generator, substeps: int = 1) -> dict[str, np.ndarray]:
    """The log; ``substeps`` > 1 simulates the noise that many times finer and reports each
    sample as the mean over its step, as a gyro's integrated output is."""
    time_s = np.arange(ROWS) * DT
    temperature = 21.0 + 15.0 * np.sin(2.0 * math.pi * time_s / (ROWS * DT))
    n, dt = ROWS * substeps, DT / substeps
    noise = 60.0 * truth["N_deg_sqrt_h"] / math.sqrt(dt) * rng.standard_normal(n)
    noise = noise + gauss_markov_sum(rng, n, dt, flicker_tau_s,
                                     truth["B_deg_h"] ** 2 * flicker_unit_var)
    walk = np.cumsum(truth["K_deg_h_sqrt_h"] / 60.0 * math.sqrt(dt) * rng.standard_normal(n))
    noise = (noise + walk - walk.mean()).reshape(ROWS, substeps).mean(axis=1)
    drift = truth["w0"] + truth["w1"] * (temperature - 21.0) + noise
    return {"time_s": time_s, "temperature_C": temperature, "drift_deg_h": drift}


def one(seed: int, substeps: int = 1) -> dict:
    import gyroid
    from gyroid.bench import BenchOptions, BenchProblem, fit_log
    from gyroid.inference import Emcee, Importance
    from gyroid.io import BenchLog
    from gyroid.models._derived import RATE_WINDOW_S
    from gyroid.noise import Flicker

    gyroid.configure()
    started = time.time()
    rng = np.random.default_rng(seed)
    truth = draw_truth(rng)
    clock = simulate({k: 0.0 if k != "N_deg_sqrt_h" else 1.0 for k in truth}, [], 0.0, rng)
    noise = BenchProblem.from_log(BenchLog(clock), TERMS,
                                  BenchOptions(noise="white+flicker+rw", priors=priors(),
                                               rate_window_s=RATE_WINDOW_S)).density.noise
    flicker = next(t for t in noise.terms if isinstance(t, Flicker))
    columns = simulate(truth, np.asarray(flicker.tau_s), float(flicker.unit_var), rng, substeps)
    fit = fit_log(BenchLog(columns), TERMS, BenchOptions(noise="auto", priors=priors()), seed=seed,
                  sampler=Importance(fallback=Emcee(progress=False)))
    draws = fit.posterior.draws.reshape(-1, len(fit.problem.names))
    ranks = {name: float(np.mean(draws[:, i] < truth[name]))
             for i, name in enumerate(fit.problem.names)}
    return {"seed": seed, "truth": truth, "ranks": ranks, "sampler": fit.posterior.move,
            "trustworthy": fit.trustworthy, "seconds": round(time.time() - started, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--datasets", type=int, default=200)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--substeps", type=int, default=1,
                        help="simulate the noise this many times finer, each sample the mean")
    parser.add_argument("--results", default="sbc_ieee")
    args = parser.parse_args()
    started = time.time()
    seeds = [args.seed * 100000 + k for k in range(args.datasets)]
    with ProcessPoolExecutor(args.workers) as pool:
        runs = list(pool.map(one, seeds, [args.substeps] * len(seeds)))
    names = list(runs[0]["ranks"])
    summary = {}
    for name in names:
        ranks = np.array([r["ranks"][name] for r in runs])
        summary[name] = {
            "ks_pvalue": float(stats.kstest(ranks, "uniform").pvalue),
            "mean_rank": float(ranks.mean()),
            "coverage": {f"{int(100 * lv)}%": float(np.mean(np.abs(ranks - 0.5) <= lv / 2))
                         for lv in LEVELS},
        }
    summary["importance_sampled"] = sum(r["sampler"] == "psis" for r in runs)
    summary["trustworthy"] = sum(r["trustworthy"] for r in runs)
    summary["median_seconds"] = float(np.median([r["seconds"] for r in runs]))
    config = {"datasets": args.datasets, "rows": ROWS, "dt_s": DT, "terms": TERMS,
              "substeps": args.substeps,
              "priors": {k: repr(v) for k, v in priors().items()}, "workers": args.workers}
    save_run(results_dir(args.results), seed=args.seed, config=config,
             results={"summary": summary, "runs": runs}, started=started)


if __name__ == "__main__":
    main()
