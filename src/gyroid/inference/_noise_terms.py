"""The IEEE Std 952 noise terms a static rate log's Allan variance is a sum of, and the
Haar levels' likelihood.

Each term ``k`` adds ``a_k**2 g_k(tau)`` to the Allan variance (deg/h)^2 at averaging time
``tau`` (s), with ``a_k`` in the datasheet's unit:

====  ==========================  ==============  =============================================
name  process                     unit            ``AVAR``
====  ==========================  ==============  =============================================
Q     angle quantisation          deg             ``3 (3600 Q)**2 / tau**2``
N     angle random walk (white)   deg/sqrt(h)     ``(60 N)**2 / tau``
B     bias instability (flicker)  deg/h           ``(2 ln 2 / pi) B**2`` (IEEE's 0.664 B floor)
K     rate random walk            deg/h/sqrt(h)   ``(K / 60)**2 (tau / 3 + tau0**2 / (6 tau))``
R     rate ramp                   deg/h^2         ``(R / 3600)**2 tau**2 / 2``
====  ==========================  ==============  =============================================

The rate random walk's form is exact for a sampled walk (the second term is the sampling's);
the others are IEEE's.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from gyroid.inference._haar import HaarStatistics


@dataclass(frozen=True)
class NoiseTerm:
    """One noise process: its name, what it is, its datasheet unit and Allan-variance shape
    ``g(tau, tau0)`` ((deg/h)^2 per unit amplitude squared)."""

    name: str
    process: str
    unit: str
    shape: Callable[[np.ndarray, float], np.ndarray]
    #: Why a log may not resolve it.
    unresolved_hint: str


NOISE_TERMS: tuple[NoiseTerm, ...] = (
    NoiseTerm("Q", "angle quantisation", "deg", lambda tau, t0: 3.0 * 3600.0**2 / tau**2,
              "a rate too slow, or samples averaged before logging"),
    NoiseTerm("N", "angle random walk", "deg/sqrt(h)", lambda tau, t0: 3600.0 / tau,
              "another process dominates the shortest averaging times"),
    NoiseTerm("B", "bias instability", "deg/h",
              lambda tau, t0: np.full_like(tau, 2.0 * math.log(2.0) / math.pi),
              "white noise or a random walk covers the flicker floor"),
    NoiseTerm("K", "rate random walk", "deg/h/sqrt(h)",
              lambda tau, t0: (tau / 3.0 + t0**2 / (6.0 * tau)) / 3600.0,
              "the log is too short for the walk to rise above the floor"),
    NoiseTerm("R", "rate ramp", "deg/h^2", lambda tau, t0: tau**2 / (2.0 * 3600.0**2),
              "the log is too short, or its rate does not drift steadily"),
)
TERM_NAMES = tuple(t.name for t in NOISE_TERMS)


def term(name: str) -> NoiseTerm:
    return NOISE_TERMS[TERM_NAMES.index(name)]


def shapes(stats: HaarStatistics, names: tuple[str, ...]) -> np.ndarray:
    """(levels, terms) Allan-variance shapes of ``names`` at the log's averaging times."""
    return np.stack([term(n).shape(stats.tau_s, stats.tau0_s) for n in names], axis=1)


def envelope(stats: HaarStatistics) -> dict[str, float]:
    """Per term, the amplitude at which it alone would explain the smallest Allan variance
    the log shows relative to its shape (datasheet units)."""
    g = shapes(stats, TERM_NAMES)
    return {n: float(np.sqrt(np.min(stats.avar / g[:, k]))) for k, n in enumerate(TERM_NAMES)}


def level_log_likelihood(variance: np.ndarray, stats: HaarStatistics) -> np.ndarray:
    """Per level, the log-likelihood of its Haar coefficients given their model variance
    ``2 AVAR`` (..., levels), in NumPy (:class:`NoiseDensity` is the same in JAX)."""
    return -0.5 * stats.count * np.log(2.0 * np.pi * variance) - 0.5 * stats.sum_sq / variance
