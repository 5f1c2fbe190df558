"""The means of a compensated log over consecutive windows (``compensated_means.csv``):
measured, modelled, and the 95 % band a measured mean should lie in (the model's uncertainty
and the fit's noise model together), and the check that holds the bands against the log."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from gyroid.inference._checks import Check
from gyroid.inference._predictive import part_means
from gyroid.io._fitted import FittedDrift
from gyroid.io._logs import BenchLog
from gyroid.noise._estimate import NoiseEstimate
from gyroid.workflows._turn_on import StartUp


def measured_mean_covariance(log: BenchLog, noise: NoiseEstimate, part: np.ndarray,
                             n_parts: int, startup: StartUp | None = None) -> np.ndarray:
    """The fit's noise model's covariance ((deg/h)^2) of ``log``'s measured means over its
    parts (``part``: each row's, -1 for none; contiguous, in time order), white noise from
    the log's own sds or the fit's at this log's sample interval (a rate averaged over each
    sample), the log after the fitted one; with ``startup``, of each part's mean less the
    start-up rows' mean (the parts then must not hold start-up rows)."""
    time_s = np.asarray(log.time_s)
    step = float(np.median(np.diff(time_s))) if time_s.size > 1 else 1.0
    if startup is not None:
        part, n = startup.relabelled(part), n_parts + 1
    else:
        n = n_parts
    kept = part >= 0
    counts = np.bincount(part[kept], minlength=n).astype(float)
    sigma = log.sigma_deg_h
    white = (np.bincount(part[kept], np.asarray(sigma)[kept] ** 2, n) / counts**2
             if sigma is not None else noise.white_sd_at(step) ** 2 / counts)
    covariance = np.atleast_2d(noise.part_covariance(time_s, part, n, step, white))
    return covariance if startup is None else startup.contrasted(covariance)


def window_means(log: BenchLog, fitted: FittedDrift,
                 draw_part_means: Callable[[np.ndarray, int], np.ndarray], window_s: float,
                 startup: StartUp | None = None
                 ) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
    """Per consecutive window of ``window_s`` seconds holding samples (after the start-up
    calibration's rows, with ``startup``): its first and last time, samples, the measured
    drift's mean, the model's mean over posterior draws and its sd, the fit's noise model's
    sd of such a mean (at this log's sample interval, after the fitted log; less the
    start-up mean, with ``startup``), and the 95 % band for the measured mean (model and
    noise, normal). A fit without a noise model (an old folder) has no noise sd or band
    (NaN). Also the predictive covariance of the windows' measured means (model and noise;
    None without a noise model), which the bands are the diagonal of."""
    time_s = np.asarray(log.time_s)
    kept = np.ones(time_s.size, dtype=bool) if startup is None else ~startup.rows
    part = np.full(time_s.size, -1)
    index = np.floor((time_s[kept] - time_s[kept][0]) / window_s).astype(int)
    part[kept] = np.unique(index, return_inverse=True)[1]
    n = int(part.max()) + 1
    counts = np.bincount(part[kept], minlength=n).astype(float)
    means = draw_part_means(part, n)
    model_mean, model_sd = means.mean(axis=0), means.std(axis=0, ddof=1) if means.shape[
        0] > 1 else np.zeros(n)
    noise_sd = np.full(n, np.nan)
    covariance = None
    if fitted.noise is not None:
        noise_cov = measured_mean_covariance(log, fitted.noise, part, n, startup)
        noise_sd = np.sqrt(np.diag(noise_cov))
        model_cov = np.atleast_2d(np.cov(means, rowvar=False)) if means.shape[0] > 1 else 0.0
        covariance = noise_cov + model_cov
    half = 1.96 * np.sqrt(model_sd**2 + noise_sd**2)
    return {"t_start_s": np.array([time_s[part == k][0] for k in range(n)]),
            "t_end_s": np.array([time_s[part == k][-1] for k in range(n)]),
            "n_samples": counts.astype(int),
            "drift_mean_deg_h": part_means(np.asarray(log.drift_deg_h), part, n),
            "model_mean_deg_h": model_mean, "model_mean_sd_deg_h": model_sd,
            "noise_mean_sd_deg_h": noise_sd, "band95_lo_deg_h": model_mean - half,
            "band95_hi_deg_h": model_mean + half}, covariance


#: Share of a log's window means below which, if improbable, the bands fail; the fewest
#: windows judged; the improbability (under the predictive covariance) that is an error;
#: the draws the probability is estimated from, and the most windows it reads.
WINDOW_BANDS_INSIDE = 0.8
WINDOW_BANDS_MIN = 5
WINDOW_BANDS_P = 0.01
WINDOW_BANDS_DRAWS = 4000
WINDOW_BANDS_MAX = 2000


def window_bands(windows: dict[str, np.ndarray], covariance: np.ndarray | None,
                 window_s: float, *, seed: int = 0) -> Check:
    """The bands ``compensated_means.csv`` states, held against this log's measured window
    means, one window at a time as a user reads them: fewer than ``WINDOW_BANDS_INSIDE``
    inside is an error when that is improbable (p < ``WINDOW_BANDS_P``) under the windows'
    predictive covariance (model and noise; by ``WINDOW_BANDS_DRAWS`` draws with ``seed``),
    judged by how far beyond the bands the means lie in all (the sum over windows of each
    one's excess beyond its band, in half-bands: zero inside). The windows' errors are
    correlated (a shared offset, a walk's trend), so many may fall outside together by
    chance: the probability decides, not the count, and a model that describes the log
    passes 99 times in 100. The whitened predictive check tests
    the joint calibration; this one sees a run whose means sit outside their bands together
    (another run's turn-on bias) beyond what the stated correlation allows."""
    low, high = windows.get("band95_lo_deg_h"), windows.get("band95_hi_deg_h")
    name = "window_bands"
    if (covariance is None or low is None or not np.all(np.isfinite(low))
            or low.size < WINDOW_BANDS_MIN):
        return Check(name, True, "error", None, WINDOW_BANDS_INSIDE,
                     f"fewer than {WINDOW_BANDS_MIN} windows of {window_s:g} s with bands: not "
                     "judged")
    measured = windows["drift_mean_deg_h"]
    inside = (measured >= low) & (measured <= high)
    share = float(np.mean(inside))
    where = f"{int(inside.sum())} of {inside.size} window means of {window_s:g} s"
    if share >= WINDOW_BANDS_INSIDE:
        return Check(name, True, "error", share, WINDOW_BANDS_INSIDE,
                     f"{where} lie inside their 95 % bands")
    every = max(1, -(-inside.size // WINDOW_BANDS_MAX))
    kept = np.arange(0, inside.size, every)
    half = 0.5 * (high - low)[kept]
    factor = np.linalg.cholesky(covariance[np.ix_(kept, kept)]
                                + 1e-12 * np.diag(np.diag(covariance)[kept]))
    draws = np.random.default_rng(seed).standard_normal((WINDOW_BANDS_DRAWS, kept.size))

    def beyond(errors: np.ndarray) -> np.ndarray:
        return np.sum(np.maximum(np.abs(errors) / half - 1.0, 0.0), axis=-1)

    errors = (measured - windows["model_mean_deg_h"])[kept]
    p = float(np.mean(beyond(draws @ factor.T) >= beyond(errors)))
    offset = float(np.median(measured - windows["model_mean_deg_h"]))
    if p >= WINDOW_BANDS_P:
        return Check(name, True, "error", share, WINDOW_BANDS_INSIDE,
                     f"{where} lie inside their 95 % bands; no further outside than errors "
                     f"as correlated as the fit states leave (p = {p:.2g})")
    return Check(name, False, "error", share, WINDOW_BANDS_INSIDE,
                 f"only {where} lie inside their 95 % bands, further outside than errors as "
                 f"correlated as the fit states leave (p = {p:.1g}; the measured means sit "
                 f"{offset:+.3g} deg/h from the model's, in the median): the fit does not "
                 "describe this log (another run's turn-on bias, another unit, conditions "
                 "it did not see); do not compensate with it: refit on this run, or fit "
                 "several runs together (gyroid pool) so that the run-to-run spread is "
                 "known")
