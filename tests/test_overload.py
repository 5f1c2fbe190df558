"""Overload effects (paper A eq. 1; contract section 6): the accelerometer's columns, the
six-position tumble's recovery and calibration, and what too few orientations leave
undetermined (said, and carried into predictions as the prior's uncertainty)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from gyroid.bench import BenchOptions, fit_log
from gyroid.inference import Emcee
from gyroid.io import parse_column_maps
from gyroid.io._bench_reader import load_bench_log
from gyroid.models._drift import DriftModel
from gyroid.models._orientations import orientations, unresolved
from gyroid.simulation import OVERLOAD_TRUTH, GyroNoise, OverloadProtocol, simulate_overload_bench

QUICK = Emcee(progress=False)
SHORT = OverloadProtocol(dwell_min=10.0)


def test_six_position_tumble_recovers_the_sensitivities():
    sim = simulate_overload_bench(seed=3, protocol=SHORT)
    result = fit_log(sim.log, "overload", BenchOptions(noise="white"), seed=1, sampler=QUICK)
    assert result.trustworthy, result.summary()
    for name, value in OVERLOAD_TRUTH.items():
        summary = result.posterior.summary[name]
        assert abs(summary["mean"] - value) < 3.5 * summary["sd"], (name, summary, value)
    # three levels of 10 minutes each way at 0.3 deg/h white noise: sd ~ 0.3 / sqrt(1200)
    assert result.posterior.summary["nx"]["sd"] == pytest.approx(0.3 / np.sqrt(1200), rel=0.2)


def test_three_orientations_say_what_they_leave_undetermined_and_predict_with_the_prior():
    protocol = OverloadProtocol(orientations=("+X", "+Y", "+Z"), dwell_min=10.0)
    sim = simulate_overload_bench(seed=4, protocol=protocol)
    inputs = sim.log.inputs()
    model = DriftModel.from_terms("overload")
    assert len(orientations(inputs)) == 3
    note = unresolved(model, inputs)
    assert "w0 - nx - ny - nz undetermined" in note and "-X" in note
    result = fit_log(sim.log, "overload", BenchOptions(noise="white"), seed=1, sampler=QUICK)
    assert not result.trustworthy
    identifiability = next(c for c in result.checks.checks if c.name == "identifiability")
    assert not identifiability.passed and "w0 - nx - ny - nz" in identifiability.message
    draws = np.asarray(result.posterior.draws).reshape(-1, result.posterior.draws.shape[-1])
    names = list(result.posterior.names)
    w0, nx, ny = (draws[:, names.index(n)] for n in ("w0", "nx", "ny"))
    seen = np.std(w0 + nx)  # +X, where the log dwelt
    unseen = np.std(w0 - nx)  # -X, never seen: the prior's width, not the data's
    assert seen < 0.02 and unseen > 100 * seen
    assert np.std(w0 + ny) < 0.02


def test_orientations_ignore_turns_and_the_accelerometer_noise():
    protocol = OverloadProtocol(dwell_min=5.0)
    sim = simulate_overload_bench(seed=5, protocol=protocol,
                                  noise=GyroNoise(accel_noise_g=0.02))
    found = orientations(sim.log.inputs())
    assert found.shape == (6, 3)
    assert np.allclose(np.abs(found).max(axis=1), 1.0, atol=0.02)
    assert unresolved(DriftModel.from_terms("overload"), sim.log.inputs()) is None
    # one square is pinned (its axis's pair against the others); all three are not: at 1 g
    # ax^2 + ay^2 + az^2 = 1, the bias's regressor
    assert unresolved(DriftModel.from_terms("overload,overload_sq_x"), sim.log.inputs()) is None
    note = unresolved(DriftModel.from_terms("overload,overload_sq_x,overload_sq_y,overload_sq_z"),
                      sim.log.inputs())
    assert note is not None and "w0 - nxx - nyy - nzz undetermined" in note


def test_accelerometer_columns_are_read_in_any_unit(tmp_path):
    sim = simulate_overload_bench(seed=6, protocol=OverloadProtocol(dwell_min=1.0))
    columns = sim.log.columns
    lines = ["t,w,acc_x,acc_y,acc_z"] + [
        f"{t},{w},{ax * 9.80665},{ay * 9.80665},{az * 1000}" for t, w, ax, ay, az in zip(
            columns["time_s"], columns["drift_deg_h"], columns["ax_g"], columns["ay_g"],
            columns["az_g"], strict=True)]
    path = tmp_path / "log.csv"
    path.write_text("\n".join(lines) + "\n")
    maps = parse_column_maps(["time_s=t", "drift_deg_h=w", "ax_g=acc_x:m/s^2",
                              "ay_g=acc_y:m/s2", "az_g=acc_z:mg"])
    log = load_bench_log(path, "overload", column_map=maps)
    for name in ("ax_g", "ay_g", "az_g"):
        assert np.allclose(log.columns[name], columns[name], atol=1e-9)


@pytest.mark.slow
def test_simulation_based_calibration_of_the_tumble():
    """Truth drawn from paper A's FOG priors (w0 ~ N(0, 10), n ~ N(0, 1)), 40 short
    tumbles: posterior ranks uniform, 90 % intervals cover at the binomial rate (>= 31 of
    40: a 1-in-200 miss per parameter)."""
    rng = np.random.default_rng(11)
    names = ("w0", "nx", "ny", "nz")
    protocol = OverloadProtocol(dwell_min=3.0)
    ranks = {n: [] for n in names}
    covered = dict.fromkeys(names, 0)
    for k in range(40):
        truth = {"w0": rng.normal(0, 10), **{n: rng.normal(0, 1) for n in names[1:]}}
        sim = simulate_overload_bench(parameters=truth, protocol=protocol, seed=500 + k,
                                      noise=GyroNoise(arw_deg_rt_h=0.05))
        result = fit_log(sim.log, "overload", BenchOptions(noise="white", prior_set="paper_a_fog"),
                         seed=k, sampler=QUICK)
        posterior_names = list(result.posterior.names)
        for name in names:
            draws = np.asarray(result.posterior.draws)[..., posterior_names.index(name)]
            draws = draws.reshape(-1)
            ranks[name].append(np.mean(draws < truth[name]))
            lo, hi = np.percentile(draws, [5, 95])
            covered[name] += lo <= truth[name] <= hi
    for name in names:
        assert stats.kstest(ranks[name], "uniform").pvalue > 1e-3, name
        assert covered[name] >= 31, (name, covered[name])
