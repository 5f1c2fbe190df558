"""What a term adds to a static log's Allan variance (``gyroid noise``), and the terms that
only a static log's Allan variance has (quantisation, a rate ramp, a prefilter's deficit).

A term of a static log's Allan variance (:class:`AbstractAllanTerm`) adds ``a**2 g(tau)``
to it ((deg/h)^2 at averaging time ``tau``, s), with amplitude ``a`` in its datasheet unit:

====  ==========================  ==============  =============================================
code  process                     unit            ``g(tau)``
====  ==========================  ==============  =============================================
Q     angle quantisation          deg             ``3 (3600)**2 / tau**2``
N     angle random walk (white)   deg/sqrt(h)     ``3600 / tau``
B     bias instability (flicker)  deg/h           ``2 ln 2 / pi`` (IEEE's 0.664 B floor)
K     rate random walk            deg/h/sqrt(h)   ``(tau / 3 + tau0**2 / (6 tau)) / 3600``
R     rate ramp                   deg/h^2         ``tau**2 / (2 3600**2)``
G     Gauss-Markov bias           deg/h           exact for a sampled first-order process of
                                                  correlation time ``Tc``
F     prefilter                   deg             ``-3 (3600)**2 / tau**2``
====  ==========================  ==============  =============================================

The rate random walk's form is exact for a sampled walk (the second term is the sampling's);
Q to R are IEEE Std 952's. F is a gyro's digital low-pass filter (or decimation): a short FIR
filter of white noise leaves ``AVAR = (60 N)^2 / tau - c / tau^2`` from a few samples on,
quantisation's shape with the other sign (read as white noise alone, a two-tap average's N
had come out 9 % low with a 2 % interval).

Each process term also gives the covariance of the overlapping Haar coefficients (the
difference of adjacent ``tau``-means, ``E e**2 = 2 AVAR``) a lag apart
(:meth:`AbstractAllanTerm.haar_covariance`), from the generalised covariance ``C(u)`` of
the angle (the rate's integral, deg/h s), ``cov(e_t, e_(t+k)) = sum_d w_d C(k + d tau) /
tau**2`` with ``w = (1, -4, 6, -4, 1)`` at ``d = -2..2``: white noise ``-S |u| / 2``, a
rate random walk ``q |u|**3 / 12``, flicker ``h u**2 ln|u|``, a Gauss-Markov bias's
exponential kernel integrated twice, quantisation's white angle. They give the overlapping
Allan variance's degrees of freedom under a fitted model
(:mod:`gyroid.allan._interval`). F is a deficit, not a process, and gives none.

The terms a drift log's likelihood shares (N, B, K, G) are :mod:`gyroid.noise._terms`'s.
"""

from __future__ import annotations

import abc
import math
from typing import ClassVar

import equinox as eqx
import numpy as np


class AbstractAllanTerm(eqx.Module):
    """A term of a static log's Allan variance: amplitude ``a`` (datasheet unit ``unit``)
    adds ``a**2 allan_variance(tau)`` ((deg/h)^2)."""

    #: Its letter in ``noise.json`` (IEEE 952's Q, N, B, K, R; G and F).
    code: eqx.AbstractClassVar[str]
    #: What the process is, in words.
    description: eqx.AbstractClassVar[str]
    unit: eqx.AbstractClassVar[str]
    #: Why a log may not resolve it.
    unresolved_hint: eqx.AbstractClassVar[str]

    @abc.abstractmethod
    def allan_variance(self, tau_s: np.ndarray, tau0_s: float, tc_s: float) -> np.ndarray:
        """Its Allan variance at averaging times ``tau_s`` per unit amplitude squared, for
        samples ``tau0_s`` apart (``tc_s``: a Gauss-Markov bias's correlation time, which
        only G reads)."""

    def haar_covariance(self, lag_s: np.ndarray, tau_s: float, tc_s: float
                        ) -> np.ndarray | None:
        """The covariance ((deg/h)^2 per unit amplitude squared) of overlapping Haar
        coefficients at averaging time ``tau_s`` that are ``lag_s`` (>= 0) apart; None for a
        term that is not a process (F, a deficit), which the degrees of freedom leave out."""
        del lag_s, tau_s, tc_s
        return None


#: The fourth central difference's weights at ``d = -2..2`` steps: a Haar coefficient's
#: second difference of the angle, squared out.
FOURTH_DIFFERENCE = np.array([1.0, -4.0, 6.0, -4.0, 1.0])


def second_differenced(angle_covariance, lag_s: np.ndarray, tau_s: float) -> np.ndarray:
    """``sum_d w_d C(lag + d tau) / tau**2`` (module docstring) for an angle's generalised
    covariance ``C`` (a function of ``|u|``, s)."""
    lag = np.asarray(lag_s, dtype=float)
    total = np.zeros_like(lag)
    for w, d in zip(FOURTH_DIFFERENCE, range(-2, 3), strict=True):
        total += w * angle_covariance(np.abs(lag + d * tau_s))
    return total / tau_s**2


def finite_reach(covariance: np.ndarray, lag_s: np.ndarray, tau_s: float) -> np.ndarray:
    """``covariance`` with the lags at which two coefficients share no increment (``2 tau``
    or more apart) set to zero exactly (their sum cancels only to rounding)."""
    return np.where(np.asarray(lag_s) < 2.0 * tau_s * (1.0 - 1e-12), covariance, 0.0)


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


def flicker_haar_covariance(lag_s: np.ndarray, tau_s: float) -> np.ndarray:
    """Flicker's (unit ``B``) overlapping Haar coefficients' covariance ``lag_s`` apart at
    averaging time ``tau_s``: the angle's ``u**2 ln|u| / (2 pi)`` differenced."""
    lag = np.asarray(lag_s, dtype=float)
    out = np.empty_like(lag)
    near = lag < 8.0 * tau_s

    def angle(u):
        value = np.zeros_like(u)
        positive = u > 0
        value[positive] = u[positive] ** 2 * np.log(u[positive]) / (2.0 * math.pi)
        return value

    out[near] = second_differenced(angle, lag[near], tau_s)
    # far off, the fourth difference of u^2 ln u is -2 tau^4 / u^2 (1 + tau^2 / u^2
    # + 1.5 tau^4 / u^4 + ...): the direct sum cancels to rounding there
    ratio = (tau_s / lag[~near]) ** 2
    out[~near] = -ratio * (1.0 + ratio + 1.5 * ratio**2) / math.pi
    return out


def gauss_markov_haar_covariance(lag_s: np.ndarray, tau_s: float, tc_s: float) -> np.ndarray:
    """A unit-variance Gauss-Markov bias's (correlation time ``tc_s``) overlapping Haar
    coefficients' covariance ``lag_s`` apart at averaging time ``tau_s``; zero without a
    correlation time."""
    lag = np.asarray(lag_s, dtype=float)
    out = np.zeros_like(lag)
    if not np.isfinite(tc_s):
        return out

    def angle(u):
        # -tc^2 (x - 1 + e^-x), x = u / tc, less its x^2 / 2, which the fourth
        # difference removes exactly and which, kept, cancels every digit where tc >> u
        x = u / tc_s
        small = x < 1e-2
        value = np.empty_like(x)
        xs = x[small]
        value[small] = -(xs**3) / 6.0 + xs**4 / 24.0 - xs**5 / 120.0 + xs**6 / 720.0
        xl = x[~small]
        value[~small] = xl - 1.0 + np.exp(-xl) - xl**2 / 2.0
        return -(tc_s**2) * value

    near = lag < 2.0 * tau_s
    out[near] = second_differenced(angle, lag[near], tau_s)
    # apart, only the exponential part is left: -tc^2 e^(-k / tc) sum_d w_d e^(-d tau /
    # tc) / tau^2, the sum (2 sinh(tau / 2 tc))^4, taken in logs
    half = 0.5 * tau_s / tc_s
    log_sinh = half + math.log1p(-math.exp(-2.0 * half))
    out[~near] = -(tc_s**2) / tau_s**2 * np.exp(4.0 * log_sinh - lag[~near] / tc_s)
    return out


class Quantisation(AbstractAllanTerm):
    """IEEE 952's angle quantisation Q (deg): an excess at the shortest averaging times."""

    code: ClassVar[str] = "Q"
    description: ClassVar[str] = "angle quantisation"
    unit: ClassVar[str] = "deg"
    unresolved_hint: ClassVar[str] = "a rate too slow, or samples averaged before logging"

    def allan_variance(self, tau_s, tau0_s, tc_s):
        return 3.0 * 3600.0**2 / tau_s**2

    def haar_covariance(self, lag_s, tau_s, tc_s):
        # a white angle of variance 3600**2 (deg/h s)^2: only where both ends meet
        return second_differenced(
            lambda u: np.where(u < 1e-9 * tau_s, 3600.0**2, 0.0), lag_s, tau_s)


class RateRamp(AbstractAllanTerm):
    """IEEE 952's rate ramp R (deg/h^2): a rate drifting steadily over the log."""

    code: ClassVar[str] = "R"
    description: ClassVar[str] = "rate ramp"
    unit: ClassVar[str] = "deg/h^2"
    unresolved_hint: ClassVar[str] = "the log is too short, or its rate does not drift steadily"

    def allan_variance(self, tau_s, tau0_s, tc_s):
        return tau_s**2 / (2.0 * 3600.0**2)

    def haar_covariance(self, lag_s, tau_s, tc_s):
        # a steady ramp moves every coefficient alike
        return np.full(np.shape(lag_s), tau_s**2 / 3600.0**2)


class Prefilter(AbstractAllanTerm):
    """A digital low-pass filter's (or decimation's) deficit F (deg) below white noise at
    the shortest averaging times: quantisation's shape with the other sign."""

    code: ClassVar[str] = "F"
    description: ClassVar[str] = "prefilter (low-pass deficit)"
    unit: ClassVar[str] = "deg"
    unresolved_hint: ClassVar[str] = "the shortest averaging times are not below white noise"

    def allan_variance(self, tau_s, tau0_s, tc_s):
        return -3.0 * 3600.0**2 / tau_s**2
