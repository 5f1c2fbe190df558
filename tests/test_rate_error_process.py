"""The thermometer's noise through dT/dt as a filter's process
(:mod:`gyroid.noise._rate_error_process`): the block filter with it against the dense
Gaussian written from the oscillator's closed-form kernel (Foreman-Mackey et al. 2017,
independent of the matrix exponentials the filter uses), and the matched process against
the dT/dt estimator's own error."""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import random_blocks
from scipy import stats
from scipy.linalg import toeplitz

from gyroid.inference import BenchOptions, BenchProblem
from gyroid.io import BenchLog
from gyroid.models._rate_error import estimator_autocovariance
from gyroid.noise._block_filter import block_innovations, flicker_times, mean_covariance
from gyroid.noise._rate_error_process import (
    RateErrorProcess,
    block_system,
    divergence_per_block,
    match,
)


def _position_kernel(lag, variance, omega, quality):
    """The oscillator's position autocovariance (celerite's SHO term, Q > 1/2), for a
    velocity of variance ``variance``."""
    eta = math.sqrt(1.0 - 1.0 / (4.0 * quality**2))
    tau = np.abs(lag)
    return (variance / omega**2 * np.exp(-omega * tau / (2.0 * quality))
            * (np.cos(eta * omega * tau) + np.sin(eta * omega * tau) / (2.0 * eta * quality)))


def _velocity_mean_covariance(start, end, variance, omega, quality):
    """Cov of the velocity's means over intervals: differences of the position's kernel."""
    def k(x, y):
        return _position_kernel(x[:, None] - y[None, :], variance, omega, quality)

    length = end - start
    cov = k(end, end) - k(end, start) - k(start, end) + k(start, start)
    return cov / np.outer(length, length)


def _blocks(rng, n):
    return random_blocks(rng, n, span_s=(20.0, 40.0), longest_gap_s=300.0)


def _process(span, gap, variance=0.004, omega=0.015, quality=1.6):
    system = block_system(span, gap, variance, omega, quality)
    scalars = {"variance": variance, "omega": omega, "quality": quality, "divergence": 0.0,
               "divergence_without": 0.0}
    return RateErrorProcess(**{k: jnp.asarray(v) for k, v in (system | scalars).items()})


def _log_likelihood(y, span, gap, white, b, k, taus, unit, process, centred=True):
    innovation, variance = block_innovations(
        jnp.asarray(y), jnp.asarray(span), jnp.asarray(gap), jnp.asarray(white),
        [(jnp.asarray(taus), b, unit)], (k / 60.0) ** 2, centred=centred, rate_error=process)
    return -0.5 * float(jnp.sum(innovation**2 / variance + jnp.log(2 * np.pi * variance)))


@pytest.mark.parametrize("centred", [True, False])
def test_the_filter_with_the_process_is_the_exact_likelihood_of_block_means(centred):
    """With the rate error's two states appended, the filter's likelihood of block means of
    any lengths and gaps equals the dense Gaussian: white + flicker (+ the centred walk)
    + the oscillator's velocity means from its closed-form kernel."""
    rng = np.random.default_rng(1)
    span, gap, start, end = _blocks(rng, 70)
    white = np.full(span.size, 0.002)
    b, k = 0.05, (0.2 if centred else 0.0)
    taus, unit = flicker_times(span.min(), end[-1])
    cov = mean_covariance(start, end, white, [(taus, b, unit)], 0.0, 0.0)
    if centred:
        walk = mean_covariance(start, end, np.zeros(span.size), [], (k / 60.0) ** 2, 0.0)
        centring = np.eye(span.size) - np.outer(np.ones(span.size), span / span.sum())
        cov = cov + centring @ walk @ centring.T
    cov = cov + _velocity_mean_covariance(start, end, 0.004, 0.015, 1.6)
    y = rng.multivariate_normal(np.zeros(span.size), cov)
    exact = stats.multivariate_normal(np.zeros(span.size), cov).logpdf(y)
    filtered = _log_likelihood(y, span, gap, white, b, k, taus, unit, _process(span, gap),
                               centred)
    assert filtered == pytest.approx(exact, rel=1e-9)


def test_the_processes_dense_covariance_is_the_closed_form_kernels():
    rng = np.random.default_rng(2)
    span, gap, start, end = _blocks(rng, 60)
    dense = _process(span, gap).row_covariance()
    expected = _velocity_mean_covariance(start, end, 0.004, 0.015, 1.6)
    np.testing.assert_allclose(dense, expected, atol=1e-12 * expected.max())


@pytest.mark.parametrize(("window_s", "step_s"), [(585.0, 36.0), (1529.0, 36.0),
                                                  (1200.0, 6.0)])
def test_the_matched_process_leaves_a_twentieth_of_the_divergence(window_s, step_s):
    """The oscillator matched to the degree-5 differentiator's error (paper A's bench: a
    0.01 degC thermometer, wD = 2 deg/h per degC/h, white noise 0.3 deg/h per 1-s
    sample) leaves at most 5 % of the divergence that leaving the error out leaves, on
    the exact Gaussians of at least 240 blocks and three kernels' lengths (not the
    Whittle approximation the match uses)."""
    samples = step_s / 1.0
    target = 4.0 * estimator_autocovariance(window_s, step_s, 1e-4 / samples)
    white = 0.09 / samples
    variance, omega, quality, left, without = match(target, step_s, white)
    n = max(240, 3 * target.size)
    truth = toeplitz(np.pad(target, (0, max(0, n - target.size)))[:n]) + white * np.eye(n)

    def kl(approximation):
        solved = np.linalg.solve(approximation, truth)
        return 0.5 * (np.trace(solved) - n - np.linalg.slogdet(solved)[1])

    process = _process(np.full(n, step_s), np.zeros(n), variance, omega, quality)
    matched = kl(process.row_covariance() + white * np.eye(n))
    ignored = kl(white * np.eye(n))
    assert matched < 0.05 * ignored
    # the Whittle approximation the match minimises agrees with the exact divergence
    assert left * n == pytest.approx(matched, rel=0.3)
    assert without * n == pytest.approx(ignored, rel=0.3)


def test_the_divergence_of_a_process_from_itself_is_zero():
    target = estimator_autocovariance(600.0, 10.0, 1e-3)
    assert divergence_per_block(target, target, 1e-4) == pytest.approx(0.0, abs=1e-12)
    assert divergence_per_block(target, np.zeros(1), 1e-4) > 0.0


def _noisy_thermometer_bench(seed: int, hours: float = 4.0) -> BenchLog:
    """Paper A's thermal coefficients on raised-cosine transitions of 1 h at 1 Hz, white
    noise and a 0.01 degC thermometer (written here)."""
    rng = np.random.default_rng(seed)
    time_s = np.arange(hours * 3600.0)
    h = time_s / 3600.0
    s = np.clip(h - 1.0, 0.0, 1.0)
    temperature = 21.0 + 20.0 * 0.5 * (1.0 - np.cos(math.pi * s))
    rate = np.where((s > 0) & (s < 1), 10.0 * math.pi * np.sin(math.pi * s), 0.0)
    t = temperature - 21.0
    drift = 1.197 - 0.108 * t + 0.004 * t**2 + 1.997 * rate + rng.normal(0.0, 0.3, h.size)
    return BenchLog(columns={"time_s": time_s, "drift_deg_h": drift,
                             "temperature_C": temperature + rng.normal(0.0, 0.01, h.size)})


@pytest.mark.parametrize("noise", ["white+flicker+rw", "white+gm"])
def test_every_correlated_noise_model_carries_the_thermometer(noise):
    """Both correlated noise models carry the process (wD at its least-squares value,
    within 1 % of the truth here), the predictive check's covariance of parts adds its
    parts' means, and a new log's (compensation) does not: its thermometer is not the
    fitted log's."""
    log = _noisy_thermometer_bench(0)
    carried = BenchProblem.from_log(log, "thermal", BenchOptions(noise=noise, rate_window_s=600.0))
    left_out = BenchProblem.from_log(log, "thermal",
                                     BenchOptions(noise=noise, rate_window_s=600.0,
                                                  errors_in_variables=False))
    process = carried.density.noise.rate_error
    assert process is not None and left_out.density.noise.rate_error is None
    assert carried.rate_error_wd == pytest.approx(1.997, rel=0.01)
    assert carried.thermometer_sd_C == pytest.approx(0.01, rel=0.1)
    n = carried.density.n
    part = np.arange(n) // 10
    values = dict(zip(carried.noise_names, (0.3, 0.01, 600.0) if noise == "white+gm"
                      else (0.005, 0.01, 0.005), strict=True))
    time_s = np.asarray(carried.log.time_s)
    args = (time_s, part, part.max() + 1, carried.density.step_s, np.full(part.max() + 1, 0.01),
            values)
    with_it = carried.density.noise.part_covariance(*args, block_means=True)
    without = left_out.density.noise.part_covariance(*args, block_means=True)
    average = np.zeros((part.max() + 1, n))
    average[part, np.arange(n)] = 0.1
    np.testing.assert_allclose(with_it - without,
                               average @ process.row_covariance() @ average.T, atol=1e-15)
    after = carried.density.noise.part_covariance(*args, block_means=True, after_s=3600.0)
    np.testing.assert_allclose(after, left_out.density.noise.part_covariance(
        *args, block_means=True, after_s=3600.0))


@pytest.mark.slow
def test_a_log_of_bursts_carries_none():
    """The estimator differentiates a log of bursts on a grid across its gaps: its error
    is not the rows' kernel, and nothing is carried (as under white noise); the automatic
    window is chosen without it (reading the estimator as a matrix on that grid failed with
    an internal error on PAN's real burst log)."""
    log = _noisy_thermometer_bench(1)
    kept = (np.asarray(log.time_s) % 300.0) < 60.0
    bursts = BenchLog(columns={k: np.asarray(v)[kept] for k, v in log.columns.items()})
    for window in (600.0, None):
        problem = BenchProblem.from_log(bursts, "thermal", BenchOptions(
            noise="white+flicker+rw", rate_window_s=window))
        assert problem.thermometer_sd_C == 0 and problem.density.noise.rate_error is None
