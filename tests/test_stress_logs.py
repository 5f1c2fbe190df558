"""Issue 13's failure modes on synthetic stress logs: every fit either recovers the truth
within its intervals or says it must not be used (exit code 3)."""

import json

import numpy as np
import pytest
from helpers import fast_ramp_log, mems_burst_log, weak_field_log, write_log

from gyroid.bench import BenchOptions, fit_log
from gyroid.cli import main
from gyroid.inference import Emcee
from gyroid.io import BenchLog
from gyroid.simulation import GyroNoise, simulate_magnetic_bench

QUICK = Emcee(progress=False)


def _within(result, truth, k=4.0):
    return all(abs(result.posterior.summary[n]["mean"] - v) < k * result.posterior.summary[n]["sd"]
               for n, v in truth.items())


def test_mems_gyro_with_default_priors_is_recovered_and_trusted():
    """Case 1: biases of thousands of deg/h. The default priors scale to the log."""
    columns, truth = mems_burst_log(0)
    result = fit_log(BenchLog(columns), "bias,temperature,temperature_sq",
                     BenchOptions(noise="white"), sampler=QUICK)
    assert result.trustworthy, result.checks.lines()
    assert _within(result, truth)
    assert result.checks.to_json()["checks"]["point_vs_posterior"]["value"] < 0.5


def test_mems_gyro_under_fog_priors_is_refused(tmp_path, capsys):
    """Case 1 as it was: paper A's FOG priors on a MEMS log must not give exit 0."""
    columns, _ = mems_burst_log(0)
    path = write_log(tmp_path / "mems.csv", columns)
    code = main(["fit", str(path), "--terms", "bias,temperature,temperature_sq", "--out",
                 str(tmp_path / "fit"), "--priors", "paper_a_fog", "--no-progress",
                 "--noise", "white"])
    assert code == 3
    err = capsys.readouterr().err
    assert "prior_data_conflict" in err and "NOT TRUSTWORTHY" in err
    fit = json.loads((tmp_path / "fit" / "fit.json").read_text())
    assert fit["trustworthy"] is False and fit["prior_set"] == "paper_a_fog"
    assert fit["checks"]["prior_data_conflict"]["passed"] is False


@pytest.mark.slow
def test_fast_ramps_are_recovered_or_refused():
    """Case 2: 15-minute ramps. The fixed 1200 s window smears every kink: the checks must
    refuse that fit; the automatic window must recover the truth or refuse too."""
    columns, truth = fast_ramp_log(1)
    fixed = fit_log(BenchLog(columns), "thermal", BenchOptions(noise="white", rate_window_s=1200.0),
                    sampler=QUICK)
    assert not fixed.trustworthy
    assert not fixed.checks.to_json()["checks"]["goodness_of_fit"]["passed"]
    auto = fit_log(BenchLog(columns), "thermal", BenchOptions(noise="white"), sampler=QUICK)
    assert auto.problem.rate_window_s < 1200.0
    assert (auto.trustworthy and _within(auto, truth)) or not auto.trustworthy


@pytest.mark.slow
def test_white_noise_model_on_correlated_noise_is_refused():
    """Case 3: --noise white on Gauss-Markov noise: the intervals would be far too narrow."""
    sim = simulate_magnetic_bench(seed=4, noise=GyroNoise(bias_instability_deg_h=0.1,
                                                          correlation_time_s=300.0))
    white = fit_log(sim.log, "magnetic", BenchOptions(noise="white"), sample=False)
    check = white.checks.to_json()["checks"]["residual_whiteness"]
    assert not white.trustworthy and not check["passed"] and check["severity"] == "error"
    gm = fit_log(sim.log, "magnetic", BenchOptions(noise="white+gm"), sample=False)
    assert gm.checks.to_json()["checks"]["residual_whiteness"]["severity"] == "warning"
    assert gm.trustworthy


@pytest.mark.slow
def test_magnetic_terms_on_a_weak_field_are_not_identified():
    """Case 4: a field that varied by +/-2 uT cannot identify the magnetic coefficients."""
    columns, _ = weak_field_log(2, hours=1.5)
    result = fit_log(BenchLog(columns), "magnetic", BenchOptions(noise="white+gm"), sampler=QUICK)
    check = result.checks.to_json()["checks"]["identifiability"]
    assert not check["passed"] and check["severity"] == "error", check
    assert "Hx_uT varies more" in check["message"] or "Hy_uT" in check["message"]
    assert not result.trustworthy


@pytest.mark.parametrize("fmt", ["csv", "csv.gz", "parquet"])
def test_formats_read_alike(tmp_path, fmt):
    from gyroid.io import load_bench_log

    columns, _ = mems_burst_log(3, hours=0.5)
    path = write_log(tmp_path / "log.csv", columns)
    if fmt == "csv.gz":
        import gzip

        target = tmp_path / "log.csv.gz"
        target.write_bytes(gzip.compress(path.read_bytes()))
    elif fmt == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        target = tmp_path / "log.parquet"
        pq.write_table(pa.table(columns), target)
    else:
        target = path
    log = load_bench_log(target, "bias,temperature")
    np.testing.assert_allclose(log.drift_deg_h, columns["drift_deg_h"], rtol=1e-9)


def test_held_out_compensation_matches_plain_least_squares(tmp_path):
    """Done-means of issue 13 on the MEMS stress log: fit on every other burst, compensate
    the bursts in between. gyroid's defaults are within 15 % of a plain NumPy least-squares
    fit of the same terms, and better than removing a constant."""
    from gyroid.workflows import compensate

    columns, _ = mems_burst_log(5)
    burst = (columns["time_s"] // 300.0).astype(int)
    train = {k: v[burst % 2 == 0] for k, v in columns.items()}
    test = {k: v[burst % 2 == 1] for k, v in columns.items()}
    terms = "bias,temperature,temperature_sq"
    result = fit_log(BenchLog(train), terms, BenchOptions(noise="white"), sampler=QUICK)
    assert result.trustworthy
    comp = compensate(BenchLog(test), result.fitted_drift())
    t = train["temperature_C"] - 21.0
    design = np.column_stack([np.ones_like(t), t, t**2])
    beta = np.linalg.lstsq(design, train["drift_deg_h"], rcond=None)[0]
    t_test = test["temperature_C"] - 21.0
    plain = test["drift_deg_h"] - np.column_stack([np.ones_like(t_test), t_test, t_test**2]) @ beta
    rms_gyroid = np.sqrt(np.mean(comp.compensated_deg_h**2))
    rms_plain = np.sqrt(np.mean(plain**2))
    assert rms_gyroid <= 1.15 * rms_plain
    assert rms_gyroid < np.std(test["drift_deg_h"])
    assert comp.checks.trustworthy, comp.checks.lines()


@pytest.mark.slow
def test_bias_wander_between_bursts_is_refused_per_sample_and_covered_by_segment_means():
    """Bursts whose bias wanders (30 deg/h per burst against 200 / sqrt(250) = 12.6 for a
    burst's white noise): the per-sample white fit must not pass; the fit of the 36 burst
    means is trusted and its 95 % intervals cover the truth: 30 intervals over 10 seeds,
    at least 25 (a binomial tail of 0.2 % at the nominal 95 %)."""
    columns, truth = mems_burst_log(0, wander_deg_h=30.0)
    per_sample = fit_log(BenchLog(columns), "bias,temperature,temperature_sq",
                         BenchOptions(noise="white"), sampler=QUICK)
    assert not per_sample.trustworthy
    from gyroid.cli.report import check_lines

    assert "--segment-means" in check_lines(per_sample.checks, "fit")[0]
    covered = 0
    for seed in range(10):
        columns, truth = mems_burst_log(seed, wander_deg_h=30.0)
        result = fit_log(BenchLog(columns), "bias,temperature,temperature_sq",
                         BenchOptions(noise="white", segment_means=True), seed=seed, sampler=QUICK)
        assert result.trustworthy, result.checks.lines()
        assert result.segment_means == {"segments": 36, "rows": 9000}
        for name, value in truth.items():
            lo, hi = result.posterior.summary[name]["ci95"]
            covered += lo <= value <= hi
    assert covered >= 25
