"""Outliers in a static rate log, found before its Allan statistics and kept out of them.

Each sample is compared with the median of its ``2 k`` neighbours (``k`` either side, itself
left out, never across a gap): the slow processes (flicker, a random walk, a Gauss-Markov
bias of seconds) cancel, white noise and spikes remain. The residuals' robust scale (their
median absolute deviation, 1.4826 x) sets a threshold at which Gaussian noise would flag
:data:`FALSE_FLAGS` samples in the whole log (5.6 robust sd for 5 x 10^5 samples). A
sample so flagged is an outlier only if it also stands out from the log about a minute's
running mean (:data:`RUNNING_MEAN_S`) by as many robust sd of that (at least
:data:`WITHIN_MEAN_SD`): on a log filtered or decimated by its logger (a phone's IMU, 100 Hz
low-passed forward and backward to 10 Hz, lag-1 correlation 0.86) neighbours' medians sit
so close to each sample that their residuals' scale collapses, and 24 % of its samples
were named outliers though none lay beyond 5 sd of a minute's mean. A flagged
sample is replaced by its neighbours' median, so it adds nothing to N, B or any other term
(a spike of height ``h`` adds ``h^2 tau0 / tau^2``-shaped variance, which a fit reads as
quantisation, or lifts N). A few such samples are outliers (a warning naming their rows).
More than :data:`MAX_OUTLIER_FRACTION` of the log is a heavy-tailed distribution, which a
Gaussian noise model does not describe whatever is removed: nothing is replaced (replacing
6 % of a log's samples by medians smooths it and invents correlation at the shortest
averaging times, measured on the MTi-G run of ``smac_imudata``) and the fit is refused (an
error).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import median_filter
from scipy.stats import norm

from gyroid.inference._check_report import Check

#: Neighbours either side a sample is compared with.
NEIGHBOURS = 5
#: Expected number of samples Gaussian noise would put beyond the threshold, per log.
FALSE_FLAGS = 0.01
#: More flagged samples than this fraction of the log: heavy tails, not outliers.
MAX_OUTLIER_FRACTION = 1e-3
#: Rows named in a message.
NAMED_ROWS = 5
#: The running mean a flagged sample must also stand out from (s), and the fewest of its
#: robust sd it must stand out by.
RUNNING_MEAN_S, WITHIN_MEAN_SD = 60.0, 5.0


@dataclass(frozen=True)
class Outliers:
    """The samples of a rate log found to be outliers (indices into it), the threshold
    (robust sd) and the robust scale of the residuals about the neighbours' median (deg/h)."""

    rows: np.ndarray
    threshold_sd: float
    scale_deg_h: float
    n_samples: int

    @property
    def fraction(self) -> float:
        return self.rows.size / max(self.n_samples, 1)

    def check(self, where: Callable[[int], str] | None = None) -> Check:
        """``outliers``: passes with none; a warning naming the rows of a few (replaced by
        their neighbours' median, so kept out of every term); an error for heavy tails."""
        k = self.rows.size
        limit = MAX_OUTLIER_FRACTION
        if k == 0:
            return Check("outliers", True, "warning", 0.0, limit,
                         f"no sample lies beyond {self.threshold_sd:.2g} robust sd of its "
                         "neighbours' median")
        named = ", ".join(where(int(r)) if where else f"row {int(r) + 1}"
                          for r in self.rows[:NAMED_ROWS]) + (", ..." if k > NAMED_ROWS else "")
        what = (f"{k} sample(s) ({100 * self.fraction:.2g} % of the log) lie beyond "
                f"{self.threshold_sd:.2g} robust sd ({self.threshold_sd * self.scale_deg_h:.3g} "
                f"deg/h) of their neighbours' median, where Gaussian noise puts "
                f"{FALSE_FLAGS:g}: {named}")
        if self.fraction <= limit:
            return Check("outliers", False, "warning", self.fraction, limit,
                         f"{what}; each was replaced by its neighbours' median before the "
                         "Allan statistics, so none adds to N, B or any other term (check "
                         "the logger or the sensor at those rows)")
        return Check("outliers", False, "error", self.fraction, limit,
                     f"{what}: too many to be outliers, the rate's distribution has heavy "
                     "tails, which a Gaussian noise model does not describe (the terms shown "
                     "count them as Gaussian noise: N is the variance's, tails included); "
                     "find the cause (a damaged logger, vibration, electrical interference) "
                     "before taking a datasheet value from this log")


def _robust_scale(values: np.ndarray) -> tuple[float, float]:
    """The centre (median) and robust sd (1.4826 median absolute deviation; for a coarsely
    quantised rate, whose MAD may be 0, the mean absolute deviation's) of ``values``."""
    centre = float(np.median(values))
    scale = 1.4826 * float(np.median(np.abs(values - centre)))
    if not scale > 0:
        scale = float(np.mean(np.abs(values - centre))) * np.sqrt(np.pi / 2.0)
    return centre, scale


def _running_mean(rate: np.ndarray, window: int) -> np.ndarray:
    """Each sample's mean over the ``window`` samples centred on it, the window cut at the
    stretch's ends (not padded: padding by the end sample repeated it half a window's times,
    and a logger's start-up transient there, a few samples far off, made the samples after
    it stand out from a mean it had dragged away; a phone-grade log's first samples were
    named outliers at 2.9 sd of the minute's true mean)."""
    half = window // 2
    total = np.concatenate([[0.0], np.cumsum(rate - rate.mean())])
    index = np.arange(rate.size)
    low, high = np.maximum(index - half, 0), np.minimum(index + half + 1, rate.size)
    return (total[high] - total[low]) / (high - low) + rate.mean()


def remove_outliers(rate_deg_h: np.ndarray, segments: list[tuple[int, int]] | None = None,
                    *, sample_s: float | None = None) -> tuple[np.ndarray, Outliers]:
    """The rate with its outliers replaced by their neighbours' median (as it is when they
    are too many: heavy tails, module docstring), and what was found. ``segments``: the
    log's contiguous stretches (``[start, stop)``); ``sample_s``: its sample interval (s),
    which sets the running mean's length in samples (without it, ``2 k + 1``)."""
    rate = np.asarray(rate_deg_h, dtype=float)
    segments = segments or [(0, rate.size)]
    footprint = np.ones(2 * NEIGHBOURS + 1, dtype=bool)
    footprint[NEIGHBOURS] = False
    window = 2 * NEIGHBOURS + 1
    if sample_s is not None and sample_s > 0:
        window = max(window, int(round(RUNNING_MEAN_S / sample_s)) | 1)
    around, slow = np.empty_like(rate), np.empty_like(rate)
    for start, stop in segments:
        around[start:stop] = median_filter(rate[start:stop], footprint=footprint,
                                           mode="nearest")
        slow[start:stop] = _running_mean(rate[start:stop], window)
    residual = rate - around
    centre, scale = _robust_scale(residual)
    threshold = float(norm.isf(0.5 * FALSE_FLAGS / max(rate.size, 1)))
    if not scale > 0:
        return rate, Outliers(np.zeros(0, dtype=int), threshold, 0.0, rate.size)
    about = rate - slow
    middle, spread = _robust_scale(about)
    far = np.abs(about - middle) > max(threshold, WITHIN_MEAN_SD) * spread
    flagged = np.flatnonzero((np.abs(residual - centre) > threshold * scale) & far)
    found = Outliers(flagged, threshold, scale, rate.size)
    if found.fraction > MAX_OUTLIER_FRACTION:
        return rate, found
    cleaned = rate.copy()
    cleaned[flagged] = around[flagged]
    return cleaned, found
