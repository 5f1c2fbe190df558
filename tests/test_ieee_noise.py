"""The IEEE 952 drift likelihood (white + flicker + rate random walk on block means): the
filter against the dense Gaussian written out pair by pair, the pair-by-pair covariance
against numerical integrals of the kernels, the flicker construction against IEEE's Allan
floor, the block-mean reduction, and ``--noise auto``'s choice."""

from __future__ import annotations

import math
import pickle

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import random_blocks
from scipy import integrate, stats

from gyroid.bench import BenchOptions, BenchProblem, fit_log
from gyroid.io import BenchLog
from gyroid.noise._block_filter import block_innovations, flicker_times
from gyroid.noise._mean_covariance import mean_covariance, part_covariance


def _blocks(rng, n):
    return random_blocks(rng, n, span_s=(0.5, 30.0), longest_gap_s=100.0)


def _centred_covariance(start, end, white, b, k, taus, unit, span):
    """White + flicker, and the walk centred on its span-weighted mean over the blocks:
    ``P C P'`` with ``P = I - 1 w'``, the walk's covariance from zero at time 0."""
    stationary = mean_covariance(start, end, white, [(taus, b, unit)], 0.0, 0.0)
    walk = mean_covariance(start, end, np.zeros(span.size), [], (k / 60.0) ** 2, 0.0)
    centring = np.eye(span.size) - np.outer(np.ones(span.size), span / span.sum())
    return stationary + centring @ walk @ centring.T


@pytest.mark.parametrize("held_out", [0, 7])
def test_the_filter_is_the_exact_likelihood_of_block_means_of_any_lengths_and_gaps(held_out):
    """The walk has no anchor at the first block: its level there is diffuse and it averages
    zero over the blocks. The filter's likelihood equals the dense Gaussian of that centred
    covariance, for blocks of any lengths and gaps, and with the first blocks held out
    (the predictive check's first fold; the diffuse level is then revealed later)."""
    rng = np.random.default_rng(0)
    span, gap, start, end = _blocks(rng, 80)
    n_arw, b, k = 0.3, 6.0, 10.0
    white = (60.0 * n_arw) ** 2 / span
    taus, unit = flicker_times(span.min(), end[-1])
    cov = _centred_covariance(start, end, white, b, k, taus, unit, span)
    y = rng.multivariate_normal(np.zeros(span.size), cov)
    kept = np.arange(span.size) >= held_out
    exact = stats.multivariate_normal(np.zeros(kept.sum()),
                                      cov[np.ix_(kept, kept)]).logpdf(y[kept])
    args = (jnp.asarray(span), jnp.asarray(gap), jnp.asarray(white),
            [(jnp.asarray(taus), b, unit)], (k / 60.0) ** 2, jnp.asarray(kept, dtype=float))
    innovation, variance = block_innovations(jnp.asarray(y), *args)
    terms = innovation**2 / variance + jnp.log(2 * np.pi * variance)
    filtered = -0.5 * float(jnp.sum(jnp.where(jnp.asarray(kept), terms, 0.0)))
    assert filtered == pytest.approx(exact, rel=1e-9)
    # the filter is linear in the data: columns are filtered alike
    both, _ = block_innovations(jnp.column_stack([y, -2.0 * y]), *args)
    np.testing.assert_allclose(both[:, 1], -2.0 * np.asarray(innovation), rtol=1e-12,
                               atol=1e-12)


@pytest.mark.parametrize("centred", [True, False])
def test_columns_zero_up_to_a_row_have_zero_innovations_there_and_leave_the_rest_alone(centred):
    """The one-sided rows' end columns are zero until the end's last window, and are filtered
    with the data from the first row (one scan): their innovations are exactly zero before
    their row (the walk's diffuse level revealed before it: the constraint's innovation at
    the first row learnt from is theirs too), and the other columns' are those of the
    filter without them; the first rows held out."""
    rng = np.random.default_rng(4)
    span, gap, _, end = _blocks(rng, 60)
    taus, unit = flicker_times(span.min(), end[-1])
    late_from = 41
    columns = rng.normal(size=(60, 5))
    columns[:late_from, 3:] = 0.0
    held_out = (np.arange(60) >= 3).astype(float)
    args = (jnp.asarray(span), jnp.asarray(gap), jnp.asarray((60.0 * 0.3) ** 2 / span),
            [(jnp.asarray(taus), 6.0, unit)], (10.0 / 60.0) ** 2 if centred else 0.0,
            jnp.asarray(held_out))
    whole, variance = block_innovations(jnp.asarray(columns), *args, centred=centred)
    alone, alone_variance = block_innovations(jnp.asarray(columns[:, :3]), *args,
                                              centred=centred)
    np.testing.assert_allclose(np.asarray(whole)[:, :3], np.asarray(alone), rtol=1e-12,
                               atol=1e-12)
    np.testing.assert_allclose(np.asarray(variance), np.asarray(alone_variance), rtol=1e-12)
    before = np.asarray(whole)[:late_from, 3:]
    learnt = np.flatnonzero(held_out[:late_from] > 0)
    assert np.all(before[learnt[1:]] == 0.0)  # the first row learnt from: the constraint's
    assert np.any(np.asarray(whole)[late_from:, 3:] != 0.0)


@pytest.mark.parametrize("centred", [True, False])
@pytest.mark.parametrize("held_out", [0, 3])
def test_constant_states_read_by_the_first_rows_add_their_covariance(centred, held_out):
    """``early``: constant standard-normal states read through loadings ``V`` on the first
    rows, filtered there and left out after: the likelihood is the dense Gaussian's with
    ``V V'`` added, first rows held out or not (the diffuse level revealed among them or
    after them), and with trailing columns zero until late beside them."""
    rng = np.random.default_rng(5)
    span, gap, start, end = _blocks(rng, 50)
    taus, unit = flicker_times(span.min(), end[-1])
    white = (60.0 * 0.3) ** 2 / span
    k = (10.0 / 60.0) ** 2 if centred else 0.0
    cov = (_centred_covariance(start, end, white, 6.0, 10.0, taus, unit, span) if centred
           else mean_covariance(start, end, white, [(taus, 6.0, unit)], 0.0, 0.0))
    loadings = np.zeros((50, 2))
    loadings[:9] = 3.0 * rng.normal(size=(9, 2))
    total = cov + loadings @ loadings.T
    y = rng.multivariate_normal(np.zeros(50), total)
    kept = np.arange(50) >= held_out
    exact = stats.multivariate_normal(np.zeros(kept.sum()),
                                      total[np.ix_(kept, kept)]).logpdf(y[kept])
    columns = np.column_stack([y, np.where(np.arange(50) >= 40, y, 0.0)])
    args = (jnp.asarray(span), jnp.asarray(gap), jnp.asarray(white),
            [(jnp.asarray(taus), 6.0, unit)], k, jnp.asarray(kept, dtype=float))
    innovation, variance = block_innovations(jnp.asarray(columns), *args, centred=centred,
                                             early=jnp.asarray(loadings[:9]))
    terms = innovation[:, 0] ** 2 / variance + jnp.log(2 * np.pi * variance)
    filtered = -0.5 * float(jnp.sum(jnp.where(jnp.asarray(kept), terms, 0.0)))
    assert filtered == pytest.approx(exact, rel=1e-9)


def test_a_walk_without_a_walk_is_a_constant_the_constraint_removes():
    """K = 0: the diffuse level cannot wander, and averaging zero it is zero: the
    centred filter gives the likelihood without any walk (the stationary noise's)."""
    rng = np.random.default_rng(1)
    span, gap, start, end = _blocks(rng, 40)
    white = (60.0 * 0.3) ** 2 / span
    taus, unit = flicker_times(span.min(), end[-1])
    cov = mean_covariance(start, end, white, [(taus, 6.0, unit)], 0.0, 0.0)
    y = rng.multivariate_normal(np.zeros(span.size), cov)
    innovation, variance = block_innovations(
        jnp.asarray(y), jnp.asarray(span), jnp.asarray(gap), jnp.asarray(white),
        [(jnp.asarray(taus), 6.0, unit)], 0.0)
    filtered = -0.5 * float(jnp.sum(innovation**2 / variance + jnp.log(2 * np.pi * variance)))
    exact = stats.multivariate_normal(np.zeros(span.size), cov).logpdf(y)
    assert filtered == pytest.approx(exact, rel=1e-9)


@pytest.mark.parametrize("tau", [0.3, 7.0, 400.0])
@pytest.mark.parametrize("second_start", [9.0, 5.0 - 1e-14])
def test_the_pairwise_covariance_integrates_the_kernels(tau, second_start):
    """Two intervals' means: the exponential kernel (one Gauss-Markov process) and the
    random walk's ``D min(s, t)``, integrated numerically over both intervals; apart, or
    touching with the second's start a rounding before the first's end (as a uniform
    clock's parts are: their covariance was dropped once)."""
    a, b = np.array([2.0, second_start]), np.array([5.0, 13.0])  # [2, 5], [.., 13]; origin 0
    exp_cov = mean_covariance(a, b, np.zeros(2), [(np.array([tau]), 1.0, 1.0)], 0.0, 0.0)
    walk_cov = mean_covariance(a, b, np.zeros(2), [], 1.0, 0.0)  # K = 60: D = 1 (deg/h)^2/s
    def both(f, i, j):
        """The integral of f(s, t) over interval i x interval j (on the diagonal, twice
        the triangle t < s, where the kernels are smooth)."""
        if i == j:
            return 2.0 * integrate.dblquad(lambda t, s: f(s, t), a[i], b[i], a[i],
                                           lambda s: s, epsabs=1e-13, epsrel=1e-11)[0]
        return integrate.dblquad(lambda t, s: f(s, t), a[i], b[i], a[j], b[j],
                                 epsabs=1e-13, epsrel=1e-11)[0]

    for i in range(2):
        for j in range(2):
            area = (b[i] - a[i]) * (b[j] - a[j])
            kernel = both(lambda s, t: math.exp(-abs(t - s) / tau), i, j)
            walk = both(min, i, j)
            assert exp_cov[i, j] == pytest.approx(kernel / area, rel=1e-8)
            assert walk_cov[i, j] == pytest.approx(walk / area, rel=1e-8)


def test_the_covariance_of_a_uniform_clocks_parts_is_positive_definite():
    """A 10^4-row log's 1000 block means, 37.2 s apart, in 80 touching parts (the
    predictive check's): rounding put some parts' ends past the next start, their
    covariance was dropped, and ``gyroid fit --noise white+flicker+rw`` stopped on a
    Cholesky factor that does not exist (a real run, 2026-11-24)."""
    step = 37.2
    time_s = 16.74 + step * np.arange(1000)
    part = np.arange(1000) * 80 // 1000
    white = np.full(80, 1e-4)
    taus, unit = flicker_times(step, time_s[-1] - time_s[0] + step)
    flicker, walk = [(taus, 0.0365, unit)], (0.0097 / 60.0) ** 2
    cov = part_covariance(time_s, part, 80, step, white, flicker, walk)
    assert np.linalg.eigvalsh(cov).min() > 0.5 * white.min()  # the white part at least
    # the same as with the parts' ends and starts made equal
    first = step * (part.searchsorted(np.arange(80))) + time_s[0] - 0.5 * step
    ends = np.append(first[1:], time_s[-1] + 0.5 * step)
    exact = mean_covariance(first, ends, white, flicker, walk, time_s[0] - 0.5 * step,
                            centre_span_s=time_s[-1] - time_s[0] + step)
    np.testing.assert_allclose(cov, exact, rtol=1e-9)


def test_the_centred_walks_dense_covariance_is_the_filters_on_tiled_blocks():
    """The predictive check's dense covariance centres the walk on the log's span, the
    filter on its blocks' weighted mean: the same on blocks that tile the log."""
    span = np.full(30, 20.0)
    end = np.cumsum(span)
    start = end - span
    taus, unit = flicker_times(20.0, end[-1])
    dense = mean_covariance(start, end, np.full(30, 0.1), [(taus, 0.0, unit)],
                            (5.0 / 60.0) ** 2, 0.0, centre_span_s=end[-1])
    np.testing.assert_allclose(dense, _centred_covariance(start, end, np.full(30, 0.1), 0.0,
                                                          5.0, taus, unit, span),
                               rtol=1e-9, atol=1e-12)


def test_the_flicker_sum_has_ieee_allan_floor_across_its_band():
    """IEEE 952: flicker of bias instability B has the Allan deviation 0.664 B (sqrt(2 ln 2
    / pi) B); the summed Gauss-Markov processes give it within 2 % from 8 shortest blocks
    to half the log (within 7 % down to the shortest block, where white noise rules)."""
    shortest, duration = 1.0, 20_000.0
    taus, unit = flicker_times(shortest, duration)
    floor = math.sqrt(2.0 * math.log(2.0) / math.pi)
    for tau, tolerance in [(1.0, 0.07), (8.0, 0.02), (100.0, 0.02), (1000.0, 0.02),
                           (10_000.0, 0.02)]:
        cov = mean_covariance(np.array([0.0, tau]), np.array([tau, 2.0 * tau]),
                              np.zeros(2), [(taus, 1.0, unit)], 0.0, 0.0)
        adev = math.sqrt(0.5 * (cov[0, 0] + cov[1, 1] - 2.0 * cov[0, 1]))
        assert adev == pytest.approx(floor, rel=tolerance), tau


def _flicker(rng, n, dt, b):
    """Flicker of bias instability ``b`` by shaping white noise's spectrum by f^-1/2 (a
    construction independent of the fitted one)."""
    spectrum = np.fft.rfft(rng.normal(size=2 * n))
    f = np.fft.rfftfreq(2 * n, dt)
    spectrum[1:] /= np.sqrt(f[1:])
    spectrum[0] = 0.0
    return b / math.sqrt(2.0 * math.pi * dt) * np.fft.irfft(spectrum)[:n]


def _ramp_log(rng, n, *, b=0.0, k=0.0, arw=0.3, dt=1.0):
    """A temperature ramp with drift 2 + 0.5 t (t = T - 21 degC) and the given noise."""
    time_s = np.arange(n) * dt
    temperature = 21.0 + 20.0 * np.sin(np.pi * time_s / time_s[-1])
    noise = rng.normal(0.0, 60.0 * arw / math.sqrt(dt), n)
    if b:
        noise += _flicker(rng, n, dt, b)
    if k:
        noise += np.cumsum(rng.normal(0.0, k / 60.0 * math.sqrt(dt), n))
    drift = 2.0 + 0.5 * (temperature - 21.0) + noise
    return BenchLog({"time_s": time_s, "drift_deg_h": drift, "temperature_C": temperature})


@pytest.mark.slow
def test_a_long_log_is_fitted_as_block_means_and_its_samples_checked_for_spikes():
    rng = np.random.default_rng(1)
    log = _ramp_log(rng, 5000, b=3.0)
    columns = dict(log.columns)
    columns["drift_deg_h"] = columns["drift_deg_h"].copy()
    columns["drift_deg_h"][1234] += 5000.0
    problem = BenchProblem.from_log(BenchLog(columns), "bias,temperature",
                                    BenchOptions(noise="white+flicker+rw"), max_rows=1000)
    assert problem.block_rows == 5 and problem.n == 1000
    assert problem.density.step_s == pytest.approx(5.0)
    # a problem on block means crosses a process boundary (the demo's pool came back from
    # its second process holding the runs' fitted problems, and could not be pickled)
    again = pickle.loads(pickle.dumps(problem))
    assert again.log.where(3) == problem.log.where(3) == "the mean of 5 samples from row 16"
    fit = fit_log(BenchLog(columns), "bias,temperature", BenchOptions(noise="white+flicker+rw"),
                  sample=False)
    spikes = {c.name: c for c in fit.checks.failed}["outliers_within_segments"]
    assert "row 1235" in spikes.message
    assert fit.to_json()["block_means"] == {"means": 1000, "rows_per_mean": 5, "rows": 5000}


@pytest.mark.slow
def test_auto_carries_flicker_and_a_walk_whatever_the_log():
    """The default carries the low-frequency processes on every log, white or not: no test
    with no power at the hour scales chooses the noise model (issue 42)."""
    rng = np.random.default_rng(2)
    for log in (_ramp_log(rng, 4000), _ramp_log(rng, 4000, b=30.0, k=20.0)):
        fit = fit_log(log, "bias,temperature", BenchOptions(noise="auto"), sample=False)
        assert fit.problem.noise.name == "white+flicker+rw"
        assert fit.noise_choice.startswith("auto: white+flicker+rw, always")
    white = fit_log(_ramp_log(rng, 500), "bias", BenchOptions(noise="white"), sample=False)
    assert white.to_json()["noise_choice"] == "asked for: white"


@pytest.mark.slow
def test_a_burst_log_is_read_as_it_is():
    """IEEE noise carries the wander between bursts as flicker and walk, over the gaps: asked
    for by name or by auto with --segment-means, the samples are fitted, and fit.json says
    so."""
    rng = np.random.default_rng(3)
    log = _ramp_log(rng, 12_000, k=200.0)
    bursts = (np.arange(12_000) // 20) % 2 == 0  # 20 s on, 20 s off: 300 bursts
    columns = {name: values[bursts] for name, values in log.columns.items()}
    named = fit_log(BenchLog(columns), "bias,temperature",
                    BenchOptions(noise="white+flicker+rw", segment_means=True), sample=False)
    assert named.to_json()["noise_choice"].startswith("asked for: white+flicker+rw (on the "
                                                      "samples")
    fit = fit_log(BenchLog(columns), "bias,temperature",
                  BenchOptions(noise="auto", segment_means=True), sample=False)
    assert fit.problem.n == named.problem.n
    # the means of a walk's bursts are a walk: not white
    assert fit.problem.noise.name == "white+flicker+rw"
    assert "on the samples" in fit.noise_choice
    # 6000 samples: means of 6 (3 per burst, its last 2 samples left out), 22 s apart
    # across a gap
    assert fit.problem.block_rows == 6 and fit.problem.n == 900
    gaps = np.asarray(fit.problem.density.gap_s)
    assert np.sum(gaps > 0) == 299 and np.allclose(gaps[gaps > 0], 22.0)


@pytest.mark.slow
def test_w0_is_the_bias_over_the_log_not_at_its_first_row():
    """A bias that walks far over the log (written here with NumPy's cumsum, not gyroid's
    simulator): under IEEE noise the posterior of w0 is centred on the log's mean bias,
    within its sd, and its interval holds it. With the walk anchored at zero at the first
    row (before issue 42), w0 was the bias of the first minutes: 63 deg/h off the log's mean
    bias, 16 of its 4 deg/h sd."""
    rng = np.random.default_rng(7)
    n, k = 20_000, 40.0  # 5.6 h at 1 Hz; K in deg/h/sqrt(h)
    time_s = np.arange(n, dtype=float)
    walk = np.cumsum(rng.normal(0.0, k / 60.0, n))
    walk -= walk[:600].mean() - 3.0  # the first ten minutes at 3 deg/h
    drift = walk + rng.normal(0.0, 60.0 * 0.3, n)
    log = BenchLog({"time_s": time_s, "drift_deg_h": drift})
    fit = fit_log(log, "bias", BenchOptions(noise="white+flicker+rw"), seed=1, progress=False)
    w0 = fit.posterior.summary["w0"]
    mean_bias, first_minutes = float(walk.mean()), float(walk[:600].mean())
    assert abs(first_minutes - mean_bias) > 5.0 * w0["sd"]  # the two readings differ
    assert abs(w0["mean"] - mean_bias) < 2.5 * w0["sd"], (w0, mean_bias)
    assert w0["ci95"][0] < mean_bias < w0["ci95"][1]
    # the point estimate reads w0 alike, and the model's level is the data's
    assert abs(fit.point.value["w0"] - mean_bias) < 2.5 * w0["sd"]
    level = fit.fitted_drift().draws[:, 0].mean()
    assert abs(level - drift.mean()) < 2.5 * w0["sd"]
