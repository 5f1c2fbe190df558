"""How far a fit's intervals rest on its noise levels' priors (``noise_prior_dependence``):
with the levels pinned by narrow priors the allowed region is a point and each
coefficient's sd there is its posterior sd; with the default weak priors on a 10 h log
whose flicker and walk sit where the log cannot resolve them, the check warns, the
coefficients' range over the allowed levels holds the posterior's own interval, and the
widest sd is the posterior sd of a fit pinned at the levels where it was found."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from gyroid.bench import BenchOptions, fit_log
from gyroid.io import BenchLog
from gyroid.models import LogNormal

HOURS, ARW, B, K = 10.0, 0.005, 0.01, 0.005  # h, deg/sqrt(h), deg/h, deg/h/sqrt(h)
TRUTH = {"w0": 1.2, "w1": -0.1, "w2": 0.004}


def _fog_log(seed: int) -> BenchLog:
    """A FOG at 1 Hz through one +-20 degC sine over 10 h: white noise, a Gauss-Markov
    bump of B's size standing in for flicker (correlation time 1 h) and a rate random walk
    (written here, not with gyroid's simulator)."""
    rng = np.random.default_rng(seed)
    n = int(HOURS * 3600)
    time_s = np.arange(n, dtype=float)
    t = 20.0 * np.sin(2.0 * math.pi * time_s / (HOURS * 3600))
    phi = math.exp(-1.0 / 3600.0)
    bump = signal.lfilter([1.0], [1.0, -phi], rng.normal(0.0, B * math.sqrt(1.0 - phi**2), n))
    walk = np.cumsum(rng.normal(0.0, K / 60.0, n))
    drift = (TRUTH["w0"] + TRUTH["w1"] * t + TRUTH["w2"] * t**2
             + rng.normal(0.0, 60.0 * ARW, n) + bump + walk - walk.mean())
    return BenchLog({"time_s": time_s, "drift_deg_h": drift, "temperature_C": 21.0 + t})


@pytest.mark.slow
def test_pinned_levels_leave_the_posterior_sd_and_weak_priors_warn():
    log = _fog_log(3)
    pinned = {"N_deg_sqrt_h": LogNormal(ARW, 0.01), "B_deg_h": LogNormal(B, 0.01),
              "K_deg_h_sqrt_h": LogNormal(K, 0.01)}
    fixed = fit_log(log, "bias,temperature,temperature_sq", BenchOptions(priors=pinned), seed=1)
    checks = {c.name: c for c in fixed.checks.checks}
    assert checks["noise_prior_dependence"].passed
    # a posterior sd from >= 400 effective draws has a relative standard error under 4 %;
    # the union over a region of levels a hundredth wide moves the sd by ~1 % more
    for name, factor in fixed.allowed_noise.widening.items():
        assert factor == pytest.approx(1.0, abs=0.12), name
    default = fit_log(log, "bias,temperature,temperature_sq", seed=1)
    checks = {c.name: c for c in default.checks.checks}
    allowed = default.allowed_noise
    assert not checks["noise_prior_dependence"].passed, allowed.widening
    assert "noise_prior_dependence" in default.to_json()["checks"]
    assert default.to_json()["over_allowed_noise"]["sd_widening"] == allowed.widening
    for name in TRUTH:
        low, high = allowed.ranges[name]
        ci = default.posterior.summary[name]["ci95"]
        spread = default.posterior.summary[name]["sd"]
        # the range holds the posterior's interval (a mixture's quantiles lie within its
        # parts'), up to the Monte Carlo error of the posterior's quantiles
        assert low <= ci[0] + 0.1 * spread and high >= ci[1] - 0.1 * spread, name
    # the widest sd, found from the filter's precision factors, is the posterior sd of a fit
    # pinned at those levels (drawn, not computed)
    name = allowed.widest[0]
    at = {level: LogNormal(value, 0.01) for level, value in allowed.at[name].items()}
    there = fit_log(log, "bias,temperature,temperature_sq", BenchOptions(priors=at), seed=2)
    assert there.posterior.summary[name]["sd"] == pytest.approx(
        allowed.widening[name] * default.posterior.summary[name]["sd"], rel=0.12)


def test_a_white_fit_is_weighed_by_the_same_check():
    """Under white noise the rows pin the one level: the check runs (the same code as for
    correlated noise, on the sufficient statistics' marginal), passes, and each
    coefficient's sd over the allowed levels is its posterior sd, its range holding the
    posterior's interval."""
    rng = np.random.default_rng(5)
    n = 4000
    t = 20.0 * np.sin(2.0 * math.pi * np.arange(n) / n)
    drift = TRUTH["w0"] + TRUTH["w1"] * t + TRUTH["w2"] * t**2 + rng.normal(0.0, 0.3, n)
    log = BenchLog({"time_s": np.arange(n, dtype=float), "drift_deg_h": drift,
                    "temperature_C": 21.0 + t})
    result = fit_log(log, "bias,temperature,temperature_sq", BenchOptions(noise="white"), seed=1,
                     progress=False)
    check = next(c for c in result.checks.checks if c.name == "noise_prior_dependence")
    assert check.passed and "do not rest" in check.message
    allowed = result.allowed_noise
    # sigma from 4000 rows has a relative sd of 1 %: the region's sds within ~3 % of the
    # posterior's, which has its own Monte Carlo error of a few %
    for name in TRUTH:
        assert allowed.widening[name] == pytest.approx(1.0, abs=0.08), name
        low, high = allowed.ranges[name]
        ci = result.posterior.summary[name]["ci95"]
        spread = result.posterior.summary[name]["sd"]
        assert low <= ci[0] + 0.1 * spread and high >= ci[1] - 0.1 * spread, name


@pytest.mark.parametrize(("factor", "passed", "severity"), [
    (1.5, True, "warning"), (2.0, False, "warning"), (10.0, False, "warning"),
    (10.5, False, "error"), (695.0, False, "error")])
def test_an_interval_that_could_be_ten_times_wider_is_not_trustworthy(factor, passed, severity):
    """Contract section 7, trust by range: a warning from 2x, and beyond 10x for some
    coefficient an error (exit 3): the interval is then the priors' answer."""
    from gyroid.bench._allowed_noise import AllowedNoise
    from gyroid.inference._check_report import CheckReport

    allowed = AllowedNoise(upper={"B_deg_h": 0.1}, ranges={"w0": (-6.1, 8.3), "w1": (0.0, 1.0)},
                           widening={"w0": factor, "w1": 1.0},
                           at={"w0": {"B_deg_h": 0.1}, "w1": {"B_deg_h": 0.01}},
                           evaluated=2000, allowed=100, units={"B_deg_h": "deg/h"})
    check = allowed.check()
    assert (check.passed, check.severity) == (passed, severity)
    assert CheckReport((check,)).trustworthy == (severity == "warning")
    assert ("not an answer" in check.message) == (severity == "error")
    assert ("do not rest" in check.message) == passed
    assert "w0's sd" in check.message and "[-6.1, 8.3]" in check.message


@pytest.mark.parametrize(("own", "other", "said"), [
    (120, 900, "which fits this log as well"), (0, 900, "which fits this log better")])
def test_a_range_over_the_default_noise_model_says_the_choice_is_what_it_rests_on(
        own, other, said):
    """A white+gm fit whose coefficient widens most under the default noise model (white +
    flicker + rate random walk, which the log does not rule out) says that its intervals
    rest on the choice of white+gm, with the range over both models; a default the log
    rules out is named as such in a passing check."""
    from gyroid.bench._allowed_noise import AllowedNoise, OtherNoise

    levels = {"N_deg_sqrt_h": 0.4, "B_deg_h": 5.9, "K_deg_h_sqrt_h": 14.0}
    allowed = AllowedNoise(upper=levels, ranges={"w0": (11.0, 84.4), "w1": (2.3, 8.5)},
                           widening={"w0": 4.2, "w1": 2.8}, at={"w0": levels, "w1": levels},
                           evaluated=3000, allowed=own + other,
                           units={"N_deg_sqrt_h": "deg/sqrt(h)", "B_deg_h": "deg/h",
                                  "K_deg_h_sqrt_h": "deg/h/sqrt(h)"},
                           model="white+gm", under_other=frozenset({"w0", "w1"}),
                           other=OtherNoise("white+flicker+rw", 4.9, other))
    check = allowed.check()
    assert not check.passed and check.severity == "warning"
    assert said in check.message and "(+4.9 nats of log-likelihood)" in check.message
    assert check.message.startswith("the intervals rest on the choice of white+gm over "
                                    "white+flicker+rw, which fits this log ")
    assert check.remedies == ("noise_model",)  # the console's hint: --noise auto
    assert "B_deg_h = 5.9 deg/h" in check.message and "[11, 84.4]" in check.message
    assert allowed.to_json()["other_noise_model"] == {
        "model": "white+flicker+rw", "log_likelihood_gain": 4.9, "levels_allowed": other,
        "widest_under_it": ["w0", "w1"]}
    ruled_out = AllowedNoise(upper={}, ranges={"w0": (0.9, 1.1)}, widening={"w0": 1.2},
                             at={"w0": {"sigma_gm_deg_h": 0.1}}, evaluated=3000, allowed=400,
                             model="white+gm", other=OtherNoise("white+flicker+rw", -6.4, 0))
    check = ruled_out.check()
    assert check.passed and "fits this log worse (-6.4 nats" in check.message
    assert "is ruled out" in check.message


def _walk_log(seed: int) -> BenchLog:
    """A MEMS-grade gyro at 1 Hz through one +-20 degC sine over 10 h: white noise (18
    deg/h a sample) and a rate random walk of 10 deg/h/sqrt(h), nothing a single
    Gauss-Markov bias carries beyond its correlation time (written here, not with gyroid's
    simulator)."""
    rng = np.random.default_rng(seed)
    n = int(HOURS * 3600)
    time_s = np.arange(n, dtype=float)
    t = 20.0 * np.sin(2.0 * math.pi * time_s / n)
    walk = np.cumsum(rng.normal(0.0, 10.0 / 60.0, n))
    drift = (50.0 + 3.0 * t + 0.05 * t**2 + rng.normal(0.0, 18.0, n) + walk - walk.mean())
    return BenchLog({"time_s": time_s, "drift_deg_h": drift, "temperature_C": 21.0 + t})


@pytest.mark.slow
def test_a_white_gm_fit_of_a_walk_spans_the_default_noise_model():
    """Under white+gm a walk reads as a bump of some correlation time and the log cannot
    tell the two apart (the default fits it within the likelihood region's drop): the
    check explores the default's levels on the same rows, fails, and its range over both
    models holds every truth where the posterior's interval does not (w1 3.6 sd from its
    truth on this seed)."""
    truth = {"w0": 50.0, "w1": 3.0, "w2": 0.05}
    fit = fit_log(_walk_log(3), "bias,temperature,temperature_sq", BenchOptions(noise="white+gm"),
                  seed=1, progress=False)
    allowed = fit.allowed_noise
    check = next(c for c in fit.checks.checks if c.name == "noise_prior_dependence")
    assert allowed.other is not None and allowed.other.model == "white+flicker+rw"
    assert allowed.other.allowed > 0 and allowed.own_allowed > 0
    # the widest may be at the default's levels or at a white+gm correlation time as long
    # as the log (a bump standing in for the walk): either way the check fails
    assert not check.passed
    assert ("rest on the choice of white+gm" in check.message) == (
        allowed.widest[0] in allowed.under_other)
    summary = fit.posterior.summary
    missed = [n for n, v in truth.items() if not
              summary[n]["ci95"][0] <= v <= summary[n]["ci95"][1]]
    assert missed, "the posterior's own intervals hold every truth on this seed"
    for name, value in truth.items():
        low, high = allowed.ranges[name]
        assert low <= value <= high, name
    assert fit.to_json()["over_allowed_noise"]["other_noise_model"]["model"] == (
        "white+flicker+rw")
