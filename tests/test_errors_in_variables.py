"""Errors in variables: the thermometer's noise carried through the dT/dt estimator into the
white-noise likelihood (models/_rate_error.py; the noise model's exact rate error,
noise/_rate_error_rows.py), wD at its least-squares value."""

import jax.numpy as jnp
import numpy as np
import pytest
from scipy.stats import multivariate_normal, norm

from gyroid.bench import BenchOptions, BenchProblem, fit_log
from gyroid.inference._emcee import Emcee
from gyroid.io import BenchLog
from gyroid.models import temperature_rate_deg_c_per_h
from gyroid.models._derived import RATE_WINDOW_S, _rate_and_floors, temperature_rate_operator
from gyroid.models._rate_error import thermometer_noise_var
from gyroid.simulation import GyroNoise, simulate_thermal_bench
from tests.helpers import SHORT_THERMAL


@pytest.mark.parametrize("sampling", ["uniform", "irregular", "fast"])
def test_the_rate_operator_is_the_estimator(sampling):
    # The estimator is linear once its end windows' degrees are chosen; the operator must
    # reproduce it on the data it was chosen from, to rounding.
    rng = np.random.default_rng(3)
    n = 600
    time_s = {"uniform": np.arange(n) * 30.0,
              "irregular": np.sort(rng.uniform(0.0, 18000.0, n)),
              "fast": np.sort(rng.uniform(0.0, 30.0, n))}[sampling]
    span = np.ptp(time_s)
    temperature = (30.0 + 8.0 * np.tanh((time_s - time_s.mean()) / (span / 6))
                   + 0.01 * rng.standard_normal(n))
    window = 1200.0 if sampling != "fast" else 1000.0  # "fast": the binned path
    operator = temperature_rate_operator(time_s, temperature, window)
    estimate = temperature_rate_deg_c_per_h(time_s, temperature, window)
    np.testing.assert_allclose(operator @ temperature, estimate,
                               atol=1e-10 * np.max(np.abs(estimate)))
    # every column: the estimator applied to each unit thermometer error (a uniform clock's
    # operator is written directly as a band and two end blocks)
    _, floors = _rate_and_floors(time_s, temperature, window)
    columns = rng.choice(n, 40, replace=False)
    unit = np.zeros((n, columns.size))
    unit[columns, np.arange(columns.size)] = 1.0
    np.testing.assert_allclose(operator[:, columns],
                               _rate_and_floors(time_s, unit, window, floors)[0],
                               atol=1e-12 * np.max(np.abs(operator)))


def test_thermometer_noise_is_read_from_a_moving_temperature():
    rng = np.random.default_rng(5)
    time_s = np.arange(0.0, 37_200.0)
    smooth = 21.0 + 15.0 * np.tanh((time_s - 18_000.0) / 3_000.0)
    # its curvature, read on means of 32 rows, is 0.1 % of a 0.01 degC thermometer
    assert np.sqrt(thermometer_noise_var(time_s, smooth)) < 1e-4
    noisy = smooth + 0.01 * rng.standard_normal(time_s.size)
    # 37 200 third differences: the variance's sampling error is ~2 %; the largest of six
    # aggregations adds a little more (documented: 1.02 on paper A's bench).
    assert np.sqrt(thermometer_noise_var(time_s, noisy)) == pytest.approx(0.01, rel=0.05)
    # a value held for 10 rows is as noisy, over a window, as sqrt(10) times a white one;
    # read on means of 16 rows it is 0.8 of that (documented), give or take 3 %
    held = smooth + np.repeat(0.01 * rng.standard_normal(time_s.size // 10), 10)
    assert np.sqrt(thermometer_noise_var(time_s, held)) > 0.7 * 0.01 * np.sqrt(10)
    # a smooth cycle read at 10 s is not taken for noise (aggregations span at most 20 s)
    cycle_s = 10.0 * np.arange(900)
    cycle = 30.0 - 15.0 * np.cos(2.0 * np.pi * cycle_s / 6000.0)
    assert np.sqrt(thermometer_noise_var(cycle_s, cycle)) < 1e-4


def _problem(sigma_known: bool, seed: int = 0) -> BenchProblem:
    sim = simulate_thermal_bench(protocol=SHORT_THERMAL, seed=seed,
                                 noise=GyroNoise(temperature_noise_C=0.05))
    columns = dict(sim.log.columns)
    if sigma_known:
        columns["sigma_deg_h"] = np.full(sim.log.n, sim.truth["noise"]["white_sd_deg_h"])
    return BenchProblem.from_log(BenchLog(columns=columns), "thermal",
                                 BenchOptions(noise="white", rate_window_s=RATE_WINDOW_S),
                                 max_rows=200)


def _rate_error_covariance(problem: BenchProblem) -> np.ndarray:
    """The rows' covariance the noise model carries for the thermometer, (deg/h)^2."""
    return np.asarray(problem.noise.carried.row_covariance())


@pytest.mark.parametrize("sigma_known", [False, True])
def test_the_likelihood_is_the_dense_gaussian(sigma_known):
    problem = _problem(sigma_known)
    density = problem.density
    assert problem.thermometer_sd_C > 0 and problem.block_rows > 1
    # wD^2 times the rate error's covariance, wD at its least-squares value on the log
    assert problem.rate_error_wd == pytest.approx(2.0, rel=0.05)
    rate_error = _rate_error_covariance(problem)
    rng = np.random.default_rng(1)
    m = problem.block_rows
    for _ in range(3):
        u = np.asarray(problem.mode().u) + 0.05 * rng.standard_normal(len(problem.names))
        white = (np.asarray(density.sigma) ** 2 if sigma_known
                 else np.full(problem.n, np.exp(2 * u[-1]) / m))
        covariance = np.diag(white) + rate_error
        residual = np.asarray(density.drift) - np.asarray(density.predict(jnp.asarray(u)))
        dense = multivariate_normal(np.zeros(problem.n), covariance).logpdf(residual)
        assert float(density.log_likelihood(jnp.asarray(u))) == pytest.approx(dense, abs=1e-6)
        # ... on the rows kept when a stretch is held out: the kept rows' marginal
        held = np.zeros(problem.n, dtype=bool)
        held[40:70] = True
        kept = ~held
        marginal = multivariate_normal(np.zeros(kept.sum()), covariance[np.ix_(kept, kept)])
        masked = density.without_rows(held)
        assert float(masked.log_likelihood(jnp.asarray(u))) == pytest.approx(
            marginal.logpdf(residual[kept]), abs=1e-6)
        # leave-one-out rows: each row's density given every other row
        rows = np.asarray(density.log_likelihood_rows(jnp.asarray(u)))
        for i in (0, 17, problem.n - 1):
            others = np.arange(problem.n) != i
            gain = covariance[i, others] @ np.linalg.inv(covariance[np.ix_(others, others)])
            mean = gain @ residual[others]
            variance = covariance[i, i] - gain @ covariance[others, i]
            expected = (-0.5 * np.log(2 * np.pi * variance)
                        - 0.5 * (residual[i] - mean) ** 2 / variance)
            assert rows[i] == pytest.approx(expected, abs=1e-8)


@pytest.mark.parametrize("sigma_known", [False, True])
def test_the_coefficients_integrate_out_exactly(sigma_known):
    """The coefficients' marginal (the one bench posterior, :mod:`gyroid.inference.
    _collapsed`) is the dense Gaussian with them integrated out under their normal priors,
    ``N(y; X m0, C + X S0 X')``, times the noise level's prior; their conditional is the
    generalised least-squares posterior."""
    from gyroid.inference._collapsed import collapse

    problem = _problem(sigma_known)
    density = problem.density
    p = problem.n_model
    loc, scale = np.asarray(density.prior_loc), np.asarray(density.prior_scale)
    assert np.all(np.asarray(density.prior_on)[:p] > 0)
    x = np.asarray(density.model.design(density.inputs))
    y = np.asarray(density.drift)
    marginal = collapse(density)
    rate_error = _rate_error_covariance(problem)
    v = np.asarray(problem.mode().u)[p:]
    for shift in (0.0, 0.3, -0.4):
        levels = v + shift
        white = (np.asarray(density.sigma) ** 2 if sigma_known
                 else np.full(problem.n, np.exp(2 * levels[0]) / problem.block_rows))
        covariance = np.diag(white) + rate_error
        inverse = np.linalg.inv(covariance)
        precision = x.T @ inverse @ x + np.diag(1.0 / scale[:p] ** 2)
        gls = np.linalg.solve(precision, x.T @ inverse @ y + loc[:p] / scale[:p] ** 2)
        # p(y) = p(y | b) p(b) / p(b | y) at the posterior mean b (a wide prior makes
        # C + X S0 X' too ill-conditioned to evaluate directly)
        expected = (multivariate_normal(x @ gls, covariance).logpdf(y)
                    + np.sum(norm.logpdf(gls, loc[:p], scale[:p]))
                    - 0.5 * np.linalg.slogdet(precision)[1] + 0.5 * p * np.log(2 * np.pi))
        if not sigma_known:
            expected += norm.logpdf(levels[0], loc[p], scale[p])
        got = float(marginal.log_posterior(jnp.asarray(levels)))
        assert got == pytest.approx(expected, abs=1e-6)
        mean, factor, _ = marginal._solve(jnp.asarray(levels))
        np.testing.assert_allclose(np.asarray(mean), gls, rtol=1e-8, atol=1e-10)
        np.testing.assert_allclose(np.asarray(factor) @ np.asarray(factor).T, precision,
                                   rtol=1e-8)


def test_the_standardised_residuals_are_the_whitened_residuals():
    problem = _problem(False)
    density = problem.density
    u = np.asarray(problem.mode().u)
    m = problem.block_rows
    covariance = (np.exp(2 * u[-1]) / m * np.eye(problem.n) + _rate_error_covariance(problem))
    residual = np.asarray(density.drift) - np.asarray(density.predict(jnp.asarray(u)))
    expected = np.linalg.solve(np.linalg.cholesky(covariance), residual)
    np.testing.assert_allclose(problem.standardised_residuals(u), expected, atol=1e-8)


@pytest.mark.parametrize("sigma_known", [False, True])
def test_held_out_folds_by_generalised_least_squares_match_refitted_modes(sigma_known):
    """The predictive check's folds under errors in variables hold the full fit's noise
    levels (the coefficients' exact conditional posterior on the rows kept); refitting
    every fold's mode, levels included, gives the same predictions and bands. The levels of
    ~160 kept rows move by ~1/sqrt(2*160) = 6 % between folds, so the bands agree to a few
    percent and the predictions to a small fraction of their sd."""
    from gyroid.bench._predictive import _collapsed_folds, _refit_folds
    from gyroid.inference._predictive import stretches

    problem = _problem(sigma_known, seed=2)
    density, time_s = problem.density, np.asarray(problem.log.time_s)
    parts = stretches(density.n)
    gls = _collapsed_folds(density, parts, time_s, np.asarray(problem.mode().u))
    refit = _refit_folds(density, parts, time_s)
    assert len(gls) == len(refit) == 5
    for a, b in zip(gls, refit, strict=True):
        sd = np.sqrt(np.diag(b.covariance))
        np.testing.assert_array_equal(a.observed, b.observed)
        assert np.max(np.abs(a.predicted - b.predicted) / sd) < 0.1
        assert np.sqrt(np.diag(a.covariance)) / sd == pytest.approx(1.0, abs=0.15)


@pytest.mark.slow
def test_the_demo_thermal_bench_passes_white_because_the_thermometer_is_modelled():
    # Issue 30: with a 0.01 degC thermometer the white likelihood failed its whiteness
    # check (2.01 against 2.0): wD times the rate estimator's error, correlated over its
    # window, was in the residuals. Carried in the likelihood, the same fit passes every
    # check; left out, it still fails, so no threshold moved.
    sim = simulate_thermal_bench(seed=0)
    carried = fit_log(sim.log, "thermal", BenchOptions(noise="white"), seed=0,
                      sampler=Emcee(progress=False))
    assert carried.problem.thermometer_sd_C == pytest.approx(0.01, rel=0.05)
    assert carried.trustworthy, carried.checks.lines()
    for name, truth in sim.truth["parameters"].items():
        summary = carried.posterior.summary[name]
        assert abs(summary["mean"] - truth) < 3.0 * summary["sd"], name
    plain = fit_log(sim.log, "thermal", BenchOptions(noise="white", errors_in_variables=False),
                    seed=0, sample=False)
    assert "residual_whiteness" in {c.name for c in plain.checks.failed}
