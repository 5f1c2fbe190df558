"""gyroid against a plain NumPy/SciPy way of doing the same work, in one run.

    python benchmarks/run.py --quick --json out.json

Each benchmark checks that both ways give the same answer, then reports medians and the
ratio (baseline time / gyroid time; below 1 gyroid is slower). Every baseline is what a
competent researcher writes in a day: vectorised NumPy, sufficient statistics where they
apply, the same sampler and move, data passed as arguments. End-to-end cost against the
length of the log is benchmarks/scaling.py. Sections: likelihood_throughput, posterior_time,
point_fit, roll_monte_carlo, cold_start (compilation, in a fresh process), demo, help (the
CLI's --help in a fresh process).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import emcee
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from gyroid.bench import BenchOptions, BenchProblem
from gyroid.inference import Emcee, problem_batcher, summarise_draws
from gyroid.io import BenchLog
from gyroid.models import Flight, G, RollParams, correction_coefficients, navigation_errors
from gyroid.models._derived import RATE_WINDOW_S
from gyroid.simulation import (
    PAPER_A_DEVICE_2,
    PAPER_A_THERMAL,
    MagneticProtocol,
    ThermalProtocol,
    simulate_thermal_bench,
)


def _median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def six_hour_log(seed: int = 0) -> BenchLog:
    """6 h at 1 Hz with temperature steps and Helmholtz sweeps at once (all 'full' terms)."""
    protocol = ThermalProtocol(
        setpoints_C=(31.0, 40.0, 50.0), transition_min=60.0, soak_min=40.0, initial_min=60.0
    )
    sim = simulate_thermal_bench(
        seed=seed,
        protocol=protocol,
        parameters={**PAPER_A_THERMAL, **PAPER_A_DEVICE_2},
    )
    n = 6 * 3600
    columns = {k: v[:n] for k, v in sim.log.columns.items()}
    _, field = MagneticProtocol(turn_gap_s=0.0).schedule()
    field = np.resize(field, (n, 3))
    rng = np.random.default_rng(seed)
    truth = np.array([-0.037, -0.576, -0.253])
    columns["drift_deg_h"] = columns["drift_deg_h"] + field @ truth / 100.0
    for k, name in enumerate(("Hx_uT", "Hy_uT", "Hz_uT")):
        columns[name] = field[:, k] + rng.normal(0, 0.05, n)
    return BenchLog(columns=columns)


def sufficient_statistics(design, y) -> dict:
    """What a researcher computes once for a linear model with white noise."""
    return {"gram": design.T @ design, "xy": design.T @ y, "yy": float(y @ y), "n": y.size}


def numpy_log_posterior(stats, priors_scale, u):
    """What a competent researcher writes: every walker at once (emcee's ``vectorize``), on
    the sufficient statistics, in NumPy. ``u``: (walkers, d), the last column log sigma."""
    u = np.atleast_2d(u)
    theta, log_sigma = u[:, :-1], u[:, -1]
    rss = (stats["yy"] - 2.0 * theta @ stats["xy"]
           + np.einsum("ki,ij,kj->k", theta, stats["gram"], theta))
    loglik = -0.5 * rss / np.exp(2.0 * log_sigma) - stats["n"] * log_sigma
    prior = -0.5 * np.sum((theta / priors_scale) ** 2, axis=1) - 0.5 * (log_sigma / 3.0) ** 2
    return loglik + prior - 0.5 * stats["n"] * np.log(2 * np.pi)


def bench_likelihood(problem, design, y, scales, repeats):
    rng = np.random.default_rng(0)
    d = len(problem.names)
    u = rng.normal(0, 0.01, (64, d))
    u[:, -1] = np.log(0.3)
    batch = problem_batcher(problem.density.log_posterior)
    stats = sufficient_statistics(design, y)
    ours = np.asarray(batch(u))
    theirs = numpy_log_posterior(stats, scales, u)
    # Constant terms of the priors differ; compare differences between walkers.
    assert np.allclose(ours - ours[0], theirs - theirs[0], rtol=1e-8, atol=1e-6)
    calls = 200  # one batch takes ~0.1 ms: time many per repeat

    def many(f):
        def run():
            for _ in range(calls):
                f()
        return run

    t_ours = _median_time(many(lambda: np.asarray(batch(u))), repeats) / calls
    t_base = _median_time(many(lambda: numpy_log_posterior(stats, scales, u)), repeats) / calls
    return {
        "gyroid_evals_per_s": 64 / t_ours,
        "baseline_evals_per_s": 64 / t_base,
        "ratio": t_base / t_ours,
        "baseline": "NumPy on sufficient statistics, 64 walkers at once",
    }


def bench_posterior_repeated(problem, design, y, scales, seed, repeats):
    """``bench_posterior`` over ``repeats`` seeds: medians of every number, and the runs."""
    runs = [bench_posterior(problem, design, y, scales, seed + 10 * k) for k in range(repeats)]
    if repeats == 1:
        return runs[0]
    out = {key: float(np.median([r[key] for r in runs])) for key in runs[0]}
    out["ratio_of_medians"] = out["baseline_s"] / out["gyroid_s"]
    out["runs"] = runs
    return out


def bench_posterior(problem, design, y, scales, seed):
    settings = Emcee(progress=False)
    start = time.perf_counter()
    point = problem.mode()
    post = settings.sample(problem, point, seed=seed)
    t_ours = time.perf_counter() - start  # cold: includes compiling for the sampler's shapes
    start = time.perf_counter()
    warm = settings.sample(problem, problem.mode(), seed=seed + 1)
    t_warm = time.perf_counter() - start
    min_ess = min(v["ess_bulk"] for v in post.summary.values())
    # Baseline: emcee as a competent researcher runs it: the same DE move, every walker at
    # once (vectorize=True) on sufficient statistics, the same walkers and start, run in
    # chunks until the same stopping rule holds (50 tau, r_hat <= 1.01, every ESS >= 400).
    start = time.perf_counter()
    d = len(problem.names)
    walkers = post.draws.shape[0]
    stats = sufficient_statistics(design, y)
    rng = np.random.default_rng(seed)
    p0 = point.u + 1e-3 * rng.standard_normal((walkers, d)) * np.sqrt(np.diag(point.covariance_u))
    sampler = emcee.EnsembleSampler(walkers, d, lambda u: numpy_log_posterior(stats, scales, u),
                                    vectorize=True, moves=emcee.moves.DEMove())
    state = sampler.run_mcmc(p0, 300, progress=False)
    while True:  # the same stopping rule as gyroid's sampler (checked once 50 tau is reached)
        state = sampler.run_mcmc(state, 500, progress=False)
        tau = float(np.max(sampler.get_autocorr_time(discard=300, tol=0)))
        if sampler.iteration - 300 < 50 * tau and sampler.iteration < 30000:
            continue
        chain = np.transpose(sampler.get_chain(discard=300), (1, 0, 2))
        natural = chain.copy()
        natural[..., -1] = np.exp(natural[..., -1])
        summary = summarise_draws(natural[:, :: max(1, int(tau / 2))], problem.names)
        base_ess = min(v["ess_bulk"] for v in summary.values())
        good = all(v["r_hat"] <= 1.01 for v in summary.values()) and base_ess >= 400
        if good or sampler.iteration >= 30000:
            break
    t_base = time.perf_counter() - start
    # Same answer: posterior means agree within a few Monte-Carlo errors.
    ours = post.draws.reshape(-1, d).mean(axis=0)
    theirs = natural.reshape(-1, d).mean(axis=0)
    sd = post.draws.reshape(-1, d).std(axis=0)
    assert np.all(np.abs(ours - theirs) < 6 * sd / np.sqrt(min_ess)), (ours, theirs)
    return {
        "gyroid_s": t_ours,
        "baseline_s": t_base,
        "ratio": t_base / t_ours,
        "gyroid_warm_s": t_warm,
        "gyroid_warm_steps": warm.n_steps,
        "min_ess": min_ess,
        "baseline_min_ess": base_ess,
        # Where the ratio comes from: steps needed (set by the move's autocorrelation time)
        # times the cost of a step (log-probability of all walkers plus emcee's own work).
        "gyroid_steps": post.n_steps,
        "baseline_steps": int(sampler.iteration),
        "gyroid_tau_max_steps": float(np.max(post.tau_steps)),
        "baseline_tau_max_steps": tau,
        "gyroid_ms_per_step": 1e3 * t_ours / post.n_steps,
        "baseline_ms_per_step": 1e3 * t_base / sampler.iteration,
    }


def bench_point(problem, design, y, repeats):
    """Least squares of the 'full' model, flat priors, both ways (warm): gyroid's point fit
    against NumPy's lstsq on the design matrix (a linear model needs nothing more)."""
    start = time.perf_counter()
    problem.mode()
    first = time.perf_counter() - start
    t_ours = _median_time(lambda: problem.mode(), repeats)
    ours = problem.mode().value
    solution = np.linalg.lstsq(design, y, rcond=None)[0]
    assert np.allclose(solution, [ours[n] for n in problem.model.parameter_names], rtol=1e-6,
                       atol=1e-8)
    t_base = _median_time(lambda: np.linalg.lstsq(design, y, rcond=None), repeats)
    return {
        "gyroid_s": t_ours,
        "baseline_s": t_base,
        "ratio": t_base / t_ours,
        "compile_s": first - t_ours,
        "baseline": "numpy.linalg.lstsq on the design matrix",
        "note": "gyroid's time includes its covariance, noise level and convergence report",
    }


def bench_roll(draws: int, quick: bool):
    sample_s, duration = 1e-3, 120.0
    n = int(duration / sample_s)
    rng = np.random.default_rng(0)
    d1 = 600e-6 + 30e-6 * rng.standard_normal(draws)
    d0gs = 3.3e-3 + 3e-4 * rng.standard_normal(draws)
    flight = Flight(
        jnp.full(n, 900.0),
        jnp.full(n, 300.0),
        jnp.zeros(n),
        jnp.zeros(n),
        jnp.zeros(n),
        sample_s=sample_s,
        period_s=5.0,
    )

    # The flight is an argument, not a constant closed over: XLA would fold a closed-over
    # flight into the compiled program (4000x faster, and unfair: a new flight recompiles).
    @eqx.filter_jit
    def batch(flight, d1, d0gs):
        return jax.vmap(lambda a, b: correction_coefficients(RollParams(D1=a, D0gs=b), flight))(
            d1, d0gs)

    chunk = 1000
    batch(flight, jnp.asarray(d1[:chunk]), jnp.asarray(d0gs[:chunk])).block_until_ready()

    def ours():
        return np.concatenate(
            [
                np.asarray(batch(flight, jnp.asarray(d1[i : i + chunk]),
                                 jnp.asarray(d0gs[i : i + chunk])))
                for i in range(0, draws, chunk)
            ]
        )

    start = time.perf_counter()
    dk = ours()
    t_ours = time.perf_counter() - start

    m = 5000
    report = np.array([10_000, 60_000, 120_000]) - 1  # samples at 10, 60 and 120 s

    def numpy_loop(a, b, navigation=False):
        """The loop as a researcher writes it for one draw: per-sample angles in NumPy."""
        w = np.full(n, 900.0)
        true = np.cumsum(w) * sample_s
        sins = (1 + a) * w
        mems = np.clip(b + (1 + 280e-6) * 300.0, -330, 330)
        gs = true + np.cumsum(np.full(n, mems - 300.0)) * sample_s + 0.33 * np.sin(np.deg2rad(true))
        raw = sins.reshape(-1, m).sum(axis=1) * sample_s
        gs_end = np.concatenate([[0.0], gs[m - 1 :: m]])
        estimate = (raw - np.diff(gs_end)) / raw
        dk = (1 - estimate) * (1 + a) - 1
        if not navigation:
            return dk
        applied = np.concatenate([[1.0], 1 - estimate[:-1]])
        error = np.cumsum(sins * np.repeat(applied, m)) * sample_s - true
        velocity = np.cumsum(G * np.sin(np.deg2rad(error))) * sample_s
        position = np.cumsum(velocity) * sample_s
        return dk, error[report], position[report]

    subset = 50 if quick else 200
    start = time.perf_counter()
    base = np.array([numpy_loop(a, b) for a, b in zip(d1[:subset], d0gs[:subset], strict=True)])
    t_base = (time.perf_counter() - start) * draws / subset
    assert np.allclose(base, dk[:subset], rtol=1e-8, atol=1e-12)

    # Navigation errors (roll and lateral error at 10/60/120 s) need the per-sample angle
    # error: gyroid's navigation_errors (one cumulative sum and one sine per sample) against
    # the NumPy loop above; both run a subset of the draws, scaled.
    index = jnp.asarray(report)

    @eqx.filter_jit
    def navigation(flight, d1, d0gs):
        return jax.vmap(lambda a, b: navigation_errors(RollParams(D1=a, D0gs=b), flight,
                                                       index))(d1, d0gs)

    nav_chunk = 128
    nav_subset = 2 * nav_chunk if quick else 8 * nav_chunk
    jax.block_until_ready(navigation(flight, jnp.asarray(d1[:nav_chunk]),
                                     jnp.asarray(d0gs[:nav_chunk])))
    start = time.perf_counter()
    nav = [navigation(flight, jnp.asarray(d1[i : i + nav_chunk]),
                      jnp.asarray(d0gs[i : i + nav_chunk]))
           for i in range(0, nav_subset, nav_chunk)]
    jax.block_until_ready(nav)
    t_nav = (time.perf_counter() - start) * draws / nav_subset
    base_subset = 10 if quick else 40
    start = time.perf_counter()
    base_nav = [numpy_loop(a, b, navigation=True)
                for a, b in zip(d1[:base_subset], d0gs[:base_subset], strict=True)]
    t_base_nav = (time.perf_counter() - start) * draws / base_subset
    for k, (dk_b, error_b, position_b) in enumerate(base_nav):
        np.testing.assert_allclose(nav[0].dK[k], dk_b, rtol=1e-8, atol=1e-12)
        np.testing.assert_allclose(nav[0].angle_error_deg[k], error_b, rtol=1e-6, atol=1e-8)
        np.testing.assert_allclose(nav[0].lateral_error_m[k], position_b, rtol=1e-6, atol=1e-8)
    return {
        "gyroid_s": t_ours,
        "baseline_s": t_base,
        "ratio": t_base / t_ours,
        "draws": draws,
        "baseline_note": f"dK per period (per-period fast path); baseline ran {subset} draws, "
                         "scaled",
        "navigation_gyroid_s": t_nav,
        "navigation_baseline_s": t_base_nav,
        "navigation_ratio": t_base_nav / t_nav,
        "navigation_note": f"dK plus roll and lateral error at 10/60/120 s (per-sample angle "
                           f"error); gyroid ran {nav_subset} draws and the baseline "
                           f"{base_subset}, both scaled to {draws}",
    }


_COLD_START = """
import json, sys, time
start = time.perf_counter()
sys.path.insert(0, "benchmarks")
from run import six_hour_log
from gyroid.inference import BenchProblem
from gyroid.inference import Emcee
out = {"import_s": time.perf_counter() - start}
problem = BenchProblem.from_log(six_hour_log(0), "full")
settings = Emcee(progress=False)
for label in ("cold", "warm"):
    start = time.perf_counter()
    point = problem.mode()
    out[f"point_{label}_s"] = time.perf_counter() - start
    start = time.perf_counter()
    post = settings.sample(problem, point, seed=0)
    out[f"posterior_{label}_s"] = time.perf_counter() - start
print(json.dumps(out))
"""


def bench_cold_start():
    """Compilation cost, measured in a fresh process: the first fit of the 6 h log against
    the second (same shapes: nothing is compiled again)."""
    run = subprocess.run([sys.executable, "-c", _COLD_START], check=True, capture_output=True,
                         text=True, cwd=Path(__file__).resolve().parents[1])
    out = json.loads(run.stdout.strip().splitlines()[-1])
    out["compile_s"] = (out["point_cold_s"] + out["posterior_cold_s"]
                        - out["point_warm_s"] - out["posterior_warm_s"])
    return out


_MEASURE = (
    "import json, os, resource, subprocess, sys, time\n"
    "def tree_rss(root):  # resident bytes of root and its descendants (Linux /proc)\n"
    "    parent, rss = {}, {}\n"
    "    for pid in filter(str.isdigit, os.listdir('/proc')):\n"
    "        try:\n"
    "            stat = open(f'/proc/{pid}/stat').read().rsplit(')', 1)[1].split()\n"
    "            pages = int(open(f'/proc/{pid}/statm').read().split()[1])\n"
    "        except (OSError, IndexError, ValueError):\n"
    "            continue\n"
    "        parent[int(pid)], rss[int(pid)] = int(stat[1]), pages * os.sysconf('SC_PAGE_SIZE')\n"
    "    tree, grew = {root}, True\n"
    "    while grew:\n"
    "        new = {p for p, q in parent.items() if q in tree} - tree\n"
    "        grew, tree = bool(new), tree | new\n"
    "    return sum(rss.get(p, 0) for p in tree)\n"
    "start = time.perf_counter()\n"
    "child = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)\n"
    "total = 0\n"
    "while child.poll() is None:\n"
    "    total = max(total, tree_rss(child.pid))\n"
    "    time.sleep(0.1)\n"
    "seconds = time.perf_counter() - start\n"
    "if child.returncode:\n"
    "    sys.exit(child.stderr.read().decode())\n"
    "print(json.dumps({'seconds': seconds,\n"
    "  'peak_rss_mb': resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,\n"
    "  'peak_total_rss_mb': total / 2**20}))\n"
)


def bench_demo():
    """``gyroid demo`` in a fresh process, with the compilation cache off (cold) and on
    (warm: the programs compiled by the cold run). Memory: the largest process's peak (a
    wrapper process waits for the demo alone, so no other child of this run counts) and
    the peak of the demo's processes together (sampled every 0.1 s): the demo runs two."""
    out = {}
    with tempfile.TemporaryDirectory() as folder:
        for label, cache in (("cold", "off"), ("warm", str(Path(folder) / "cache"))):
            if label == "warm":  # fill the cache first
                subprocess.run([sys.executable, "-m", "gyroid", "demo", "--out",
                                str(Path(folder) / "fill")], check=True, capture_output=True,
                               env={**os.environ, "GYROID_JAX_CACHE": cache})
            run = subprocess.run(
                [sys.executable, "-c", _MEASURE, sys.executable, "-m", "gyroid", "demo",
                 "--out", str(Path(folder) / label)], check=True, capture_output=True,
                text=True, env={**os.environ, "GYROID_JAX_CACHE": cache})
            measured = json.loads(run.stdout)
            out[f"{label}_seconds"] = measured["seconds"]
            out[f"{label}_peak_rss_mb"] = measured["peak_rss_mb"]
            out[f"{label}_peak_total_rss_mb"] = measured["peak_total_rss_mb"]
    return out


def bench_help():
    """``gyroid --help`` and ``gyroid fit --help`` in fresh processes: seconds, the median of
    five runs each (every run kept)."""
    out = {}
    for label, command in (("gyroid", ["--help"]), ("gyroid_fit", ["fit", "--help"])):
        runs = []
        for _ in range(5):
            started = time.perf_counter()
            subprocess.run([sys.executable, "-m", "gyroid", *command], check=True,
                           capture_output=True)
            runs.append(time.perf_counter() - started)
        out[label] = {"seconds": sorted(runs)[2], "seconds_all": runs}
    return out


def bench_problems(seed: int):
    """The 6 h log's problem (paper A's FOG priors: the registry's fixed scales, which the
    NumPy baseline writes out; the default priors are scaled to each log), its flat-prior
    twin, and the baseline's design matrix, data and prior scales. The thermometer's noise
    is left out of the likelihood (``errors_in_variables=False``), as the baseline leaves
    it out: the same density on both sides."""
    log = six_hour_log(seed)
    problem = BenchProblem.from_log(log, "full",
                                    BenchOptions(noise="white", prior_set="paper_a_fog",
                                                 rate_window_s=RATE_WINDOW_S,
                                                 errors_in_variables=False))
    flat = BenchProblem.from_log(log, "full",
                                 BenchOptions(noise="white", prior_set="flat",
                                              rate_window_s=RATE_WINDOW_S,
                                              errors_in_variables=False))
    design = np.asarray(problem.model.design(problem.inputs))
    y = np.asarray(problem.density.drift)
    scales = np.array([p.prior.scale for p in problem.model.parameters])
    return problem, flat, design, y, scales


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats and draws")
    parser.add_argument("--json", type=Path, default=None, help="write the results here")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", nargs="*", default=None,
                        help="run only these jobs (e.g. demo); default: all")
    args = parser.parse_args()
    repeats = 5 if args.quick else 20
    problem, flat, design, y, scales = bench_problems(args.seed)
    results = {}
    for name, run in (
        ("likelihood_throughput", lambda: bench_likelihood(problem, design, y, scales, repeats)),
        ("posterior_time", lambda: bench_posterior_repeated(problem, design, y, scales,
                                                            args.seed, 3)),
        ("point_fit", lambda: bench_point(flat, design, y, repeats)),
        ("roll_monte_carlo", lambda: bench_roll(10000, args.quick)),
        ("cold_start", bench_cold_start),
        ("demo", bench_demo),
        ("help", bench_help),
    ):
        if args.jobs is not None and name not in args.jobs:
            continue
        print(f"-- {name} ...", flush=True)
        results[name] = run()
        print(json.dumps(results[name], indent=2), flush=True)
    if args.json:
        from gyroid.io import atomic_write_text

        atomic_write_text(args.json, json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
