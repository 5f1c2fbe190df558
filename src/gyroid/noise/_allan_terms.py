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


class Quantisation(AbstractAllanTerm):
    """IEEE 952's angle quantisation Q (deg): an excess at the shortest averaging times."""

    code: ClassVar[str] = "Q"
    description: ClassVar[str] = "angle quantisation"
    unit: ClassVar[str] = "deg"
    unresolved_hint: ClassVar[str] = "a rate too slow, or samples averaged before logging"

    def allan_variance(self, tau_s, tau0_s, tc_s):
        return 3.0 * 3600.0**2 / tau_s**2


class RateRamp(AbstractAllanTerm):
    """IEEE 952's rate ramp R (deg/h^2): a rate drifting steadily over the log."""

    code: ClassVar[str] = "R"
    description: ClassVar[str] = "rate ramp"
    unit: ClassVar[str] = "deg/h^2"
    unresolved_hint: ClassVar[str] = "the log is too short, or its rate does not drift steadily"

    def allan_variance(self, tau_s, tau0_s, tc_s):
        return tau_s**2 / (2.0 * 3600.0**2)


class Prefilter(AbstractAllanTerm):
    """A digital low-pass filter's (or decimation's) deficit F (deg) below white noise at
    the shortest averaging times: quantisation's shape with the other sign."""

    code: ClassVar[str] = "F"
    description: ClassVar[str] = "prefilter (low-pass deficit)"
    unit: ClassVar[str] = "deg"
    unresolved_hint: ClassVar[str] = "the shortest averaging times are not below white noise"

    def allan_variance(self, tau_s, tau0_s, tc_s):
        return -3.0 * 3600.0**2 / tau_s**2
