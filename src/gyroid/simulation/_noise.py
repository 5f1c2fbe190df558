"""Gyro noise in the usual FOG units: white (angle random walk) plus a correlated part."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

#: Peak of the Allan deviation of a first-order Gauss-Markov process over its sd
#: (reached at an averaging time of 1.89 correlation times).
GM_ADEV_PEAK = 0.6174


@dataclass(frozen=True)
class GyroNoise:
    """Noise of a gyro's rate output and of the bench's sensors.

    ``arw_deg_rt_h``: angle random walk, deg/sqrt(h); a sample averaged over ``dt`` seconds
    has a white-noise sd of ``arw * 60 / sqrt(dt)`` deg/h.
    ``bias_instability_deg_h``: the flat floor of the Allan deviation, deg/h, made by a
    first-order Gauss-Markov process of correlation time ``correlation_time_s`` whose sd is
    ``bias_instability / 0.6174`` (so that its Allan-deviation peak equals it); 0 turns the
    correlated part off.
    ``temperature_noise_C``, ``field_noise_uT``, ``accel_noise_g``: white noise of the
    bench's thermometer, magnetometer and accelerometer readings.
    """

    arw_deg_rt_h: float = 0.005
    bias_instability_deg_h: float = 0.0
    correlation_time_s: float = 300.0
    temperature_noise_C: float = 0.01
    field_noise_uT: float = 0.05
    accel_noise_g: float = 0.002

    def white_sd_deg_h(self, sample_s: float) -> float:
        """Sd of the white part of one sample averaged over ``sample_s`` seconds, deg/h."""
        return self.arw_deg_rt_h * 60.0 / np.sqrt(sample_s)

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def gauss_markov(
    rng: np.random.Generator, n: int, sample_s: float, sd: float, correlation_time_s: float
) -> np.ndarray:
    """Stationary first-order Gauss-Markov (AR(1)) sequence with the given sd."""
    if sd == 0.0 or n == 0:
        return np.zeros(n)
    phi = float(np.exp(-sample_s / correlation_time_s))
    shocks = rng.standard_normal(n) * sd * np.sqrt(1.0 - phi**2)
    shocks[0] = rng.standard_normal() * sd
    from scipy.signal import lfilter  # here: importing scipy.signal is slow at start-up

    return np.asarray(lfilter([1.0], [1.0, -phi], shocks))


def rate_noise(rng: np.random.Generator, n: int, sample_s: float, noise: GyroNoise) -> np.ndarray:
    """Rate noise of ``n`` samples at ``sample_s`` spacing, deg/h."""
    white = rng.standard_normal(n) * noise.white_sd_deg_h(sample_s)
    correlated = gauss_markov(
        rng, n, sample_s, noise.bias_instability_deg_h / GM_ADEV_PEAK, noise.correlation_time_s
    )
    return white + correlated
