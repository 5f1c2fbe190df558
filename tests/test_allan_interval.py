"""The overlapping Allan deviation's interval under a fitted noise model, and the
``allan_interval`` check of ``gyroid noise``."""

import math

import allantools
import numpy as np
import pytest

from gyroid.allan import fit_noise
from gyroid.allan._haar import overlapping_haar
from gyroid.allan._interval import coefficient_covariance, overlapping_edf
from gyroid.noise import STATIC_TERMS


@pytest.mark.parametrize("term", [t for t in STATIC_TERMS if t.code != "F"],
                         ids=lambda t: t.code)
def test_each_terms_haar_covariance_at_lag_zero_is_twice_its_allan_variance(term):
    tau = np.geomspace(0.05, 5e4, 12)
    for t in tau:
        lag0 = term.haar_covariance(np.zeros(1), float(t), 30.0)[0]
        # the walk's tau0^2 / (6 tau) and G's sampling are the sampled forms' (tau0 1 ms)
        assert lag0 == pytest.approx(2.0 * term.allan_variance(np.array([t]), 1e-3, 30.0)[0],
                                     rel=1e-3)


def test_a_prefilter_is_no_process_and_has_no_covariance():
    (prefilter,) = [t for t in STATIC_TERMS if t.code == "F"]
    assert prefilter.haar_covariance(np.zeros(3), 1.0, 30.0) is None


@pytest.mark.parametrize(("code", "reach"), [("B", 8.0), ("G", 2.0)])
@pytest.mark.parametrize("tau", [0.05, 3.0, 4000.0])
def test_far_lags_join_the_near_ones(code, reach, tau):
    """Flicker and a bias change formula at a lag (the direct sum cancels to rounding
    beyond it): the two agree there."""
    (term,) = [t for t in STATIC_TERMS if t.code == code]
    lags = np.array([reach * tau * (1 - 1e-9), reach * tau])
    near, far = term.haar_covariance(lags, tau, 30.0)
    assert far == pytest.approx(near, rel=1e-4)


@pytest.mark.parametrize(("code", "alpha"), [("N", 0), ("B", -1), ("K", -2)])
@pytest.mark.parametrize("m", [64, 1024, 8192])
def test_degrees_of_freedom_are_greenhalls_for_the_ieee_processes(code, alpha, m):
    n = 100_000
    edf = overlapping_edf(m, [n - 2 * m + 1], 0.01, {code: 1.0}, math.nan)
    reference = allantools.edf_greenhall(alpha=alpha, d=2, m=m, N=n, overlapping=True,
                                         modified=False)
    assert edf == pytest.approx(reference, rel=0.006)


def test_degrees_of_freedom_of_white_noise_and_a_bias_match_simulation():
    """White noise plus a Gauss-Markov bias near the averaging time, which Greenhall's
    power-law table does not cover: the variance of the overlapping Allan variance over
    600 logs (its relative sd sqrt(2 / 599), 5.8 %, so 4 sd is 23 %), against the model's
    degrees of freedom and white noise's, 1.45x as many."""
    from scipy.signal import lfilter

    rng = np.random.default_rng(3)
    n, m, step, tc, sd = 4000, 16, 1.0, 10.0, 2.0
    phi = math.exp(-step / tc)
    values = []
    for _ in range(600):
        start = rng.normal(0.0, sd)
        shocks = rng.normal(0.0, sd * math.sqrt(1.0 - phi**2), n)
        bias, _ = lfilter([1.0], [1.0, -phi], shocks, zi=[phi * start])
        rate = rng.normal(size=n) + bias
        sums, counts = overlapping_haar(rate, [(0, n)], np.array([m]))
        values.append(sums[0] / (2 * counts.sum()))
    values = np.asarray(values)
    simulated = 2.0 * values.mean() ** 2 / values.var(ddof=1)
    # a sample's white variance 1 is N = step**0.5 / 60 deg/sqrt(h) at 1 s steps
    model = overlapping_edf(m, [n - 2 * m + 1], step, {"N": 1.0 / 60.0, "G": sd}, tc)
    white = overlapping_edf(m, [n - 2 * m + 1], step, {"N": 1.0 / 60.0}, tc)
    assert simulated == pytest.approx(model, rel=0.23)
    assert white > 1.4 * model and simulated < white / 1.2


def test_overlapping_allan_variance_is_allantools_and_never_spans_a_gap():
    rng = np.random.default_rng(0)
    rate = rng.normal(size=3000) + np.cumsum(rng.normal(scale=0.01, size=3000))
    m = np.array([1, 4, 32])
    sums, counts = overlapping_haar(rate, [(0, 3000)], m)
    _, adev, _, _ = allantools.oadev(rate, rate=1.0, data_type="freq", taus=m.astype(float))
    np.testing.assert_allclose(np.sqrt(sums[:, 0] / (2 * counts[:, 0])), adev, rtol=1e-9)
    # two stretches: their coefficients, none across the join
    split, counts2 = overlapping_haar(rate, [(0, 1000), (1000, 3000)], m)
    first, _ = overlapping_haar(rate[:1000], [(0, 1000)], m)
    second, _ = overlapping_haar(rate[1000:], [(0, 2000)], m)
    np.testing.assert_allclose(split, np.column_stack([first, second]), rtol=1e-12)
    assert counts2.tolist() == [[999, 1999], [993, 1993], [937, 1937]]


def test_coefficient_covariance_sums_the_terms():
    lags = np.array([0.0, 1.0, 5.0])
    both = coefficient_covariance(lags, 2.0, {"N": 0.3, "K": 2.0}, math.nan)
    parts = (coefficient_covariance(lags, 2.0, {"N": 0.3}, math.nan)
             + coefficient_covariance(lags, 2.0, {"K": 2.0}, math.nan))
    np.testing.assert_allclose(both, parts, rtol=1e-12)


def _static(rng, hours, sample_s, n_deg_sqrt_h, b_deg_h):
    """White noise and flicker (one-sided PSD ``B^2 / (pi f)``, white noise's spectrum
    shaped by ``f^-1/2`` over twice the length), written here, not gyroid's."""
    n = int(hours * 3600 / sample_s)
    rate = rng.normal(0.0, 60.0 * n_deg_sqrt_h / math.sqrt(sample_s), n)
    spectrum = np.fft.rfft(rng.normal(size=2 * n))
    f = np.fft.rfftfreq(2 * n, sample_s)
    spectrum[1:] /= np.sqrt(f[1:])
    spectrum[0] = 0.0
    return rate + b_deg_h / math.sqrt(2.0 * math.pi * sample_s) * np.fft.irfft(spectrum)[:n]


def _check(fit, name):
    (check,) = [c for c in fit.checks.checks if c.name == name]
    return check


@pytest.mark.slow
def test_a_log_the_terms_describe_passes_and_a_cycling_one_is_refused():
    """White noise and flicker: the check passes. The same log with a 40 s temperature
    cycle's square wave on it (a bump and a dip no sum of the terms makes): refused, with
    the averaging times named."""
    rng = np.random.default_rng(11)
    sample_s = 0.1
    rate = _static(rng, 4.0, sample_s, 0.5, 5.0)
    plain = fit_noise(rate, sample_s, seed=0)
    check = _check(plain, "allan_interval")
    assert check.passed, check.message
    time = np.arange(rate.size) * sample_s
    cycled = rate + 20.0 * np.sign(np.sin(2 * math.pi * time / 40.0))
    refused = fit_noise(cycled, sample_s, seed=0)
    check = _check(refused, "allan_interval")
    assert not check.passed
    assert not refused.trustworthy
    assert "allan.png" in check.message
    assert refused.overlapping is not None and refused.overlapping.outside.sum() >= 2
