"""Under correlated noise the dT/dt window is chosen by the fit's own (collapsed marginal)
likelihood, not by least squares: on a bench whose transitions are raised cosines the
least-squares window smears dT/dt over their ends. There the thermometer's noise through
dT/dt, left out of the filter, is taken in as a random walk hundreds of times its truth."""

import math

import numpy as np
import pytest

from gyroid import BenchLog
from gyroid.bench import BenchOptions, BenchProblem
from gyroid.bench._rate_window import choose_rate_window
from gyroid.bench._rate_window_marginal import marginal_window

WALK = 0.005  # deg/h/sqrt(h)


def _raised_cosine_bench(seed: int) -> BenchLog:
    """10 h at 1 Hz: plateaus at 21, 41, 1 and 21 degC joined by 1 h raised cosines;
    paper A's thermal coefficients on the true temperature and rate; white noise
    0.005 deg/sqrt(h), a rate random walk, a 0.01 degC thermometer (written here, not by
    gyroid's simulator)."""
    rng = np.random.default_rng(seed)
    time_s = np.arange(36_000.0)
    hours = time_s / 3600.0
    temperature, rate = np.full_like(hours, 21.0), np.zeros_like(hours)
    for start, step in ((1.5, 20.0), (4.5, -40.0), (7.5, 20.0)):
        s = np.clip(hours - start, 0.0, 1.0)
        temperature += step * 0.5 * (1.0 - np.cos(math.pi * s))
        rate += np.where((s > 0) & (s < 1), step * 0.5 * math.pi * np.sin(math.pi * s), 0.0)
    t = temperature - 21.0
    drift = (1.197 - 0.108 * t + 0.004 * t**2 + 1.997 * rate
             + rng.normal(0.0, 0.3, time_s.size)
             + np.cumsum(rng.normal(0.0, WALK / 60.0, time_s.size)))
    return BenchLog(columns={"time_s": time_s, "drift_deg_h": drift,
                             "temperature_C": temperature + rng.normal(0.0, 0.01, time_s.size)})


@pytest.fixture(scope="module")
def bench():
    return _raised_cosine_bench(0)


@pytest.mark.slow
def test_the_window_under_ieee_noise_is_the_marginal_likelihoods(bench):
    """The chosen window is shorter than least squares' and its marginal is far higher;
    the walk's mode is within a few times its truth at both windows (the thermometer's
    noise carried by the filter)."""
    chosen = BenchProblem.from_log(bench, "thermal",
                                   BenchOptions(noise="white+flicker+rw", rate_window_s=None))
    least_squares, _ = choose_rate_window(chosen.log, chosen.model, t0_C=chosen.t0_C,
                                          thermometer_var_C2=chosen.thermometer_sd_C**2)
    assert chosen.rate_window_choice.startswith("auto: the marginal likelihood's of")
    assert f"(least squares' {least_squares:.0f} s)" in chosen.rate_window_choice
    assert chosen.rate_window_s < 0.8 * least_squares
    smeared = BenchProblem.from_log(bench, "thermal",
                                    BenchOptions(noise="white+flicker+rw",
                                                 rate_window_s=least_squares))
    _, scores, _ = marginal_window(
        lambda w: BenchProblem.from_log(bench, "thermal", BenchOptions(
            noise="white+flicker+rw", rate_window_s=w)).density, least_squares,
        float(np.median(np.diff(np.asarray(smeared.log.time_s)))))
    assert scores[float(chosen.rate_window_s)] > scores[least_squares] + 50.0
    for problem in (chosen, smeared):
        assert problem.mode().value["K_deg_h_sqrt_h"] < 5.0 * WALK


@pytest.mark.slow
def test_without_the_thermometers_noise_the_walk_takes_it_in(bench):
    """Left out of the filter, the dT/dt estimator's error from the thermometer's noise
    (correlated over the window, above the white noise of a block mean here) is taken in
    as a random walk tens of times its truth, and the coefficients' intervals widen."""
    carried = BenchProblem.from_log(bench, "thermal",
                                    BenchOptions(noise="white+flicker+rw", rate_window_s=864.0))
    left_out = BenchProblem.from_log(bench, "thermal",
                                     BenchOptions(noise="white+flicker+rw", rate_window_s=864.0,
                                                  errors_in_variables=False))
    assert carried.density.noise.carried is not None
    assert left_out.density.noise.carried is None
    with_it, without = carried.mode(), left_out.mode()
    assert without.value["K_deg_h_sqrt_h"] > 30.0 * WALK
    assert with_it.value["K_deg_h_sqrt_h"] < 5.0 * WALK
    assert with_it.sd["w1"] < 0.5 * without.sd["w1"]


def test_a_white_fit_keeps_least_squares_window(bench):
    """Under white noise the least-squares window stands, the thermometer's noise carried
    (its marginal likelihood chose 1528-2157 s on paper A's bench: nothing absorbs the
    smearing of dT/dt there)."""
    white = BenchProblem.from_log(bench, "thermal", BenchOptions(noise="white", rate_window_s=None))
    assert white.thermometer_sd_C > 0 and white.noise.carried is not None
    assert white.rate_window_choice == "auto"


@pytest.mark.slow
def test_a_model_with_a_time_constant_carries_the_thermometer_and_chooses_the_same_way(
        bench):
    """A warm-up beside the thermal terms: the thermometer's noise is carried through
    dT/dt, scaled by the wD of the start grid's best least squares (it had been carried for
    linear models only: a nonlinear model's design could not be built), and the window is
    the marginal likelihood's as for the linear model, the warm-up's time constant held at
    that best point."""
    columns = dict(bench.columns)
    time_s = columns["time_s"]
    columns["drift_deg_h"] = columns["drift_deg_h"] + 0.5 * np.exp(-time_s / 1800.0)
    log = BenchLog(columns=columns)
    linear = BenchProblem.from_log(log, "thermal",
                                   BenchOptions(noise="white+flicker+rw", rate_window_s=None))
    warm = BenchProblem.from_log(log, "thermal,warmup",
                                 BenchOptions(noise="white+flicker+rw", rate_window_s=None))
    assert warm.thermometer_sd_C == pytest.approx(linear.thermometer_sd_C)
    assert warm.thermometer_sd_C == pytest.approx(0.01, rel=0.1)
    assert warm.rate_error_wd == pytest.approx(1.997, abs=0.05)
    assert warm.rate_window_choice.startswith("auto: the marginal likelihood's of")
