"""Experiment (issue 42): paper A's thermal bench with the noise every real FOG has, fitted as
``gyroid fit --terms thermal`` fits it by default: each fit must either refuse (exit 3) or
cover the truths with its 95 % intervals at the nominal rate, and none may exit 0 with a
truth more than 3.3 posterior sd away.

Everything about the log is written here, independently of gyroid's simulator: 10 h at
1 Hz; paper A's coefficients (``w0=1.197, w1=-0.108, w2=0.004, wD=1.997``, t0 = 21 degC)
applied to the true temperature and its exact rate; white noise 0.005 deg/sqrt(h), flicker
of bias instability 0.01 deg/h (spectral shaping, :func:`_common.flicker_noise`), a rate
random walk of 0.005 deg/h/sqrt(h) (a cumulative sum), and a thermometer read with white
noise of 0.01 degC. The truth of ``w0`` is the bias over the log: paper A's plus the
walk's mean over the log (a walk has no level of its own). Two temperature profiles:

* ``smooth``: one sine cycle of +-20 degC about 21 degC over the 10 h;
* ``raised_cosine``: plateaus at 21, 41, 1 and 21 degC joined by 1 h raised-cosine
  transitions (the curvature jumps at each end of a transition, where the dT/dt estimator's
  own error is largest).

    python experiments/fog_thermal_bench.py --seed 0 --datasets 30 --noise auto \
        --results fog_thermal_bench
    python experiments/fog_thermal_bench.py --seed 0 --datasets 30 --noise white \
        --results fog_thermal_bench_white --white-only

Each log is fitted twice (once with ``--warmup``): by default (the
run's ``z``, ``sd``, ``seconds``), and with the noise levels pinned at their truths
(``z_known_noise``: what the realisation alone does to the coefficients, apart from the
noise levels' inference; not for ``--white-only``).

``--flicker-walk-median X`` gives B and K the prior LogNormal(X, 3) instead of gyroid's
default (median a thousandth of the log's white density: 3e-4 here): a study of what the
priors trade between logs with a FOG's flicker and walk and logs without.

``--static-hours H`` first simulates the same gyro at rest for H hours (the same white
noise, flicker and walk, an independent realisation, a constant temperature), fits its
noise as ``gyroid noise`` does and fits the bench with IEEE noise priors from that fit, as
``gyroid fit --noise DIR`` does (paper A's bench would record such a run): what a measured
noise buys where a 10 h thermal log cannot tell a FOG's flicker from none.

``--warmup [W]`` adds a start-up transient ``w exp(-t / tau)`` (w = W deg/h, 0.05 unless
given: five times the flicker's Allan floor at its start; tau = 40 min) and fits
``thermal,warmup``: the
coverage of a model with a time constant under the default correlated noise, whose mode
the profiled mode-finder finds (the time constant profiled, the coefficients integrated
out) and whose posterior the sampler draws.

``--flicker markov`` simulates the flicker as gyroid's noise model writes it (six
Gauss-Markov processes, correlation times from a quarter of the fit's 36 s blocks to four
times the log's length, :func:`_common.markov_flicker`) instead of by spectral shaping over
twice the log (whose flicker has no power below 1/(20 h) and none of the model's slowest
process): whether a miss is the realisation or the difference between the two flickers.

``--datasheet`` fits with the noise levels' priors from a datasheet that states the bench's
own ARW, B and K (written to a TOML file and read as ``gyroid fit --noise FILE.toml`` reads
it), and fits the same log by default too: whether the datasheet's intervals cover at the
nominal rate, and how wide they are beside the default's interval and the default's range
over the noise levels the log allows (``width_95``: each coefficient's interval width with
the datasheet, ``width_95_default``, ``range_95_default``).

``--white-only`` drops the flicker and the walk (white noise and the thermometer's only):
what the default costs where there is nothing low-frequency to carry (the posterior sds
beside ``--noise white``'s on the same logs). ``--workers 2`` runs two processes.
"""

from __future__ import annotations

import argparse
import math
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from _common import flicker_noise, markov_flicker, results_dir, save_run

TRUTH = {"w0": 1.197, "w1": -0.108, "w2": 0.004, "wD": 1.997}
T0_C = 21.0
HOURS, RATE_HZ = 10.0, 1.0
ARW, B, K = 0.005, 0.01, 0.005  # deg/sqrt(h), deg/h, deg/h/sqrt(h)
THERMOMETER_SD_C = 0.01
PROFILES = ("smooth", "raised_cosine")
WARMUP = {"w_warmup": 0.05, "tau_warmup_min": 40.0}  # deg/h, min (w: --warmup's default)


def temperature_profile(profile: str, time_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The true temperature (degC) and its rate (degC/h) at ``time_s``."""
    hours = time_s / 3600.0
    if profile == "smooth":
        phase = 2.0 * math.pi * hours / HOURS
        return (T0_C + 20.0 * np.sin(phase),
                20.0 * 2.0 * math.pi / HOURS * np.cos(phase))
    # plateaus joined by raised-cosine transitions of 1 h
    levels = [21.0, 41.0, 1.0, 21.0]
    starts = [1.5, 4.5, 7.5]  # h: each transition's start
    temperature = np.full_like(hours, levels[0])
    rate = np.zeros_like(hours)
    for k, start in enumerate(starts):
        s = np.clip(hours - start, 0.0, 1.0)
        step = levels[k + 1] - levels[k]
        temperature += step * 0.5 * (1.0 - np.cos(math.pi * s))
        inside = (hours > start) & (hours < start + 1.0)
        rate += np.where(inside, step * 0.5 * math.pi * np.sin(math.pi * s), 0.0)
    return temperature, rate


def fog_log(seed: int, profile: str, white_only: bool = False, warmup: float | None = None,
            flicker: str = "spectral") -> dict[str, np.ndarray]:
    """One bench log's columns (contract section 1), with a start-up transient of
    ``warmup`` deg/h (:data:`WARMUP`'s time constant) if given; ``flicker``: "spectral"
    (:func:`_common.flicker_noise`) or "markov" (:func:`_common.markov_flicker`, the
    model's own construction for this log: 1000 block means of 36 s)."""
    rng = np.random.default_rng([seed, PROFILES.index(profile), 42])
    dt = 1.0 / RATE_HZ
    n = int(HOURS * 3600 * RATE_HZ)
    time_s = np.arange(n) * dt
    temperature, rate = temperature_profile(profile, time_s)
    t = temperature - T0_C
    drift = TRUTH["w0"] + TRUTH["w1"] * t + TRUTH["w2"] * t**2 + TRUTH["wD"] * rate
    if warmup:
        drift = drift + warmup * np.exp(-time_s / (60.0 * WARMUP["tau_warmup_min"]))
    noise = rng.normal(0.0, 60.0 * ARW / math.sqrt(dt), n)
    walk = np.zeros(n)
    if not white_only:
        if flicker == "markov":
            block_s = HOURS * 3600.0 / 1000.0
            noise += markov_flicker(rng, n, dt, B, block_s / 4.0, 4.0 * HOURS * 3600.0)
        else:
            noise += flicker_noise(rng, n, dt, B)
        walk = np.cumsum(rng.normal(0.0, K / 60.0 * math.sqrt(dt), n))
    # w0's truth is the bias over the log: a random walk has no level of its own, the
    # flicker (stationary) its long-run mean, zero
    return {"time_s": time_s, "drift_deg_h": drift + noise + walk,
            "temperature_C": temperature + rng.normal(0.0, THERMOMETER_SD_C, n),
            "w0_over_the_log": TRUTH["w0"] + float(walk.mean())}


def static_log(seed: int, hours: float) -> np.ndarray:
    """The gyro at rest at a constant temperature: paper A's bias plus the bench's white
    noise, flicker and walk (deg/h at 1 Hz; its own random stream)."""
    rng = np.random.default_rng([seed, 7, 42])
    dt = 1.0 / RATE_HZ
    n = int(hours * 3600 * RATE_HZ)
    return (TRUTH["w0"] + rng.normal(0.0, 60.0 * ARW / math.sqrt(dt), n)
            + flicker_noise(rng, n, dt, B)
            + np.cumsum(rng.normal(0.0, K / 60.0 * math.sqrt(dt), n)))


def measured_noise_priors(seed: int, hours: float) -> tuple[dict, dict]:
    """IEEE noise priors from ``gyroid noise``'s fit of :func:`static_log` (as ``gyroid fit
    --noise DIR`` makes them), and what that fit found (terms' means and intervals)."""
    from gyroid.allan import fit_noise
    from gyroid.noise import noise_model, priors_from_noise

    fitted = fit_noise(static_log(seed, hours), 1.0 / RATE_HZ, seed=seed)
    terms = fitted.term_summaries()
    found = {k: {"mean": terms[k].get("mean"), "ci90": terms[k].get("ci90"),
                 "resolved": terms[k].get("resolved")} for k in ("N", "B", "K")}
    return (priors_from_noise(terms, noise_model("white+flicker+rw")),
            {"trustworthy": fitted.trustworthy, "terms": found})


def datasheet_priors_of_the_bench() -> dict:
    """The noise priors ``gyroid fit --noise FILE.toml`` takes from a datasheet stating this
    bench's ARW, B and K (the file written and read as the command reads it)."""
    import tempfile
    from pathlib import Path

    from gyroid.io._datasheet import datasheet_priors, read_datasheet

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "fog.toml"
        path.write_text(f'[gyro]\narw = "{ARW} deg/sqrt(h)"\nbias_instability = "{B} deg/h"\n'
                        f'rate_random_walk = "{K} deg/h/sqrt(h)"\n')
        return datasheet_priors(read_datasheet(path))


def one(seed: int, profile: str, noise: str, white_only: bool,
        flicker_walk_median: float | None = None, static_hours: float | None = None,
        warmup: float | None = None, flicker: str = "spectral",
        datasheet: bool = False) -> dict:
    import gyroid
    from gyroid.bench import BenchOptions, fit_log
    from gyroid.inference import Emcee, Importance
    from gyroid.io import BenchLog
    from gyroid.models import LogNormal

    gyroid.configure()
    started = time.time()
    columns = fog_log(seed, profile, white_only, warmup, flicker)
    truth = dict(TRUTH, w0=columns.pop("w0_over_the_log"),
                 **(dict(WARMUP, w_warmup=warmup) if warmup else {}))
    terms = "thermal,warmup" if warmup else "thermal"
    chosen = None if flicker_walk_median is None else {
        name: LogNormal(flicker_walk_median, 3.0) for name in ("B_deg_h", "K_deg_h_sqrt_h")}
    static = None
    if static_hours:
        chosen, static = measured_noise_priors(seed, static_hours)
        noise = "white+flicker+rw"  # the noise model whose priors those are
    if datasheet:
        chosen, noise = datasheet_priors_of_the_bench(), "white+flicker+rw"
    fit = fit_log(BenchLog(columns), terms, BenchOptions(noise=noise, priors=chosen), seed=seed,
                  sampler=Importance(fallback=Emcee(progress=False)))
    seconds = round(time.time() - started, 1)  # the default fit's alone
    widths = _datasheet_widths(fit, columns, terms, seed, truth) if datasheet else None
    summary = fit.posterior.summary
    z = {name: (summary[name]["mean"] - value) / summary[name]["sd"]
         for name, value in truth.items()}
    # the same fit with the noise levels pinned at their truths: what the realisation
    # alone does to the coefficients, apart from the noise levels' inference
    pinned = {"N_deg_sqrt_h": LogNormal(ARW, 0.01), "B_deg_h": LogNormal(B, 0.01),
              "K_deg_h_sqrt_h": LogNormal(K, 0.01)}
    known = (fit_log(BenchLog(columns), terms, BenchOptions(noise=noise, priors=pinned), seed=seed,
                     sampler=Importance(fallback=Emcee(progress=False))).posterior.summary
             if fit.problem.noise.name == "white+flicker+rw" and not white_only
             and not static_hours and not warmup and not datasheet else None)
    return {"seed": seed, "profile": profile, "noise": noise,
            "noise_used": fit.problem.noise.name, "trustworthy": fit.trustworthy,
            "sampler": fit.posterior.move,
            "failed_errors": [c.name for c in fit.checks.failed if c.severity == "error"],
            "failed_messages": [c.message for c in fit.checks.failed if c.severity == "error"],
            "inside_95": {name: bool(summary[name]["ci95"][0] <= value
                                     <= summary[name]["ci95"][1])
                          for name, value in truth.items()},
            "z": {k: round(v, 3) for k, v in z.items()},
            "z_known_noise": None if known is None else {
                k: round((known[k]["mean"] - v) / known[k]["sd"], 3) for k, v in truth.items()},
            "sd": {k: summary[k]["sd"] for k in truth},
            "w0_truth": truth["w0"],
            "rate_window_s": round(float(fit.problem.rate_window_s), 1),
            "noise_median": {name: float(np.median(fit.posterior.draws[..., i]))
                             for i, name in enumerate(fit.problem.names)
                             if name not in truth},
            "static_noise_fit": static,
            "allowed_noise": _allowed(fit, truth),
            "datasheet": widths,
            "seconds": seconds}


def _datasheet_widths(fit, columns: dict, terms: str, seed: int, truth: dict) -> dict:
    """Each coefficient's 95 % interval width with the datasheet's priors, and on the same
    log by default: its interval's width and its range's over the noise levels the log
    allows (what the default's noise_prior_dependence says to read instead), and whether
    the truth lies in each."""
    from gyroid.bench import fit_log
    from gyroid.inference import Emcee, Importance
    from gyroid.io import BenchLog

    default = fit_log(BenchLog(columns), terms, seed=seed,
                      sampler=Importance(fallback=Emcee(progress=False)))
    mine, theirs = fit.posterior.summary, default.posterior.summary
    allowed = default.allowed_noise
    return {
        "trustworthy_default": default.trustworthy,
        "width_95": {k: mine[k]["ci95"][1] - mine[k]["ci95"][0] for k in truth},
        "width_95_default": {k: theirs[k]["ci95"][1] - theirs[k]["ci95"][0] for k in truth},
        "range_95_default": None if allowed is None else {
            k: allowed.ranges[k][1] - allowed.ranges[k][0] for k in truth},
        "inside_95_default": {k: bool(theirs[k]["ci95"][0] <= v <= theirs[k]["ci95"][1])
                              for k, v in truth.items()}}


def _allowed(fit, truth: dict) -> dict | None:
    """What the fit's ``noise_prior_dependence`` check found: whether it warned, each
    coefficient's sd at the noisiest levels the log allows over its posterior sd, and
    whether the truth lies in its range over those levels."""
    allowed = fit.allowed_noise
    if allowed is None:
        return None
    check = {c.name: c for c in fit.checks.checks}["noise_prior_dependence"]
    return {"warned": not check.passed,
            "sd_widening": {k: round(v, 3) for k, v in allowed.widening.items()},
            "inside_range": {k: bool(allowed.ranges[k][0] <= truth[k] <= allowed.ranges[k][1])
                             for k in allowed.ranges if k in truth}}


def _known_noise_sd(runs: list[dict], names: list[str]) -> dict[str, float] | None:
    """The z-scores' sd per coefficient with the noise levels pinned at their truths."""
    known = [r["z_known_noise"] for r in runs if r["z_known_noise"] is not None]
    if len(known) < 2:
        return None
    return {k: round(float(np.std([z[k] for z in known], ddof=1)), 3) for k in names}


def summarise(runs: list[dict]) -> dict:
    out = {}
    for profile in PROFILES:
        mine = [r for r in runs if r["profile"] == profile]
        if not mine:
            continue
        names = list(mine[0]["z"])
        z = np.array([[r["z"][k] for k in names] for r in mine])
        passed = [r for r in mine if r["trustworthy"]]
        out[profile] = {
            "fits": len(mine),
            "exit_3": len(mine) - len(passed),
            "z_sd": {k: round(float(np.std(z[:, i], ddof=1)), 3)
                     for i, k in enumerate(names)},
            "z_mean": {k: round(float(np.mean(z[:, i])), 3) for i, k in enumerate(names)},
            "z_sd_known_noise": _known_noise_sd(mine, names),
            "noise_median_over_truth": None if _known_noise_sd(mine, names) is None else {
                name: round(float(np.median([r["noise_median"][name] / truth for r in mine])),
                            3)
                for name, truth in (("N_deg_sqrt_h", ARW), ("B_deg_h", B),
                                    ("K_deg_h_sqrt_h", K))},
            "inside_95": {k: sum(r["inside_95"][k] for r in mine) for k in names},
            "exit_0_beyond_3_3_sd": sum(any(abs(v) > 3.3 for v in r["z"].values())
                                        for r in passed),
            **_allowed_summary(mine, passed),
            "noise_used": {m: sum(r["noise_used"] == m for r in mine)
                           for m in sorted({r["noise_used"] for r in mine})},
            "median_seconds": float(np.median([r["seconds"] for r in mine])),
            **_datasheet_summary(mine, names),
        }
    return out


def _datasheet_summary(mine: list[dict], names: list[str]) -> dict:
    """With ``--datasheet``: the default fit's coverage on the same logs, and per
    coefficient the median ratio of the datasheet's interval width to the default's
    interval and to the default's range over the allowed noise levels."""
    seen = [r["datasheet"] for r in mine if r.get("datasheet")]
    if not seen:
        return {}
    def ratio(key: str) -> dict:
        return {k: round(float(np.median([d["width_95"][k] / d[key][k] for d in seen
                                          if d[key] is not None])), 3) for k in names}
    return {"datasheet": {
        "inside_95_default": {k: sum(d["inside_95_default"][k] for d in seen) for k in names},
        "exit_3_default": sum(not d["trustworthy_default"] for d in seen),
        "width_over_default_interval": ratio("width_95_default"),
        "width_over_default_range": ratio("range_95_default")}}


def _allowed_summary(mine: list[dict], passed: list[dict]) -> dict:
    """The ``noise_prior_dependence`` check over the runs: how many warned, the median
    widening per coefficient, how often each truth lay in the range over the allowed noise
    levels, and the trusted fits with a truth beyond 3.3 sd that it did not warn of."""
    seen = [r for r in mine if r["allowed_noise"] is not None]
    if not seen:
        return {}
    names = list(seen[0]["allowed_noise"]["sd_widening"])
    return {"noise_prior_dependence_warned": sum(r["allowed_noise"]["warned"] for r in seen),
            "sd_widening_median": {k: round(float(np.median(
                [r["allowed_noise"]["sd_widening"][k] for r in seen])), 2) for k in names},
            "inside_allowed_range": {k: sum(r["allowed_noise"]["inside_range"][k]
                                            for r in seen) for k in names},
            "exit_0_beyond_3_3_sd_unwarned": sum(
                any(abs(v) > 3.3 for v in r["z"].values())
                and not (r["allowed_noise"] or {}).get("warned", False) for r in passed)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--datasets", type=int, default=30)
    parser.add_argument("--noise", default="auto")
    parser.add_argument("--profiles", default=",".join(PROFILES))
    parser.add_argument("--white-only", action="store_true")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--flicker-walk-median", type=float, default=None,
                        help="B's and K's prior median (deg/h, deg/h/sqrt(h); log-sd 3) "
                             "instead of gyroid's default (a thousandth of the white "
                             "density): a study of the priors")
    parser.add_argument("--static-hours", type=float, default=None,
                        help="fit with IEEE noise priors from a noise fit of this many "
                             "hours of the same gyro at rest (module docstring)")
    parser.add_argument("--warmup", type=float, nargs="?", const=WARMUP["w_warmup"],
                        default=None, metavar="DEG_H",
                        help="add a start-up transient of this size (default 0.05 deg/h) "
                             "and fit thermal,warmup")
    parser.add_argument("--flicker", choices=("spectral", "markov"), default="spectral",
                        help="the flicker's simulation (module docstring)")
    parser.add_argument("--datasheet", action="store_true",
                        help="noise priors from a datasheet of the bench's own levels")
    parser.add_argument("--results", default="fog_thermal_bench")
    args = parser.parse_args()
    started = time.time()
    jobs = [(args.seed + k, profile, args.noise, args.white_only, args.flicker_walk_median,
             args.static_hours, args.warmup, args.flicker, args.datasheet)
            for profile in args.profiles.split(",") for k in range(args.datasets)]
    with ProcessPoolExecutor(args.workers) as pool:
        runs = []
        for run in pool.map(one, *zip(*jobs, strict=True)):
            print(run, flush=True)
            runs.append(run)
    save_run(results_dir(args.results), seed=args.seed,
             config={"truth": TRUTH, "hours": HOURS, "rate_hz": RATE_HZ, "arw": ARW,
                     "bias_instability": B, "rate_random_walk": K,
                     "thermometer_sd_C": THERMOMETER_SD_C, "white_only": args.white_only,
                     "noise": args.noise, "datasets": args.datasets,
                     "flicker_walk_median": args.flicker_walk_median,
                     "static_hours": args.static_hours,
                     "warmup": dict(WARMUP, w_warmup=args.warmup) if args.warmup else None,
                     "flicker": args.flicker, "datasheet": args.datasheet},
             results={"summary": summarise(runs), "runs": runs}, started=started)


if __name__ == "__main__":
    main()
