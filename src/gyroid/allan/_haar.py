"""A rate log's Haar wavelet statistics: the sufficient statistics of gyroid's noise fit.

At level ``j`` the log is cut into blocks of ``m = 2**j`` samples; each pair of adjacent
blocks (blocks ``2k`` and ``2k + 1``, never across a gap) gives one coefficient, the
difference of their means ``e = mean_b - mean_a`` (deg/h). For any of the IEEE Std 952
noise processes, ``E[e**2] = 2 AVAR(tau)`` at ``tau = m tau0``: the Allan variance is
the coefficients' variance. These are the non-overlapping (decimated) Haar coefficients: for
white rate noise they are independent within and across levels, for a rate random walk
independent within a level (disjoint windows of increments), and for flicker and
quantisation weakly correlated (the wavelet transform's known decorrelation). A level keeps
only its count and sum of squares, so the fit's cost after this one pass does not depend on
the log's length.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np

from gyroid.errors import GyroidInputError

#: Fewest coefficients a level must have to be kept.
MIN_COEFFICIENTS = 2


@dataclass(frozen=True)
class HaarStatistics:
    """Per level: samples per block ``m``, coefficients ``count`` and their sum of squares
    ``sum_sq`` ((deg/h)^2); the sample step ``tau0_s`` and the log's segments."""

    m: np.ndarray
    count: np.ndarray
    sum_sq: np.ndarray
    tau0_s: float
    n_samples: int
    segments: int
    #: The correlation time of the Gauss-Markov term G fitted to these statistics, s (NaN
    #: before it is chosen: :attr:`~gyroid.allan._choice.TermChoice.gm_tc_s`).
    gm_tc_s: float = float("nan")
    #: A prefilter's deficit F (deg) read where it is large, at the shortest levels left
    #: out for it (:func:`~gyroid.allan._levels.drop_prefiltered`), NaN where none
    #: was: F is then in every set of terms, this reading in its likelihood.
    prefilter_deg: float = float("nan")

    @property
    def tau_s(self) -> np.ndarray:
        return self.m * self.tau0_s

    @cached_property
    def memo(self) -> dict[str, Any]:
        """What the noise fit derives from these statistics alone (each term's Allan-variance
        shape, the envelope: :mod:`gyroid.allan._terms`), kept as it is asked for:
        choosing the terms asks thousands of times."""
        return {}

    @property
    def avar(self) -> np.ndarray:
        """The empirical Allan variance per level, (deg/h)^2: ``sum_sq / (2 count)``."""
        return self.sum_sq / (2.0 * self.count)

    def levels(self, which: slice) -> HaarStatistics:
        """The statistics of the levels ``which`` selects (e.g. the shortest ones left out)."""
        return replace(self, m=self.m[which], count=self.count[which],
                       sum_sq=self.sum_sq[which])

    def deflated(self, dispersion: float) -> HaarStatistics:
        """The same Allan variances worth ``1 / dispersion`` of the coefficients: a
        quasi-likelihood for Haar coefficients that scatter ``dispersion`` times more than
        independent ones would (every interval widens by ``sqrt(dispersion)``)."""
        return replace(self, count=self.count / dispersion, sum_sq=self.sum_sq / dispersion)


def haar_statistics(rate_deg_h: np.ndarray, tau0_s: float,
                    segments: list[tuple[int, int]] | None = None) -> HaarStatistics:
    """The Haar statistics of a rate (deg/h) sampled every ``tau0_s`` seconds, pooled over
    its contiguous ``segments`` (``[start, stop)``; default: one)."""
    rate = np.asarray(rate_deg_h, dtype=float)
    if not np.all(np.isfinite(rate)):
        raise GyroidInputError("the rate has missing or infinite values: remove those rows")
    segments = segments or [(0, rate.size)]
    levels: dict[int, list[float]] = {}
    for start, stop in segments:
        means = rate[start:stop]
        m = 1
        while means.size >= 2:
            pairs = means[: means.size // 2 * 2].reshape(-1, 2)
            e = pairs[:, 1] - pairs[:, 0]
            entry = levels.setdefault(m, [0.0, 0.0])
            entry[0] += e.size
            entry[1] += float(e @ e)
            means = pairs.mean(axis=1)
            m *= 2
    kept = sorted(m for m, (count, _) in levels.items() if count >= MIN_COEFFICIENTS)
    if len(kept) < 3:
        raise GyroidInputError(
            f"{rate.size} samples in {len(segments)} stretch(es) give {len(kept)} averaging "
            "times with enough pairs of blocks; a noise fit needs at least 3 (a log of 16 "
            "contiguous samples or more)")
    return HaarStatistics(
        m=np.asarray(kept, dtype=float),
        count=np.asarray([levels[m][0] for m in kept]),
        sum_sq=np.asarray([levels[m][1] for m in kept]),
        tau0_s=float(tau0_s), n_samples=int(rate.size), segments=len(segments))


def overlapping_haar(rate_deg_h: np.ndarray, segments: list[tuple[int, int]],
                     m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The overlapping Haar coefficients at ``m`` samples per block (every pair of adjacent
    blocks, at every sample, never across a gap): (levels, stretches) their sum of squares
    ((deg/h)^2) and their count per stretch of ``segments``. The sum over ``2`` times the
    count is the overlapping Allan variance."""
    rate = np.asarray(rate_deg_h, dtype=float)
    sums = np.zeros((len(m), len(segments)))
    counts = np.zeros((len(m), len(segments)), dtype=int)
    for j, (start, stop) in enumerate(segments):
        angle = np.concatenate([[0.0], np.cumsum(rate[start:stop])])  # deg/h samples
        for i, level in enumerate(int(x) for x in m):
            size = stop - start - 2 * level + 1
            if size < 1:
                continue
            # in chunks: a 10^8-sample log's temporaries stay a few MB, not GB
            for a in range(0, size, OVERLAPPING_CHUNK):
                b = min(a + OVERLAPPING_CHUNK, size)
                e = (angle[a + 2 * level:b + 2 * level] - 2.0 * angle[a + level:b + level]
                     + angle[a:b]) / level
                sums[i, j] += float(e @ e)
            counts[i, j] = size
    return sums, counts


#: Overlapping Haar coefficients computed at a time.
OVERLAPPING_CHUNK = 1 << 20
