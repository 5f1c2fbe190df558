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

from gyroid.inference import fit_log
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
    fixed = fit_log(log, "bias,temperature,temperature_sq", seed=1, priors=pinned)
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
    there = fit_log(log, "bias,temperature,temperature_sq", seed=2, priors=at)
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
    result = fit_log(log, "bias,temperature,temperature_sq", noise="white", seed=1,
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
    from gyroid.inference._allowed_noise import AllowedNoise
    from gyroid.inference._check_report import CheckReport

    allowed = AllowedNoise(upper={"B_deg_h": 0.1}, ranges={"w0": (-6.1, 8.3), "w1": (0.0, 1.0)},
                           widening={"w0": factor, "w1": 1.0},
                           at={"w0": {"B_deg_h": 0.1}, "w1": {"B_deg_h": 0.01}},
                           evaluated=2000, allowed=100)
    check = allowed.check({"B_deg_h": "deg/h"})
    assert (check.passed, check.severity) == (passed, severity)
    assert CheckReport((check,)).trustworthy == (severity == "warning")
    assert ("not an answer" in check.message) == (severity == "error")
    assert ("do not rest" in check.message) == passed
    assert "w0's sd" in check.message and "[-6.1, 8.3]" in check.message
