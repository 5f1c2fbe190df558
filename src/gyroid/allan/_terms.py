"""The static noise fit's use of the noise terms (:data:`gyroid.noise._terms.STATIC_TERMS`;
each one's Allan-variance shape in :mod:`gyroid.noise._allan_terms`' table): their letters,
the sets that can be fitted together, their envelopes and ceilings on a log, and the Haar
levels' likelihood.

G, a first-order Gauss-Markov bias of stationary sd ``G`` (a MEMS gyro's bump in the Allan
deviation at some seconds to minutes, which rises as a random walk below its correlation
time and falls as white noise above it) is not an IEEE Std 952 term: its correlation time
is integrated out of each set's weight and chosen per set
(:func:`~gyroid.allan._choice.over_correlation_times`) and held in
the statistics (``HaarStatistics.gm_tc_s``). Q and F are never fitted together (only their
difference would be identified): an excess at the shortest times is quantisation, a deficit
a prefilter.
"""

from __future__ import annotations

import numpy as np

from gyroid.allan._haar import HaarStatistics
from gyroid.noise._allan_terms import AbstractAllanTerm
from gyroid.noise._terms import STATIC_TERMS

#: The terms' letters, in ``noise.json``'s order.
TERM_NAMES = tuple(t.code for t in STATIC_TERMS)
#: IEEE Std 952's terms (noise.json's ``terms``); G and F are reported on their own.
IEEE_TERMS = ("Q", "N", "B", "K", "R")
#: Terms never fitted together (only the sum of their shapes would be identified).
EXCLUSIVE = frozenset({"Q", "F"})


def compatible(names: tuple[str, ...]) -> bool:
    """Whether a set of terms is identifiable as a set: not both of :data:`EXCLUSIVE`, and
    F only beside N (a prefilter's deficit is the white noise's)."""
    return not EXCLUSIVE <= set(names) and ("F" not in names or "N" in names)


def term(name: str) -> AbstractAllanTerm:
    """The static fit's term of letter ``name``."""
    return STATIC_TERMS[TERM_NAMES.index(name)]


def shapes(stats: HaarStatistics, names: tuple[str, ...]) -> np.ndarray:
    """(levels, terms) Allan-variance shapes of ``names`` at the log's averaging times."""
    memo = stats.memo
    for n in names:
        if n not in memo:
            memo[n] = term(n).allan_variance(stats.tau_s, stats.tau0_s, stats.gm_tc_s)
    return np.stack([memo[n] for n in names], axis=1).reshape(stats.m.size, len(names))


def envelope(stats: HaarStatistics) -> dict[str, float]:
    """Per term, the amplitude at which it alone would explain the smallest Allan variance
    the log shows relative to its shape (datasheet units); F's is Q's."""
    if "envelope" in stats.memo:
        return stats.memo["envelope"]
    names = tuple(n for n in TERM_NAMES if n != "F" and (n != "G" or np.isfinite(stats.gm_tc_s)))
    g = shapes(stats, names)
    out = {n: float(np.sqrt(np.min(stats.avar / g[:, k]))) for k, n in enumerate(names)}
    stats.memo["envelope"] = out | {"F": out["Q"]}  # a deficit of Q's shape, bounded alike
    return stats.memo["envelope"]


def ceiling(stats: HaarStatistics) -> dict[str, float]:
    """Per term, the amplitude at which it alone would explain the *largest* Allan variance
    the log shows relative to its shape: above it the term overshoots every level (F's is
    Q's). The envelope (the smallest) can lie far below what a term takes where one level
    happens to read low (a long averaging time of two coefficients)."""
    names = tuple(n for n in TERM_NAMES if n != "F" and (n != "G" or np.isfinite(stats.gm_tc_s)))
    g = shapes(stats, names)
    with np.errstate(divide="ignore"):
        out = {n: float(np.sqrt(np.max(stats.avar / g[:, k]))) for k, n in enumerate(names)}
    return out | {"F": out["Q"]}


def level_log_likelihood(variance: np.ndarray, stats: HaarStatistics) -> np.ndarray:
    """Per level, the log-likelihood of its Haar coefficients given their model variance
    ``2 AVAR`` (..., levels), in NumPy (:class:`NoiseDensity` is the same in JAX)."""
    return -0.5 * stats.count * np.log(2.0 * np.pi * variance) - 0.5 * stats.sum_sq / variance
