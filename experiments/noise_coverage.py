"""Experiment (issue 30): ``gyroid noise`` on static logs of six gyro grades, simulated here
independently of gyroid, against the two ways users read noise terms today. The fourth is a
phone's IMU as its logger writes it (issue 63): 100 Hz low-passed forward and backward and
decimated to 10 Hz, its samples correlated as a real phone log's. The fifth (issue 63) has
no flicker: white noise, a Gauss-Markov bias G (its correlation time drawn too) and a rate
random walk, terms that look alike over a log's averaging times; a flicker read there is
counted as a false detection. The sixth is the MEMS grade with a logger's spikes (one sample
in 10^4 off by 10-50 sd).

Each dataset draws its truths log-uniformly within a factor of 3 of the grade's nominal
terms (white: angle random walk N; flicker: bias instability B, ``flicker_noise``; a rate
random walk K; for the MEMS grade also angle quantisation Q), so the intervals are checked
over a range of truths, not one point. Per term, gyroid's answer is its 90 % interval when
it resolves the term, else its one-sided 95 % upper bound; coverage of each is counted
against the binomial band. Per log also the ``allan_interval`` check (what the fit states
against the overlapping Allan deviation's 99 % interval) and, where the truth has a closed
form (every grade but the filtered phone's), at how many of the same averaging times the
truth's own Allan deviation lies outside the 95 % and 99 % intervals: what a right model
can be asked. Where gyroid resolves a term, its posterior median's error is compared with

* ``slope``: the IEEE Std 952 reading of an Allan plot as MathWorks documents it
  (allantools' overlapping Allan deviation at octave averaging times; the line of slope
  -1/2 through the point of nearest log-log slope, read at 1 s, for N; the deviation where
  the slope is nearest 0, over 0.664, for B; slope +1/2 read at 3 s for K; slope -1 read at
  sqrt(3) s for Q);
* ``allan_variance``: the ``allan-variance`` package (relative-weighted non-negative least
  squares of every term on its Allan variance).

    pip install -e ".[compare]"  # the allan-variance package, for the second comparison
    python experiments/noise_coverage.py --seed 0 --datasets 40
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import dataclass

import allantools
import matplotlib
import numpy as np
from _common import flicker_noise, gauss_markov_sum, results_dir, save_run
from allan_variance import compute_avar, estimate_parameters
from scipy import signal, stats

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import gyroid
from gyroid.allan import fit_noise

SPREAD = 3.0  # truths drawn log-uniformly in [nominal / SPREAD, nominal * SPREAD]
#: Terms counted as false detections where a grade's gyro lacks them and gyroid resolves them.
FALSE_CANDIDATES = ("B", "K", "Q", "R", "G")


@dataclass(frozen=True)
class Grade:
    name: str
    nominal: dict[str, float]
    sample_s: float
    duration_s: float
    #: A logger's low-pass filter: the rate simulated every ``sample_s / decimation`` s,
    #: low-passed forward and backward (4th-order Butterworth at ``cutoff_hz``) and every
    #: ``decimation``-th sample kept; None: logged as simulated.
    cutoff_hz: float | None = None
    decimation: int = 1
    #: The Gauss-Markov bias's nominal correlation time (s), drawn as the terms are; its
    #: sd is the nominal ``G`` (deg/h).
    gm_tau_s: float | None = None
    #: Spikes on the logged samples (a logger's glitches): this share of the samples
    #: moved by 10-50 white-noise sds either way.
    spike_rate: float = 0.0


GRADES = (
    # Bias instability near the floor the white noise leaves in two hours.
    Grade("fog", {"N": 0.003, "B": 0.01, "K": 0.01}, 0.01, 7200.0),
    Grade("tactical", {"N": 0.05, "B": 0.5, "K": 1.0}, 0.005, 3600.0),
    # A short log: the walk mostly below the flicker floor at the longest averaging times.
    Grade("mems", {"N": 0.3, "B": 6.0, "K": 10.0, "Q": 3e-4}, 0.01, 1800.0),
    # A phone's IMU as its logger writes it: 100 Hz low-passed and decimated to 10 Hz
    # (lag-1 correlation about 0.87, as a real 6 h phone log's 0.86).
    Grade("phone", {"N": 2.5, "B": 18.0, "K": 20.0}, 0.1, 6 * 3600.0, cutoff_hz=1.5,
          decimation=10),
    # No flicker: a bump at a few hundred seconds beside a walk (issue 63's logs).
    Grade("gm", {"N": 1.5, "G": 8.0, "K": 20.0}, 0.1, 6 * 3600.0, gm_tau_s=200.0),
    # The MEMS grade with a logger's spikes: one sample in 10^4 off by 10-50 sd.
    Grade("mems_spikes", {"N": 0.3, "B": 6.0, "K": 10.0, "Q": 3e-4}, 0.01, 1800.0,
          spike_rate=1e-4),
)


def static_rate(rng: np.random.Generator, grade: Grade, truth: dict[str, float],
                gm_tau_s: float | None = None) -> np.ndarray:
    """A static gyro's rate, deg/h, by each term's IEEE definition (through the logger's
    filter, where the grade has one); a Gauss-Markov bias of sd ``G`` and correlation time
    ``gm_tau_s``, started stationary."""
    dt = grade.sample_s / grade.decimation
    n = int(grade.duration_s / dt)
    rate = rng.normal(0.0, 60.0 * truth["N"] / math.sqrt(dt), n)
    if "B" in truth:
        rate += flicker_noise(rng, n, dt, truth["B"])
    if "G" in truth:
        rate += gauss_markov_sum(rng, n, dt, [gm_tau_s], truth["G"] ** 2)
    rate += np.cumsum(rng.normal(0.0, truth["K"] / 60.0 * math.sqrt(dt), n))
    if "Q" in truth:
        rate += np.diff(rng.normal(0.0, 3600.0 * truth["Q"], n + 1)) / dt
    if grade.cutoff_hz is not None:
        b, a = signal.butter(4, grade.cutoff_hz * 2.0 * dt)
        rate = signal.filtfilt(b, a, rate)[:: grade.decimation]
    if grade.spike_rate:
        spikes = rng.random(rate.size) < grade.spike_rate
        size = rng.uniform(10.0, 50.0, spikes.sum()) * 60.0 * truth["N"] / math.sqrt(dt)
        rate[spikes] += rng.choice([-1.0, 1.0], spikes.sum()) * size
    return rate


def _line_at(tau: np.ndarray, adev: np.ndarray, slope: float, at: float) -> float:
    """The line of log-log ``slope`` through the Allan deviation's point of nearest local
    slope, evaluated at ``at`` seconds."""
    log_tau, log_adev = np.log10(tau), np.log10(adev)
    local = np.diff(log_adev) / np.diff(log_tau)
    i = int(np.argmin(np.abs(local - slope)))
    return float(10 ** (log_adev[i] - slope * log_tau[i] + slope * math.log10(at)))


def slope_method(rate: np.ndarray, dt: float) -> dict[str, float]:
    tau, adev, _, _ = allantools.oadev(rate, rate=1.0 / dt, data_type="freq", taus="octave")
    keep = adev > 0
    tau, adev = tau[keep], adev[keep]
    return {"N": _line_at(tau, adev, -0.5, 1.0) / 60.0,
            "B": _line_at(tau, adev, 0.0, 1.0) / math.sqrt(2.0 * math.log(2.0) / math.pi),
            "K": _line_at(tau, adev, 0.5, 3.0) * 60.0,
            "Q": _line_at(tau, adev, -1.0, math.sqrt(3.0)) / 3600.0}


def allan_variance_package(rate: np.ndarray, dt: float) -> dict[str, float]:
    tau, avar = compute_avar(rate, dt)
    params, _ = estimate_parameters(tau, avar)
    # Its units for a rate in deg/h: deg/h*s, deg/h*sqrt(s), deg/h, deg/h/sqrt(s).
    return {"N": float(params["white"]) / 60.0, "B": float(params["flicker"]),
            "K": float(params["walk"]) * 60.0, "Q": float(params["quantization"]) / 3600.0}


def one(grade: Grade, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    truth = {k: v * math.exp(rng.uniform(-math.log(SPREAD), math.log(SPREAD)))
             for k, v in grade.nominal.items()}
    gm_tau_s = (None if grade.gm_tau_s is None else
                grade.gm_tau_s * math.exp(rng.uniform(-math.log(SPREAD), math.log(SPREAD))))
    rate = static_rate(rng, grade, truth, gm_tau_s)
    started = time.time()
    fit = fit_noise(rate, grade.sample_s, seed=seed)
    seconds = time.time() - started
    summary = fit.reported_terms()
    gyroid_answer = {}
    for name in truth:
        entry = summary.get(name)
        if entry is None:  # G: the log had too few averaging times to try one
            gyroid_answer[name] = {"resolved": False, "inside": False, "median": 0.0,
                                   "bound": None}
            continue
        if entry["resolved"]:
            low, high = entry["ci90"]
            inside = bool(low <= truth[name] <= high)
        else:
            bound = entry["upper_bound_95"]
            inside = bound is not None and bool(truth[name] <= bound)
        gyroid_answer[name] = {"resolved": entry["resolved"], "inside": inside,
                               "median": float(np.median(fit.draws(name))),
                               "bound": entry.get("upper_bound_95")}
    interval = fit.overlapping
    slope = slope_method(rate, grade.sample_s)
    package = allan_variance_package(rate, grade.sample_s)
    return {"grade": grade.name, "seed": seed, "rows": rate.size, "truth": truth,
            "gyroid": gyroid_answer, "trustworthy": fit.trustworthy,
            # IEEE terms the log does not have that gyroid resolved anyway
            "false_detections": sorted(t for t in FALSE_CANDIDATES if t not in truth
                                       and summary.get(t, {}).get("resolved", False)),
            # ... of those, the ones whose 90 % interval excludes zero (the rest say the
            # term may be absent: sets without it hold at least 5 % of the weight)
            "false_detections_excluding_zero": sorted(
                t for t in FALSE_CANDIDATES if t not in truth
                and summary.get(t, {}).get("resolved", False) and summary[t]["ci90"][0] > 0),
            "gm_tau_s": gm_tau_s,
            "gyroid_gm_tau_s": (summary["G"]["tau_s"] if "G" in summary else None),
            "terms_resolved": list(fit.terms),
            "slope": {k: slope[k] for k in truth if k in slope},
            "allan_variance": {k: package[k] for k in truth if k in package},
            "allan_interval": {
                "passed": bool(interval.check().passed),
                "missed_s": interval.tau_s[interval.outside].tolist(),
                # the truth's own Allan deviation against the same intervals (None on a
                # filtered log, whose truth has no closed form)
                "truth_missed": (None if grade.cutoff_hz is not None else
                                 truth_misses(rate, grade, truth, gm_tau_s, interval))},
            "fit_seconds": round(seconds, 2)}


def truth_avar(tau_s: np.ndarray, grade: Grade, truth: dict[str, float],
               gm_tau_s: float | None) -> np.ndarray:
    """The truth's Allan variance ((deg/h)^2) by each term's IEEE Std 952 form (G's for a
    first-order process sampled every ``sample_s``), written here."""
    avar = (60.0 * truth["N"]) ** 2 / tau_s
    if "B" in truth:
        avar = avar + 2.0 * math.log(2.0) / math.pi * truth["B"] ** 2
    if "K" in truth:
        avar = avar + (truth["K"] / 60.0) ** 2 * tau_s / 3.0
    if "Q" in truth:
        avar = avar + 3.0 * (3600.0 * truth["Q"]) ** 2 / tau_s**2
    if "G" in truth and gm_tau_s is not None:
        x = tau_s / gm_tau_s
        avar = avar + truth["G"] ** 2 / x**2 * (2.0 * x - 3.0 + 4.0 * np.exp(-x)
                                                 - np.exp(-2.0 * x))
    return avar


def truth_misses(rate: np.ndarray, grade: Grade, truth: dict[str, float],
                 gm_tau_s: float | None, interval) -> dict[str, int]:
    """At how many of the levels ``allan_interval`` reads the truth's Allan deviation lies
    outside the overlapping one's 95 % and 99 % chi-square intervals, their degrees of
    freedom under the truth's own terms: what a right model can be asked."""
    from scipy.stats import chi2

    from gyroid.allan._interval import overlapping_edf

    amplitudes = {k: v for k, v in truth.items() if k != "G"} | (
        {"G": truth["G"]} if "G" in truth else {})
    tc = gm_tau_s if gm_tau_s is not None else float("nan")
    model = np.sqrt(truth_avar(interval.tau_s, grade, truth, gm_tau_s))
    out = {}
    for confidence in (0.95, 0.99):
        missed = 0
        for tau, adev, m_model in zip(interval.tau_s, interval.adev_deg_h, model, strict=True):
            m = int(round(tau / grade.sample_s))
            edf = overlapping_edf(m, [rate.size - 2 * m + 1], grade.sample_s, amplitudes, tc)
            tail = (1.0 - confidence) / 2.0
            low = adev * math.sqrt(edf / chi2.ppf(1.0 - tail, edf))
            high = adev * math.sqrt(edf / chi2.ppf(tail, edf))
            missed += not low <= m_model <= high
        out[str(confidence)] = missed
    return out


def _relative_error(runs: list[dict], method: str, name: str) -> dict[str, float] | None:
    """Median and 90th percentile of ``|estimate / truth - 1|`` over ``runs``."""
    runs = [r for r in runs if method == "gyroid" or name in r[method]]
    if not runs:
        return None
    errors = np.array([abs((r["gyroid"][name]["median"] if method == "gyroid"
                            else r[method][name]) / r["truth"][name] - 1.0) for r in runs])
    return {"median": round(float(np.median(errors)), 4),
            "p90": round(float(np.quantile(errors, 0.9)), 4)}


def summarise(runs: list[dict]) -> dict:
    """Per grade and term: how often gyroid resolves it, how often its interval (resolved)
    or bound (not) holds the truth, and each method's relative error on the datasets where
    gyroid resolves the term and, for the two Allan readings, where it does not (there
    gyroid's answer is its bound, not a number)."""
    out = {}
    for grade in GRADES:
        mine = [r for r in runs if r["grade"] == grade.name]
        terms = {}
        for name in grade.nominal:
            resolved = [r for r in mine if r["gyroid"][name]["resolved"]]
            bounded = [r for r in mine if not r["gyroid"][name]["resolved"]]
            terms[name] = {
                "resolved": len(resolved),
                "ci90_inside": sum(r["gyroid"][name]["inside"] for r in resolved),
                "ci90_band_99": binomial_band(len(resolved), 0.9),
                "upper_bound_inside": sum(r["gyroid"][name]["inside"] for r in bounded),
                "upper_bound_band_99": binomial_band(len(bounded), 0.95),
                "error_where_resolved": {m: _relative_error(resolved, m, name)
                                         for m in ("gyroid", "slope", "allan_variance")},
                "error_where_unresolved": {m: _relative_error(bounded, m, name)
                                           for m in ("slope", "allan_variance")}}
        out[grade.name] = {
            "datasets": len(mine), "trustworthy": sum(r["trustworthy"] for r in mine),
            "terms": terms,
            "false_detections": {t: sum(t in r.get("false_detections", ()) for r in mine)
                                 for t in FALSE_CANDIDATES if t not in grade.nominal},
            "false_detections_excluding_zero": {
                t: sum(t in r.get("false_detections_excluding_zero", ()) for r in mine)
                for t in FALSE_CANDIDATES if t not in grade.nominal},
            "allan_interval": {
                "refused": sum(not r["allan_interval"]["passed"] for r in mine),
                "truth_outside_at_two_or_more": None if grade.cutoff_hz is not None else {
                    c: sum(r["allan_interval"]["truth_missed"][c] >= 2 for r in mine)
                    for c in ("0.95", "0.99")}},
            "fit_seconds_median": round(float(np.median([r["fit_seconds"] for r in mine])), 2)}
    return out


def binomial_band(n: int, p: float) -> list[int]:
    """The 99 % two-sided band of a count of ``n`` draws at rate ``p``."""
    if n == 0:
        return [0, 0]
    return [int(stats.binom.ppf(0.005, n, p)), int(stats.binom.ppf(0.995, n, p))]


#: The figure's range of estimate / truth; points beyond it are drawn at its edge.
RATIO_RANGE = (1e-2, 1e2)
METHODS = (("gyroid", "gyroid (posterior median)", "o"), ("slope", "Allan slopes", "s"),
           ("allan_variance", "allan-variance package", "^"))


def figure(runs: list[dict], path) -> None:
    """Per grade, each method's estimate over the truth for every term; gyroid's upper
    bound (where it does not resolve the term) as a downward triangle."""
    columns = 3
    rows = -(-len(GRADES) // columns)
    fig, grid = plt.subplots(rows, columns, figsize=(3.6 * columns, 3.3 * rows + 0.9),
                             sharey=True)
    axes = list(np.ravel(grid))
    low, high = RATIO_RANGE
    labelled: set[str] = set()

    def label(text: str) -> str | None:
        first = text not in labelled
        labelled.add(text)
        return text if first else None

    for ax, grade in zip(axes, GRADES, strict=True):
        mine = [r for r in runs if r["grade"] == grade.name]
        for i, name in enumerate(grade.nominal):
            for j, (method, name_of, marker) in enumerate(METHODS):
                ratios = []
                bounds = []
                for r in mine:
                    if method != "gyroid" and name not in r[method]:
                        continue
                    if method == "gyroid" and not r["gyroid"][name]["resolved"]:
                        if r["gyroid"][name]["bound"] is not None:
                            bounds.append(r["gyroid"][name]["bound"] / r["truth"][name])
                        continue
                    value = (r["gyroid"][name]["median"] if method == "gyroid"
                             else r[method][name])
                    ratios.append(value / r["truth"][name])
                x = i + (j - 1) * 0.25
                jitter = np.linspace(-0.06, 0.06, max(len(ratios), 1))[: len(ratios)]
                ax.plot(x + jitter, np.clip(ratios, low, high), marker, ms=3, mfc="none",
                        color="0.0", ls="none", label=label(name_of))
                if bounds:
                    jitter = np.linspace(-0.06, 0.06, len(bounds))
                    ax.plot(x + jitter, np.clip(bounds, low, high), "v", ms=3,
                            color="0.55", ls="none",
                            label=label("gyroid's 95 % upper bound (term not resolved)"))
        ax.axhline(1.0, color="0.0", lw=0.8)
        ax.set_yscale("log")
        ax.set_ylim(low / 1.5, high * 1.5)
        ax.set_xticks(range(len(grade.nominal)), list(grade.nominal))
        ax.set_xlabel("noise term")
        ax.set_title(f"{grade.name}: {grade.duration_s / 3600:g} h at "
                     f"{1 / grade.sample_s:g} Hz, {len(mine)} logs", fontsize=9)
        ax.grid(True, ls=":", color="0.7")
    for ax in axes[::columns]:
        ax.set_ylabel("estimate / truth (ratio, log scale)")
    handles, labels = axes[0].get_legend_handles_labels()
    for ax in axes[1:]:
        more = ax.get_legend_handles_labels()
        handles, labels = handles + more[0], labels + more[1]
    fig.legend(handles, labels, loc="lower center", ncol=2, frameon=False,
               bbox_to_anchor=(0.5, 0.02))
    fig.text(0.5, 0.0, "estimates beyond the axis drawn at its edge (a zero estimate at its "
             "foot)", ha="center", va="bottom", fontsize=7)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--datasets", type=int, default=40, help="per grade")
    parser.add_argument("--replot", action="store_true",
                        help="only redraw the figure from results.json")
    args = parser.parse_args()
    folder = results_dir("noise_coverage")
    if args.replot:
        runs = json.loads((folder / "results.json").read_text())["results"]["runs"]
        figure(runs, folder / "noise_coverage.png")
        return
    gyroid.configure()
    started = time.time()
    runs = []
    for grade in GRADES:
        for k in range(args.datasets):
            runs.append(one(grade, args.seed + k))
            print(grade.name, k, runs[-1]["gyroid"], runs[-1]["fit_seconds"], flush=True)
    figure(runs, folder / "noise_coverage.png")
    save_run(folder, seed=args.seed,
             config={"grades": [g.__dict__ for g in GRADES], "spread": SPREAD,
                     "datasets_per_grade": args.datasets},
             results={"summary": summarise(runs), "runs": runs}, started=started)


if __name__ == "__main__":
    main()
