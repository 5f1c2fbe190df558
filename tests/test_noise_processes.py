"""gyroid noise beyond IEEE Std 952's five terms (issue 42): a Gauss-Markov bump, a
prefilter, outliers and heavy tails, misfits over adjacent averaging times, and the unit
behind several runs; against logs simulated here, independently of gyroid's model."""

import json
import math

import numpy as np
import pytest
from helpers import write_log
from scipy.signal import lfilter

from gyroid.allan import fit_noise, fit_unit_noise
from gyroid.allan._haar import HaarStatistics
from gyroid.allan._levels import level_fit, level_runs
from gyroid.cli import main
from gyroid.noise._allan_terms import gauss_markov_avar


def _white(rng, n: int, dt: float, arw: float) -> np.ndarray:
    """White rate noise of angle random walk ``arw`` (deg/sqrt(h)), deg/h."""
    return rng.normal(0.0, 60.0 * arw / math.sqrt(dt), n)


def _gauss_markov(rng, n: int, dt: float, sigma: float, tc_s: float) -> np.ndarray:
    """A stationary first-order Gauss-Markov process of sd ``sigma`` (deg/h)."""
    phi = math.exp(-dt / tc_s)
    drive = rng.normal(0.0, sigma * math.sqrt(1.0 - phi**2), n)
    drive[0] = rng.normal(0.0, sigma)
    return lfilter([1.0], [1.0, -phi], drive)


@pytest.mark.parametrize("tc_over_tau0", [0.7, 5.0, 300.0])
def test_the_gauss_markov_shape_is_the_exact_allan_variance_of_its_samples(tc_over_tau0):
    """Against the block means' covariance written out: ``AVAR = d^T C d / 2`` with ``C_ij =
    phi^|i - j|`` over two adjacent blocks of m samples and ``d`` their mean difference."""
    tau0 = 0.01
    phi = math.exp(-1.0 / tc_over_tau0)
    for m in (1, 2, 3, 8, 32):
        i = np.arange(2 * m)
        cov = phi ** np.abs(i[:, None] - i[None, :])
        d = np.concatenate([-np.ones(m), np.ones(m)]) / m
        exact = 0.5 * d @ cov @ d
        shape = gauss_markov_avar(np.array([m * tau0]), tau0, tc_over_tau0 * tau0)[0]
        assert shape == pytest.approx(exact, rel=1e-10)


def test_a_gauss_markov_bump_is_named_and_not_read_as_flicker():
    """White noise and a Gauss-Markov bias (as the MTi-G run of smac_imudata has, whose
    bump at 5-20 s the IEEE terms read as B = 44 deg/h where its Allan deviation at 1000 s
    is under 9): G is resolved with its sd and correlation time, B is not, and N holds."""
    rng = np.random.default_rng(4)
    dt, n, arw, sigma, tc = 0.01, 360_000, 0.5, 20.0, 5.0
    rate = _white(rng, n, dt, arw) + _gauss_markov(rng, n, dt, sigma, tc)
    fit = fit_noise(rate, dt)
    assert fit.trustworthy, fit.summary()
    gm = fit.gauss_markov()
    assert gm["resolved"] and gm["ci90"][0] < sigma < gm["ci90"][1]
    assert tc / 2.0 < gm["tau_s"] < tc * 2.0
    terms = fit.term_summaries()
    assert not terms["B"]["resolved"]
    assert terms["N"]["ci90"][0] < arw < terms["N"]["ci90"][1]


def test_a_few_spikes_are_named_by_row_and_kept_out_of_the_terms():
    rng = np.random.default_rng(5)
    dt, n, arw = 0.01, 200_000, 0.5
    rate = _white(rng, n, dt, arw)
    sd = 60.0 * arw / math.sqrt(dt)
    rows = [1_000, 50_000, 123_456]
    rate[rows] += np.array([40.0, -60.0, 80.0]) * sd
    fit = fit_noise(rate, dt)
    check = {c.name: c for c in fit.checks.checks}["outliers"]
    assert not check.passed and check.severity == "warning" and fit.trustworthy
    assert all(f"row {r + 1}" in check.message for r in rows)
    low, high = fit.term_summaries()["N"]["ci90"]
    assert low < arw < high
    # kept, the three spikes alone would lift N by 3 %, beyond that interval
    assert math.sqrt(np.var(rate) * dt) / 60.0 > high


@pytest.mark.slow
def test_heavy_tails_are_refused_and_gaussian_noise_flags_nothing():
    rng = np.random.default_rng(6)
    dt, n = 0.01, 100_000
    tails = fit_noise(rng.standard_t(3, n) * 300.0, dt)
    check = {c.name: c for c in tails.checks.checks}["outliers"]
    assert check.severity == "error" and not check.passed and not tails.trustworthy
    gaussian = fit_noise(rng.normal(0.0, 300.0, n), dt)
    assert {c.name: c for c in gaussian.checks.checks}["outliers"].passed


def _levels(factor: np.ndarray) -> tuple[HaarStatistics, np.ndarray]:
    """Haar statistics whose Allan variance is ``factor`` times a model's, level by level."""
    m = 2.0 ** np.arange(12)
    count = np.floor(1e6 / (2 * m))
    model = 3600.0 / (m * 0.01)
    avar = model * factor
    return HaarStatistics(m, count, 2.0 * count * avar, 0.01, 1_000_000, 1), model


def test_adjacent_levels_that_misfit_together_fail_where_each_passes_alone():
    """Four adjacent levels, each about 2.8 sd above the model (p ~ 0.005, not significant
    after Bonferroni over twelve), are together 5.6 sd above it."""
    m = 2.0 ** np.arange(12)
    count = np.floor(1e6 / (2 * m))
    factor = np.ones(12)
    factor[6:10] = 1.0 + 2.8 * np.sqrt(2.0 / count[6:10])
    stats, model = _levels(factor)
    assert level_fit(stats, model).passed
    runs = level_runs(stats, model)
    assert not runs.passed and runs.severity == "warning"  # significant, not large
    assert "0.64 to 5.12 s" in runs.message
    exact, model = _levels(np.ones(12))
    assert level_runs(exact, model).passed and level_fit(exact, model).passed


def _unit_runs(seed: int, runs: int, spread: float):
    """Runs of one unit whose N differs from run to run by a factor ``exp(spread)`` at one
    sd (a temperature, a supply), each run white noise with some flicker-free bias wander."""
    rng = np.random.default_rng(seed)
    dt, n = 0.01, 200_000
    arw = 0.5 * np.exp(spread * rng.standard_normal(runs))
    return [_white(rng, n, dt, a) for a in arw], arw, dt


@pytest.mark.slow
def test_the_unit_interval_holds_runs_that_differ_more_than_their_own_intervals():
    rates, arw, dt = _unit_runs(7, 6, 0.05)
    fits = [fit_noise(r, dt) for r in rates]
    labels = [f"run{k}" for k in range(6)]
    unit = fit_unit_noise(fits, labels)
    n = unit.terms["N"]
    assert unit.trustworthy and n.runs_inside == 6
    lo, hi = n.new_run_ci90
    assert lo < min(arw) and max(arw) < hi
    assert n.unit_ci90[0] < 0.5 < n.unit_ci90[1]
    # a run's own interval describes that run: most exclude some other run
    outside = sum(any(not (a <= m <= b) for m in n.run_median)
                  for a, b in n.run_ci90)
    assert outside >= 4 and n.homogeneity_p < 1e-3


@pytest.mark.slow
def test_noise_of_several_runs_writes_each_run_and_the_unit(tmp_path, capsys):
    rates, _, dt = _unit_runs(8, 3, 0.03)
    paths = []
    for k, rate in enumerate(rates):
        paths.append(write_log(tmp_path / f"run{k}.csv",
                               {"time_s": dt * np.arange(rate.size), "drift_deg_h": rate}))
    out = tmp_path / "out"
    code = main(["noise", *map(str, paths), "--out", str(out)])
    assert code == 0
    unit = json.loads((out / "unit" / "unit.json").read_text())
    assert unit["runs"] == ["run0", "run1", "run2"] and unit["trustworthy"]
    assert set(unit["terms"]["N"]["runs"]) == {"run0", "run1", "run2"}
    assert (out / "unit" / "unit.png").exists() and (out / "run1" / "noise.json").exists()
    assert "noise of the unit behind 3 runs" in capsys.readouterr().out
