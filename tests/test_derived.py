"""Derived inputs: the temperature-rate estimator, the lagged temperature, field-change signs."""

import jax
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from gyroid.models import (
    RATE_WINDOW_S,
    field_change_sign,
    lagged_temperature,
    temperature_rate_deg_c_per_h,
)


def test_rate_recovers_a_noisy_ramp_within_5_percent():
    rng = np.random.default_rng(11)
    time_s = np.arange(0.0, 4 * 3600.0)  # 1 Hz for 4 h
    true_rate = 3.0  # degC/h, a slow ramp
    temperature = 25.0 + true_rate * time_s / 3600.0 + 0.01 * rng.standard_normal(time_s.size)
    estimate = temperature_rate_deg_c_per_h(time_s, temperature)
    assert np.all(np.abs(estimate - true_rate) < 0.05 * true_rate)
    # A plain first difference of the same readings is ~50 degC/h of noise.
    plain = np.diff(temperature) / np.diff(time_s) * 3600.0
    assert 40.0 < plain.std() < 60.0


def test_rate_noise_matches_the_documented_formula():
    rng = np.random.default_rng(12)
    time_s = np.arange(0.0, 20 * 3600.0)
    noise = 0.01 * rng.standard_normal(time_s.size)
    estimate = temperature_rate_deg_c_per_h(time_s, 21.0 + noise)
    n = RATE_WINDOW_S + 1
    predicted = 0.01 * 3600.0 * np.sqrt(229.7 / n**3)
    interior = estimate[int(RATE_WINDOW_S) : -int(RATE_WINDOW_S)]
    # ~60 independent windows: the sample sd is within ~20 % of the truth.
    assert interior.std() == pytest.approx(predicted, rel=0.2)


def test_rate_is_no_noisier_at_the_ends_of_the_log_than_inside():
    # Found on null bench logs: a degree-5 slope at the window's end was 8x noisier than
    # inside, and its error, correlated over the first half window, was taken for warmup.
    rng = np.random.default_rng(14)
    time_s = np.arange(0.0, 2 * RATE_WINDOW_S)
    draws = np.array([
        temperature_rate_deg_c_per_h(time_s, 21.0 + 0.01 * rng.standard_normal(time_s.size))
        for _ in range(200)
    ])
    n = RATE_WINDOW_S + 1
    interior = 0.01 * 3600.0 * np.sqrt(229.7 / n**3)
    half = int(RATE_WINDOW_S / 2)
    ends = np.concatenate([draws[:, :half], draws[:, -half:]], axis=1)
    # 200 draws: a sample sd has a 5 % sampling error; 1.2 is 4 of them (it was 8x before).
    assert np.all(ends.std(axis=0) < 1.2 * interior)
    # ... and a locally quadratic temperature is still followed without bias at the ends.
    hours = time_s / 3600.0
    estimate = temperature_rate_deg_c_per_h(time_s, 21.0 + 2.0 * hours + 0.5 * hours**2)
    np.testing.assert_allclose(estimate, 2.0 + hours, atol=1e-9)


def test_a_log_starting_mid_transition_is_followed_without_bias_at_its_ends():
    # Lowering the degree at the ends (for noise) must not bend a curved start: an F test
    # keeps the degree the end window needs (a stretched 2 h schedule showed 50 degC/h of
    # error at its start without it).
    time_s = np.arange(0.0, 4 * 3600.0)
    hours = time_s / 3600.0
    temperature = 30.0 + 5.0 * np.tanh((hours - 0.25) / 0.3)
    true_rate = 5.0 / 0.3 / np.cosh((hours - 0.25) / 0.3) ** 2
    estimate = temperature_rate_deg_c_per_h(time_s, temperature)
    assert np.max(np.abs(estimate - true_rate)) < 0.01 * true_rate.max()


def test_rate_has_no_lag_on_a_smooth_transition_and_handles_irregular_sampling():
    rng = np.random.default_rng(13)
    time_s = np.sort(rng.uniform(0.0, 6 * 3600.0, 15000))
    hours = time_s / 3600.0
    temperature = 30.0 + 5.0 * np.tanh((hours - 3.0) / 0.7)
    true_rate = 5.0 / 0.7 / np.cosh((hours - 3.0) / 0.7) ** 2
    estimate = temperature_rate_deg_c_per_h(time_s, temperature)
    assert np.max(np.abs(estimate - true_rate)) < 0.01 * true_rate.max()


def test_lagged_temperature_solves_the_first_order_lag():
    time_s = np.linspace(0.0, 7200.0, 500)
    temperature = 21.0 + 10.0 * np.sin(time_s / 1500.0) + 0.002 * time_s
    tau_s = 600.0
    ode = solve_ivp(
        lambda t, y: (np.interp(t, time_s, temperature) - y) / tau_s,
        (0.0, time_s[-1]),
        [temperature[0]],
        t_eval=time_s,
        rtol=1e-10,
        atol=1e-10,
        max_step=5.0,
    )
    lagged = np.asarray(lagged_temperature(time_s / 3600.0, temperature, tau_s / 3600.0))
    np.testing.assert_allclose(lagged, ode.y[0], atol=2e-6)


def test_lagged_temperature_follows_a_ramp_tau_behind_and_is_differentiable():
    time_h = np.linspace(0.0, 5.0, 3001)
    temperature = 20.0 + 4.0 * time_h
    lagged = lagged_temperature(time_h, temperature, 0.25)
    np.testing.assert_allclose(
        np.asarray(lagged)[-100:], temperature[-100:] - 4.0 * 0.25, atol=1e-9
    )
    grad = jax.grad(lambda tau: lagged_temperature(time_h, temperature, tau)[-1])(0.25)
    assert float(grad) == pytest.approx(-4.0, rel=1e-6)


def test_field_change_sign_follows_a_noisy_sweep():
    rng = np.random.default_rng(5)
    levels = np.array([0, 50, 100, 50, 0, -50, 0], dtype=float)
    field = np.repeat(levels, 100) + 0.5 * rng.standard_normal(700)
    sign = field_change_sign(field)
    expected = np.repeat([0, 1, 1, -1, -1, -1, 1], 100)
    np.testing.assert_array_equal(sign, expected)


def _schmitt_reference(field, deadband):
    """The detector written as the plain loop it is (the library runs it as a JAX scan)."""
    out, state, low, high = np.zeros(field.size), 0.0, field[0], field[0]
    for i, h in enumerate(field):
        if state >= 0.0:
            high = max(high, h)
        if state <= 0.0:
            low = min(low, h)
        if state <= 0.0 and h > low + deadband:
            state, high = 1.0, h
        elif state >= 0.0 and h < high - deadband:
            state, low = -1.0, h
        out[i] = state
    return out


@pytest.mark.parametrize("seed", range(4))
def test_field_change_sign_equals_the_plain_loop(seed):
    rng = np.random.default_rng(seed)
    levels = np.repeat(rng.choice([-300.0, -50.0, 0.0, 50.0, 100.0, 300.0], size=60), 30)
    field = levels + rng.normal(0.0, 2.0 + 3.0 * seed, levels.size)
    np.testing.assert_array_equal(field_change_sign(field, 10.0),
                                  _schmitt_reference(field, 10.0))


def test_rate_window_scores_by_projection_equal_full_least_squares():
    # choose_rate_window projects each window's dT/dt off the other columns (QR once)
    # instead of refitting: the residual sums must be the least-squares ones.
    import jax.numpy as jnp

    from gyroid.bench import choose_rate_window
    from gyroid.models import DriftModel
    from gyroid.simulation import simulate_thermal_bench

    log = simulate_thermal_bench(seed=2).log
    model = DriftModel.from_terms("thermal")
    grid = np.array([300.0, 1200.0, 3600.0])
    best, scores = choose_rate_window(log, model, t0_C=21.0, grid=grid)
    inputs = log.inputs(t0_C=21.0)
    for window in grid:
        rate = temperature_rate_deg_c_per_h(log.time_s, log.columns["temperature_C"], window)
        design = np.asarray(model.design(
            type(inputs)(**{**vars(inputs), "rate_C_h": jnp.asarray(rate)})))
        residual = np.linalg.lstsq(design, log.drift_deg_h, rcond=None)[1][0]
        assert scores[window] == pytest.approx(residual, rel=1e-9)
    assert best == min(scores, key=scores.get)


@pytest.mark.parametrize("window_s", [400.0, 900.0, 20000.0])
def test_the_rate_errors_covariance_is_solved_by_its_band_as_densely(window_s):
    # covariance_solve: C = v L L' + w I solved by the band of L L' (the window's reach),
    # or densely where the band covers most of the log (the longest window here)
    import scipy.linalg

    from gyroid.bench._rate_window import covariance_solve
    from gyroid.models._derived import temperature_rate_operator

    time_s = np.arange(1000) * 36.0
    temperature = 21.0 + 20.0 * np.sin(2 * np.pi * time_s / time_s[-1])
    operator = temperature_rate_operator(time_s, temperature, window_s)
    right = np.random.default_rng(4).normal(size=(1000, 4))
    dense = operator @ operator.T * 0.7
    dense[np.diag_indices_from(dense)] += 0.3
    expected = scipy.linalg.solve(dense, right, assume_a="pos")
    np.testing.assert_allclose(covariance_solve(operator, 0.7, 0.3, right), expected,
                               rtol=1e-8, atol=1e-10 * np.abs(expected).max())


@pytest.mark.slow
def test_rate_window_of_a_model_with_a_time_constant_is_its_profiled_least_squares():
    """A model reading dT/dt with a warm-up (a time constant): each window's score is the
    least residual sum of squares over the time constant, the coefficients by least squares
    (the warm-up's column written out here); it had been the linearisation at zero, whose
    time constant of 0 made the first row NaN and the command a traceback."""
    import jax.numpy as jnp

    from gyroid.bench import choose_rate_window
    from gyroid.models import DriftModel
    from gyroid.simulation import simulate_thermal_bench

    truth = {"w_warmup": 1.0, "tau_warmup_min": 20.0}
    log = simulate_thermal_bench(seed=2, effects={"warmup": truth}).log
    model = DriftModel.from_terms("thermal,warmup")
    grid = np.array([300.0, 1200.0, 3600.0])
    best, scores = choose_rate_window(log, model, t0_C=21.0, grid=grid)
    inputs = log.inputs(t0_C=21.0)
    thermal = DriftModel.from_terms("thermal")
    elapsed_min = (log.time_s - log.time_s[0]) / 60.0
    for window in grid:
        rate = temperature_rate_deg_c_per_h(log.time_s, log.columns["temperature_C"], window)
        design = np.asarray(thermal.design(
            type(inputs)(**{**vars(inputs), "rate_C_h": jnp.asarray(rate)})))

        def rss(tau_min, design=design):
            full = np.column_stack([design, np.exp(-elapsed_min / tau_min)])
            return np.linalg.lstsq(full, log.drift_deg_h, rcond=None)[1][0]

        assert np.isfinite(scores[window])
        # no better than the truth's time constant, no worse than the grid's best fit
        assert scores[window] <= rss(truth["tau_warmup_min"]) * (1 + 1e-3)
        assert scores[window] >= min(rss(t) for t in np.geomspace(1.0, 600.0, 400)) * (1 - 1e-9)
    assert best == min(scores, key=scores.get)


def test_temperature_change_sign_follows_a_thermal_cycle():
    """+1 warming, -1 cooling, 0 before any change beyond the 0.5 degC dead band, through
    0.05 degC noise; the plain loop's answer on the samples it reads."""
    from gyroid.models import temperature_change_sign

    time_h = np.linspace(0.0, 6.0, 30_001)
    temperature = 20.0 + 8.0 * np.sin(2 * np.pi * time_h / 4.0) ** 2
    noisy = temperature + np.random.default_rng(3).normal(0.0, 0.05, time_h.size)
    sign = temperature_change_sign(noisy)
    rising = np.gradient(temperature) > 0
    settled = (time_h > 0.3) & (np.abs(np.gradient(temperature, time_h)) > 5.0)
    assert np.all(sign[settled] == np.where(rising, 1.0, -1.0)[settled])
    assert sign[0] == 0.0
    every = -(-time_h.size // 20_000)
    np.testing.assert_array_equal(sign[::every], _schmitt_reference(noisy[::every], 0.5))
    assert not np.any(temperature_change_sign(np.full(100, 21.0)))
