"""Pooling runs whose noise is correlated (issues 42 and 43): the white pool's refusal and
its advice, the default's per-run IEEE fits pooled, burst logs with and without segment
means, and a thermal lot whose thermometer is noisy. Apart from tests/test_pool.py so that
the test workers share the pool's slowest tests."""

import json

import numpy as np
import pytest
from helpers import SHORT_MAGNETIC

from gyroid import BenchLog
from gyroid.bench import BenchOptions, fit_log
from gyroid.cli import main
from gyroid.pool import fit_pool


@pytest.mark.slow
def test_correlated_runs_are_refused_with_advice_pool_can_follow():
    """Runs with Gauss-Markov noise: pooled as white noise (``--noise white``), whiteness
    fails and the advice names what works (the command line's hint: --noise auto, the
    default)."""
    from gyroid.cli.report import check_lines
    from gyroid.simulation import GyroNoise, simulate_magnetic_bench

    noise = GyroNoise(arw_deg_rt_h=0.002, bias_instability_deg_h=0.3, correlation_time_s=600)
    logs = [simulate_magnetic_bench(protocol=SHORT_MAGNETIC, noise=noise, seed=s).log
            for s in (1, 2, 3)]
    result = fit_pool(logs, ("a", "b", "c"), "magnetic", BenchOptions(noise="white"), seed=0)
    check = next(c for c in result.checks.checks if c.name == "residual_whiteness")
    assert not check.passed and check.severity == "error"
    assert "noise_model" in check.remedies
    assert any("--noise auto" in line for line in check_lines(result.checks, "pool"))
    assert not result.trustworthy


@pytest.mark.slow
def test_the_advice_followed_pools_each_runs_correlated_noise_fit():
    """The same lot pooled by default (``--noise auto``: each run fitted under IEEE 952
    noise, its posterior pooled): every run's residual checks pass and each run's field
    coefficients' intervals widen over the white pool's (15 s)."""
    from gyroid.simulation import GyroNoise, simulate_magnetic_bench

    noise = GyroNoise(arw_deg_rt_h=0.002, bias_instability_deg_h=0.3, correlation_time_s=600)
    logs = [simulate_magnetic_bench(protocol=SHORT_MAGNETIC, noise=noise, seed=s).log
            for s in (1, 2, 3)]
    result = fit_pool(logs, ("a", "b", "c"), "magnetic", BenchOptions(noise="white"), seed=0)
    followed = fit_pool(logs, ("a", "b", "c"), "magnetic", seed=0)
    for name in ("goodness_of_fit", "residual_whiteness", "predictive"):
        assert next(c for c in followed.checks.checks if c.name == name).passed, name
    assert followed.problem.run_noise == "white+flicker+rw"
    # how far each run's intervals rest on the noise priors is carried into the lot's checks
    carried = next(c for c in followed.checks.checks if c.name == "noise_prior_dependence")
    assert carried.severity == "warning"
    # each run's field coefficients are known less well under its correlated noise (w0's
    # population sd is the runs' spread, 1.57 deg/h under either noise model)
    white, ieee = (r.to_json()["per_run"] for r in (result, followed))
    for run in ("a", "b", "c"):
        for name in ("wx", "wy", "wz"):
            assert ieee[run][name]["sd"] > white[run][name]["sd"], (run, name)


@pytest.mark.slow
def test_burst_logs_pool_on_segment_means(tmp_path):
    """Three MEMS burst logs whose bias wanders between bursts: pooled by default (each
    run under IEEE noise, which carries the wander across the gaps) the population covers
    the truth; pooled on samples as white noise the whiteness check refuses them (the
    wander is invisible within a burst); as white noise with --segment-means every
    error-level check passes and the population covers the truth."""
    from helpers import mems_burst_log, write_log

    paths = []
    for seed in (1, 2, 3):
        columns, truth = mems_burst_log(seed, hours=2.0, wander_deg_h=40.0)
        paths.append(str(write_log(tmp_path / f"unit{seed}.csv", columns)))
    terms = "bias,temperature,temperature_sq"
    assert main(["pool", *paths, "--terms", terms, "--out", str(tmp_path / "auto")]) == 0
    assert main(["pool", *paths, "--terms", terms, "--noise", "white", "--out",
                 str(tmp_path / "samples")]) == 3
    samples = json.loads((tmp_path / "samples" / "pool.json").read_text())
    assert not samples["checks"]["residual_whiteness"]["passed"]
    assert main(["pool", *paths, "--terms", terms, "--noise", "white", "--segment-means",
                 "--out", str(tmp_path / "means")]) == 0
    means = json.loads((tmp_path / "means" / "pool.json").read_text())
    assert means["segment_means"] and means["checks"]["outliers_within_segments"]["passed"]
    for folder in ("auto", "means"):
        record = json.loads((tmp_path / folder / "pool.json").read_text())
        for name, value in truth.items():
            lo, hi = record["population"][name]["ci95"]
            assert lo < value < hi, (folder, name, value, lo, hi)


@pytest.mark.slow
def test_segment_means_reach_each_runs_correlated_noise_fit():
    """Under a correlated noise model each run is fitted on its own, on its bursts' means
    when asked: `--segment-means --noise auto` used to fit the samples and write
    segment_means false, the request dropped without a word."""
    from helpers import mems_burst_log

    logs = [BenchLog(columns=mems_burst_log(seed, hours=1.0, wander_deg_h=40.0)[0])
            for seed in (1, 2)]
    terms = "bias,temperature,temperature_rate"
    result = fit_pool(logs, ("a", "b"), terms,
                      BenchOptions(noise="white+flicker+rw", segment_means=True), seed=0)
    assert result.to_json()["segment_means"] is True
    alone = fit_log(logs[0], terms, BenchOptions(noise="white+flicker+rw", segment_means=True),
                    seed=0, progress=False)
    mean = alone.posterior.draws.reshape(-1, len(alone.posterior.names))[:, :3].mean(axis=0)
    np.testing.assert_allclose(result.problem.own_mean[0], mean, rtol=1e-12)
    # each run is described by its own fit (built once), so the pool reports the dT/dt
    # window and rows that fit used, not those of a white build made beside it
    assert result.rate_window_s[0] == alone.problem.rate_window_s
    assert result.n_samples[0] == alone.problem.n


@pytest.mark.slow
def test_cli_pool_of_thermal_runs_whose_thermometer_is_noisy(tmp_path):
    """A lot of thermal runs with a noisy thermometer pools (exit 0 or 3): each run's fit
    had carried the thermometer's noise, which left it without the sufficient statistics
    the pooled algebra reads, and `gyroid pool --terms thermal` ended in an IndexError
    (the white pool's path, then the default)."""
    lot_dir, pool_dir = tmp_path / "lot", tmp_path / "pool"
    assert main(["simulate", "thermal", "--runs", "3", "--hours", "2", "--out", str(lot_dir),
                 "--seed", "3"]) == 0
    logs = [str(lot_dir / f"run_0{k}" / "bench.csv") for k in (1, 2, 3)]
    code = main(["pool", *logs, "--terms", "thermal", "--noise", "white", "--out",
                 str(pool_dir), "--seed", "1"])
    record = json.loads((pool_dir / "pool.json").read_text())
    assert code == (0 if record["trustworthy"] else 3)
    assert set(record["population"]) == {"w0", "w1", "w2", "wD"}
