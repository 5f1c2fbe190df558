"""The thermometer's noise through dT/dt as a filter's process
(:mod:`gyroid.noise._rate_error_process`): the block filter with it against the dense
Gaussian written from the oscillator's closed-form kernel (Foreman-Mackey et al. 2017,
independent of the matrix exponentials the filter uses), and the matched process against
the dT/dt estimator's own error."""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import random_blocks
from scipy import stats
from scipy.linalg import toeplitz

from gyroid.bench import BenchOptions, BenchProblem
from gyroid.bench._thermometer import carried_thermometer
from gyroid.io import BenchLog
from gyroid.models._rate_error import estimator_autocovariance
from gyroid.noise._block_filter import block_innovations, flicker_times
from gyroid.noise._mean_covariance import mean_covariance
from gyroid.noise._rate_error_process import (
    RateErrorProcess,
    block_autocovariance,
    divergence_per_block,
    low_frequency_power,
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


def _process(span, gap, *oscillators):
    return RateErrorProcess.of(np.array(oscillators or [(0.004, 0.015, 1.6)]), span, gap)


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


@pytest.mark.parametrize("quality", [0.3, 0.5, 0.7, 1.6, 5.0])
def test_the_matchs_closed_form_is_the_filters_process(quality):
    """The match reads an oscillator's block means in closed form (its kernel's roots,
    over- and underdamped, critical a hair off); the filter runs its matrix exponentials:
    the same autocovariance."""
    n = 40
    process = _process(np.full(n, 10.0), np.zeros(n), (0.004, 0.015, quality))
    np.testing.assert_allclose(block_autocovariance(n, 10.0, 0.004, 0.015, quality),
                               process.row_covariance()[0], rtol=1e-5, atol=1e-12 * 0.004)


@pytest.mark.parametrize(("window_s", "step_s"), [(585.0, 36.0), (1529.0, 36.0),
                                                  (1200.0, 6.0)])
def test_the_matched_process_leaves_a_twentieth_of_the_divergence(window_s, step_s):
    """The oscillators matched to the degree-5 differentiator's error (paper A's bench: a
    0.01 degC thermometer, wD = 2 deg/h per degC/h, white noise 0.3 deg/h per 1-s
    sample) have its power at low frequencies and leave at most 5 % of the divergence
    that leaving the error out leaves, on the exact Gaussians of at least 240 blocks and
    three kernels' lengths (not the Whittle approximation the match uses). That
    approximation is the exact divergence's rate: a segment twice as long adds ``n`` times
    the divergence per block it states (the exact one has a term from the segment's ends
    besides, which does not grow with its length)."""
    samples = step_s / 1.0
    target = 4.0 * estimator_autocovariance(window_s, step_s, 1e-4 / samples)
    white = 0.09 / samples
    oscillators, left, without = match(target, step_s, white)
    lags = 64 * target.size
    summed = sum(block_autocovariance(lags, step_s, *row) for row in oscillators)
    assert low_frequency_power(summed) == pytest.approx(low_frequency_power(target), rel=1e-6)

    def divergences(n):
        truth = toeplitz(np.pad(target, (0, max(0, n - target.size)))[:n]) + white * np.eye(n)

        def kl(approximation):
            solved = np.linalg.solve(approximation, truth)
            return 0.5 * (np.trace(solved) - n - np.linalg.slogdet(solved)[1])

        process = _process(np.full(n, step_s), np.zeros(n), *oscillators)
        return kl(process.row_covariance() + white * np.eye(n)), kl(white * np.eye(n))

    n = max(240, 3 * target.size)
    matched, ignored = divergences(n)
    assert matched < 0.05 * ignored
    longer, ignored_longer = divergences(2 * n)
    assert (longer - matched) / n == pytest.approx(left, rel=0.05)
    assert (ignored_longer - ignored) / n == pytest.approx(without, rel=0.05)


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
    process = carried.density.noise.carried
    assert process is not None and left_out.density.noise.carried is None
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
        assert problem.thermometer_sd_C == 0 and problem.density.noise.carried is None


def _carried_of(problem: BenchProblem):
    """The thermometer's noise the problem's fit carries, on its rows."""
    return carried_thermometer(problem.log, problem.rate_window_s, problem.rate_error_wd,
                               problem.thermometer_sd_C**2 / problem.block_rows)


def test_a_fits_windows_share_their_compiled_shapes():
    """Every window a fit's search tries carries the one-sided rows in the same shapes (the
    widest window's reach, each end's directions padded to the estimator's degree):
    one compiled program serves the search. Padded, the carried covariance is the same."""
    log = _noisy_thermometer_bench(2, hours=3.0)
    problem = BenchProblem.from_log(log, "thermal", BenchOptions(noise="white+flicker+rw",
                                                                 rate_window_s=900.0))
    density = problem.density
    gap = np.zeros(density.n) if density.gap_s is None else np.asarray(density.gap_s)

    def ends(window_s: float, widest_s: float | None):
        carried = carried_thermometer(problem.log, window_s, problem.rate_error_wd,
                                      problem.thermometer_sd_C**2 / problem.block_rows,
                                      widest_s)
        noise = density.noise.without_rate_error().with_rate_error(
            carried, d0=np.full(density.n, density.row_scale**2),
            span_s=np.full(density.n, density.step_s), gap_s=gap, step_s=density.step_s)
        term = noise.carried_process
        assert term is not None and term.ends is not None
        return term

    def shapes(term):
        leaves, structure = jax.tree_util.tree_flatten(term.ends)
        return structure, [np.shape(x) for x in leaves]

    widest = ends(900.0, None)
    for window_s in (450.0, 600.0):
        narrower = ends(window_s, 900.0)
        assert shapes(narrower) == shapes(widest)
        alone = ends(window_s, None)
        assert shapes(alone) != shapes(widest)
        np.testing.assert_allclose(narrower.row_covariance(), alone.row_covariance(),
                                   rtol=0, atol=1e-12 * np.max(np.abs(alone.row_covariance())))


def _exact(problem: BenchProblem):
    """The problem's density with its carried thermometer's one-sided rows exact (as
    :meth:`~gyroid.noise.NoiseModel.with_rate_error` builds it, before a fit weighs them)."""
    density = problem.density
    carried = _carried_of(problem)
    gap = np.zeros(density.n) if density.gap_s is None else np.asarray(density.gap_s)
    noise = density.noise.without_rate_error().with_rate_error(
        carried, d0=np.full(density.n, density.row_scale**2),
        span_s=np.full(density.n, density.step_s), gap_s=gap, step_s=density.step_s)
    return eqx.tree_at(lambda d: d.noise, density, noise)


@pytest.mark.parametrize(("noise", "window_s"), [("white+gm", 600.0),
                                                 ("white+flicker+rw", 900.0)])
def test_the_one_sided_rows_are_read_by_the_process_only_where_that_moves_nothing(noise,
                                                                                 window_s):
    """A fit weighs its one-sided rows' exact error at the noise levels' marginal mode: on
    this bench beside a Gauss-Markov bias, with a 600 s window, it moves the coefficients,
    and it stays; beside the flicker and walk the default model allows, less than the
    tolerance, and the process reads those rows. There the fit's mode moves from the exact
    density's by less than the tolerance (in the exact posterior's sds)."""
    from gyroid.bench._point import point_estimate
    from gyroid.noise._rate_error_rows import ONE_SIDED_TOLERANCE

    log = _noisy_thermometer_bench(2, hours=3.0)
    problem = BenchProblem.from_log(log, "thermal", BenchOptions(noise=noise,
                                                                 rate_window_s=window_s))
    term = problem.density.noise.carried_process
    assert term is not None
    shift = float(term.one_sided_shift_sd)
    assert (term.ends is None) == (shift <= ONE_SIDED_TOLERANCE)
    assert (term.ends is None) == (noise != "white+gm")
    if term.ends is not None:
        return
    exact = point_estimate(_exact(problem))
    weighed = problem.mode()
    names = problem.model.parameter_names
    moved = [abs(weighed.value[k] - exact.value[k]) / exact.sd[k] for k in names]
    assert max(moved) < ONE_SIDED_TOLERANCE


def test_beside_white_noise_alone_the_rate_error_is_exact():
    """Beside white noise alone the thermometer's noise is the rows' exact covariance
    (its eigenbasis): no process, nothing weighed."""
    from gyroid.noise._terms import ExactRateError

    log = _noisy_thermometer_bench(2, hours=3.0)
    problem = BenchProblem.from_log(log, "thermal", BenchOptions(noise="white",
                                                                 rate_window_s=900.0))
    term = problem.density.noise.carried
    assert isinstance(term, ExactRateError) and problem.density.noise.carried_process is None
    exact = _carried_of(problem).covariance()
    np.testing.assert_allclose(term.row_covariance(), exact, rtol=0, atol=1e-12 * np.max(exact))


@pytest.mark.parametrize(("noise", "window_s"), [("white+gm", 900.0),
                                                 ("white+flicker+rw", 900.0),
                                                 ("white+flicker+rw", 6000.0)])
def test_the_carried_error_is_exact_on_the_one_sided_rows_and_a_covariance(noise, window_s):
    """The term every noise model carries: on the one-sided rows (within half a window of
    either end) the estimator's exact error, among themselves and with every other row;
    the process on the rest; a covariance (the least inflation along the one-sided rows'
    directions where the process falls short); and the filter's likelihood with it, rows
    held out or not, the dense Gaussian's. With a 900 s window the log's ends share no
    thermometer sample: the start's error is states of the first rows, the end's columns
    zero until its last window; with 6000 s on the 3 h log they share some, and the ends'
    directions are one set of columns."""
    log = _noisy_thermometer_bench(2, hours=3.0)
    problem = BenchProblem.from_log(log, "thermal", BenchOptions(noise=noise,
                                                                 rate_window_s=window_s))
    density = _exact(problem)  # the fit may read the one-sided rows by the process
    term = density.noise.carried_process
    assert term is not None and term.ends is not None
    time_s = np.asarray(problem.log.time_s)
    half = window_s / 2.0
    one_sided = (time_s < time_s[0] + half) | (time_s > time_s[-1] - half)
    assert np.array_equal(_carried_of(problem).one_sided, one_sided) and one_sided.any()
    apart = window_s < 1000.0
    assert (term.ends.early is not None) == apart
    exact = _carried_of(problem).covariance()
    design = term.row_covariance()
    scale = np.max(np.abs(exact))
    np.testing.assert_allclose(design[one_sided], exact[one_sided], atol=1e-9 * scale)
    assert np.linalg.eigvalsh(design)[0] > -1e-9 * np.linalg.eigvalsh(design)[-1]
    rng = np.random.default_rng(3)
    values = dict(zip(problem.noise_names, np.exp(rng.normal(np.log(0.01), 0.3,
                                                             len(problem.noise_names))),
                      strict=True))
    white, levels = density.row_filter.levels_of(jnp.log(jnp.asarray(list(values.values()))))
    n = density.n
    white_var = np.broadcast_to(np.asarray(white) ** 2, (n,))
    cov = density.noise.part_covariance(time_s, np.arange(n), n, density.step_s, white_var,
                                        values, block_means=True)
    y = rng.multivariate_normal(np.zeros(n), cov)
    kept = rng.random(n) > 0.2
    for keep in (np.ones(n, dtype=bool), kept):
        filtered = density.without_rows(~keep).row_filter.log_likelihood(jnp.asarray(y), white,
                                                                       levels)
        dense = stats.multivariate_normal(np.zeros(keep.sum()),
                                          cov[np.ix_(keep, keep)]).logpdf(y[keep])
        assert float(filtered) == pytest.approx(dense, rel=1e-9)


def test_the_inflation_is_none_where_the_process_holds_the_one_sided_rows_share():
    """Where the process's covariance of the other rows holds what the one-sided rows'
    error explains of them, nothing is inflated (here a process four times the matched
    one); the matched one falls short on paper A's benches, and is inflated only along
    the one-sided rows' directions, to a covariance."""
    from gyroid.noise._rate_error_rows import _inflation

    log = _noisy_thermometer_bench(2, hours=3.0)
    problem = BenchProblem.from_log(log, "thermal", BenchOptions(noise="white+gm",
                                                                 rate_window_s=900.0))
    term = _exact(problem).noise.carried_process
    assert term is not None and term.ends is not None
    process = term.process
    explained = term.ends.explained
    one_sided = np.asarray(process.mean_noise) == 0.0
    large = eqx.tree_at(lambda p: (p.state_noise, p.mean_noise, p.cross_noise, p.stationary),
                        process, (4.0 * process.state_noise, 4.0 * process.mean_noise,
                                  4.0 * process.cross_noise, 4.0 * process.stationary))
    np.testing.assert_allclose(_inflation(explained, one_sided, large), 0.0, atol=1e-12)
    inflation = term.ends.inflation
    assert np.linalg.eigvalsh(inflation)[-1] > 0.0
    assert np.linalg.eigvalsh(inflation)[0] > -1e-12


def test_the_coefficient_shift_is_what_dropping_a_low_rank_term_moves():
    """:func:`~gyroid.noise._rate_error_rows.coefficient_shift` against the shifts
    themselves: data drawn from ``gyro + exact`` (white noise and a walk; a rank-3 term
    near the log's start), generalised least squares under ``gyro + exact`` and under
    ``gyro`` alone. Its rms shift per coefficient, in its sd, is what 4000 draws give
    (within 5 %: their standard error is 1.1 %)."""
    from gyroid.noise._rate_error_rows import coefficient_shift

    rng = np.random.default_rng(7)
    n = 300
    t = np.linspace(0.0, 1.0, n)
    design = np.column_stack([np.ones(n), t, t**2])
    gyro = 0.04 * np.eye(n) + 0.01 * np.minimum.outer(t, t)
    loadings = np.zeros((n, 3))
    loadings[:20] = rng.normal(0.0, 0.03, (20, 3))
    exact = loadings @ loadings.T
    predicted = coefficient_shift(design, exact, np.zeros((n, n)), gyro)

    def gls(covariance, y):
        factor = np.linalg.cholesky(covariance)
        x = np.linalg.solve(factor, design)
        precision = x.T @ x
        return (np.linalg.solve(precision, x.T @ np.linalg.solve(factor, y)),
                np.sqrt(np.diag(np.linalg.inv(precision))))

    y = rng.multivariate_normal(np.zeros(n), gyro + exact, size=4000).T
    right, sd = gls(gyro + exact, y)
    taken, _ = gls(gyro, y)
    rms = np.sqrt(np.mean((taken - right) ** 2, axis=1)) / sd
    assert 0.05 < predicted < 0.5
    assert np.max(rms) == pytest.approx(predicted, rel=0.05)
