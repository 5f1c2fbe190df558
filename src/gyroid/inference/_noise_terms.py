"""The noise terms a static rate log's Allan variance is a sum of (IEEE Std 952's, a
Gauss-Markov bias and a prefilter's deficit), and the Haar levels' likelihood.

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
G     Gauss-Markov bias           deg/h           exact for a sampled first-order process of
                                                  correlation time ``Tc`` (below)
F     prefilter                   deg             ``-3 (3600 F)**2 / tau**2``
====  ==========================  ==============  =============================================

The rate random walk's form is exact for a sampled walk (the second term is the sampling's);
Q to R are IEEE's. G, a first-order Gauss-Markov bias of stationary sd ``G`` (a MEMS gyro's
bump in the Allan deviation at some seconds to minutes, which rises as a random walk below
its correlation time and falls as white noise above it) is not an IEEE Std 952 term: its
correlation time is chosen per log
(:func:`~gyroid.inference._noise_problem.gauss_markov_time`) and held in the statistics
(``HaarStatistics.gm_tc_s``).

F is a gyro's digital low-pass filter (or decimation): a short FIR filter of white noise
leaves ``AVAR = (60 N)^2 / tau - c / tau^2`` exactly from a few samples on (a two-tap
average: ``c`` three quarters of the white variance at ``tau0``), so the shortest averaging
times lie *below* white noise by a ``1 / tau^2`` term, quantisation's shape with the other
sign. Q and F are never fitted together (only their difference would be identified): an
excess at the shortest times is quantisation, a deficit a prefilter. Read as white noise
alone, a two-tap average's N had come out 9 % low with a 2 % interval.
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
    ``g(tau, tau0, tc)`` ((deg/h)^2 per unit amplitude squared; ``tc`` the Gauss-Markov
    correlation time, s, which only G reads)."""

    name: str
    process: str
    unit: str
    shape: Callable[[np.ndarray, float, float], np.ndarray]
    #: Why a log may not resolve it.
    unresolved_hint: str


def gauss_markov_avar(tau_s: np.ndarray, tau0_s: float, tc_s: float) -> np.ndarray:
    """The Allan variance at ``tau_s = m tau0_s`` of a sampled first-order Gauss-Markov
    process of unit variance and correlation time ``tc_s`` (an AR(1) of coefficient
    ``phi = exp(-tau0 / tc)``), exactly: the variance of a block mean less the covariance
    of adjacent ones, ``[m + 2 S - phi (1 - phi^m)^2 / (1 - phi)^2] / m^2`` with
    ``S = sum_k (m - k) phi^k``. Zero without a correlation time (no G in the model)."""
    m = np.asarray(tau_s, dtype=float) / tau0_s
    if not np.isfinite(tc_s):
        return np.zeros_like(m)
    phi = math.exp(-tau0_s / tc_s)
    one = 1.0 - phi
    phi_m = np.exp(m * math.log(phi))
    s = phi * (m * one - (1.0 - phi_m)) / one**2
    return np.maximum((m + 2.0 * s - phi * (1.0 - phi_m) ** 2 / one**2) / m**2, 0.0)


NOISE_TERMS: tuple[NoiseTerm, ...] = (
    NoiseTerm("Q", "angle quantisation", "deg",
              lambda tau, t0, tc: 3.0 * 3600.0**2 / tau**2,
              "a rate too slow, or samples averaged before logging"),
    NoiseTerm("N", "angle random walk", "deg/sqrt(h)", lambda tau, t0, tc: 3600.0 / tau,
              "another process dominates the shortest averaging times"),
    NoiseTerm("B", "bias instability", "deg/h",
              lambda tau, t0, tc: np.full_like(tau, 2.0 * math.log(2.0) / math.pi),
              "white noise or a random walk covers the flicker floor"),
    NoiseTerm("K", "rate random walk", "deg/h/sqrt(h)",
              lambda tau, t0, tc: (tau / 3.0 + t0**2 / (6.0 * tau)) / 3600.0,
              "the log is too short for the walk to rise above the floor"),
    NoiseTerm("R", "rate ramp", "deg/h^2", lambda tau, t0, tc: tau**2 / (2.0 * 3600.0**2),
              "the log is too short, or its rate does not drift steadily"),
    NoiseTerm("G", "Gauss-Markov bias", "deg/h", gauss_markov_avar,
              "no bump in the Allan deviation that white noise, flicker and a walk leave"),
    NoiseTerm("F", "prefilter (low-pass deficit)", "deg",
              lambda tau, t0, tc: -3.0 * 3600.0**2 / tau**2,
              "the shortest averaging times are not below white noise"),
)
TERM_NAMES = tuple(t.name for t in NOISE_TERMS)
#: IEEE Std 952's terms (noise.json's ``terms``); G and F are reported on their own.
IEEE_TERMS = ("Q", "N", "B", "K", "R")
#: Terms never fitted together (only the sum of their shapes would be identified).
EXCLUSIVE = frozenset({"Q", "F"})


def compatible(names: tuple[str, ...]) -> bool:
    """Whether a set of terms is identifiable as a set: not both of :data:`EXCLUSIVE`, and
    F only beside N (a prefilter's deficit is the white noise's)."""
    return not EXCLUSIVE <= set(names) and ("F" not in names or "N" in names)


def term(name: str) -> NoiseTerm:
    return NOISE_TERMS[TERM_NAMES.index(name)]


def shapes(stats: HaarStatistics, names: tuple[str, ...]) -> np.ndarray:
    """(levels, terms) Allan-variance shapes of ``names`` at the log's averaging times."""
    return np.stack([term(n).shape(stats.tau_s, stats.tau0_s, stats.gm_tc_s) for n in names],
                    axis=1).reshape(stats.m.size, len(names))


def envelope(stats: HaarStatistics) -> dict[str, float]:
    """Per term, the amplitude at which it alone would explain the smallest Allan variance
    the log shows relative to its shape (datasheet units); F's is Q's."""
    names = tuple(n for n in TERM_NAMES if n != "F" and (n != "G" or np.isfinite(stats.gm_tc_s)))
    g = shapes(stats, names)
    out = {n: float(np.sqrt(np.min(stats.avar / g[:, k]))) for k, n in enumerate(names)}
    return out | {"F": out["Q"]}  # a deficit of quantisation's shape, bounded alike


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
