"""Bench simulators checked against their own truth."""

import numpy as np
import pytest
from helpers import QUIET, SHORT_THERMAL

from gyroid import DriftModel, GyroidInputError, GyroNoise
from gyroid.simulation import (
    PAPER_A_DEVICE_2,
    PAPER_A_THERMAL,
    MagneticProtocol,
    ThermalProtocol,
    simulate_magnetic_bench,
    simulate_thermal_bench,
)


def _least_squares(log, terms, **options):
    model = DriftModel.from_terms(terms)
    design = np.asarray(model.design(log.inputs(**options)))
    coef = np.linalg.lstsq(design, log.drift_deg_h, rcond=None)[0]
    return dict(zip(model.parameter_names, coef, strict=True))


def test_noise_free_thermal_log_recovers_the_coefficients():
    sim = simulate_thermal_bench(noise=QUIET, seed=0)
    # Without thermometer noise a short rate window has negligible smoothing bias.
    fit = _least_squares(sim.log, "thermal", rate_window_s=60.0)
    for name, value in PAPER_A_THERMAL.items():
        assert fit[name] == pytest.approx(value, rel=1e-6, abs=1e-6), name


def test_noise_free_magnetic_log_recovers_the_coefficients():
    sim = simulate_magnetic_bench(noise=QUIET, seed=0)
    fit = _least_squares(sim.log, "magnetic")
    for name, value in {"w0": PAPER_A_THERMAL["w0"], **PAPER_A_DEVICE_2}.items():
        assert fit[name] == pytest.approx(value, rel=1e-9, abs=1e-9), name


def test_candidate_effects_are_switched_on_with_chosen_values():
    effects = {
        "warmup": {"w_warmup": 2.5, "tau_warmup_min": 15.0},
        "time_trend": {"w_trend": 0.05},
        "temperature_cubic": {"w3": 1e-4},
    }
    sim = simulate_thermal_bench(noise=QUIET, effects=effects, protocol=SHORT_THERMAL)
    assert set(sim.truth["effects"]) >= {"warmup", "time_trend", "temperature_cubic"}
    assert sim.truth["parameters"]["tau_warmup_min"] == 15.0
    model = DriftModel(terms=tuple(sim.truth["effects"]))
    assert model.parameter_names == tuple(sim.truth["parameters"])
    # The drift starts 2.5 deg/h above what the other effects give.
    without = simulate_thermal_bench(
        noise=QUIET,
        effects={k: v for k, v in effects.items() if k != "warmup"},
        protocol=SHORT_THERMAL,
    )
    assert sim.log.drift_deg_h[0] - without.log.drift_deg_h[0] == pytest.approx(2.5)
    with pytest.raises(GyroidInputError, match="tau_warmup_min"):
        simulate_thermal_bench(effects={"warmup": {"w_warmup": 1.0}})
    with pytest.raises(GyroidInputError, match="unknown effect"):
        simulate_thermal_bench(effects={"warm_up": {}})


def test_magnetic_sweep_follows_the_paper_protocol():
    sim = simulate_magnetic_bench(seed=1)
    field = np.column_stack([sim.log.columns[c] for c in ("Hx_uT", "Hy_uT", "Hz_uT")])
    active = np.argmax(np.abs(field), axis=1)
    strong = np.max(np.abs(field), axis=1) > 25.0
    # OX, then OY, then OZ.
    order = active[strong]
    assert list(dict.fromkeys(order.tolist())) == [0, 1, 2]
    for k in range(3):
        on_axis = field[active == k, k]
        assert on_axis.max() == pytest.approx(300.0, abs=0.5)
        assert on_axis.min() == pytest.approx(-300.0, abs=0.5)
    # Each axis: 0 -> +300 -> -300 -> 0 in 50 uT steps of 180 s.
    levels = MagneticProtocol().sweep_levels_uT()
    assert levels[0] == 0 and levels[6] == 300 and levels[18] == -300 and levels[-1] == 0
    assert np.all(np.abs(np.diff(levels)) == 50.0)
    assert sim.log.n == 3 * levels.size * 180
    # The azimuth turn leaves a gap in time before OZ.
    assert np.max(np.diff(sim.log.time_s)) == pytest.approx(601.0)


def test_thermal_schedule_reaches_each_setpoint():
    protocol = ThermalProtocol()
    sim = simulate_thermal_bench(seed=2, protocol=protocol)
    for level, start, end in protocol.reading_windows_s():
        inside = (sim.log.time_s >= start) & (sim.log.time_s < end)
        # Settled: the erf tails of the neighbouring transitions leave at most 0.14 % of a
        # 10 degC step, plus the 60 s mean of 0.01 degC thermometer noise.
        mean = sim.log.columns["temperature_C"][inside].mean()
        assert mean == pytest.approx(level, abs=0.0014 * 10.0 + 4 * 0.01 / np.sqrt(60))
    assert protocol.setpoints_C == (31.0, 35.0, 40.0, 45.0, 50.0, 55.0)


def test_white_noise_level_follows_the_angle_random_walk():
    noise = GyroNoise(arw_deg_rt_h=0.01)
    sim = simulate_magnetic_bench(noise=noise, seed=4)
    residual = sim.log.drift_deg_h - sim.true_drift_deg_h
    expected = 0.01 * 60.0  # deg/h at 1 Hz
    # n = 13500 samples: the sample sd is within 4 standard errors (sd / sqrt(2n)).
    assert residual.std() == pytest.approx(expected, abs=4 * expected / np.sqrt(2 * residual.size))


def test_correlated_noise_has_the_stated_correlation():
    noise = GyroNoise(arw_deg_rt_h=0.0, bias_instability_deg_h=0.05, correlation_time_s=60.0)
    sim = simulate_magnetic_bench(noise=noise, seed=9)
    residual = sim.log.drift_deg_h - sim.true_drift_deg_h
    n = residual.size
    phi = np.exp(-1.0 / 60.0)
    r = np.corrcoef(residual[:-1], residual[1:])[0, 1]
    # Lag-one autocorrelation of an AR(1): sd about sqrt((1 - phi^2) / n).
    assert r == pytest.approx(phi, abs=5 * np.sqrt((1 - phi**2) / n))
    # Stationary sd = bias instability / 0.6174; ~n / 120 independent stretches.
    assert residual.std() == pytest.approx(0.05 / 0.6174, rel=4 / np.sqrt(n / 120))


def test_window_averages_and_sigma():
    sim = simulate_magnetic_bench(seed=5, average_s=60.0)
    log = sim.log
    steps = np.diff(log.time_s)
    assert np.allclose(steps[steps < 100], 60.0)
    white = sim.truth["noise"]["white_sd_deg_h"] / np.sqrt(60.0)
    # The standard error of each 60 s mean scatters around white / sqrt(60): its mean over
    # 225 windows is within a few percent (each window's sd has relative sd 1/sqrt(118)).
    assert np.mean(log.sigma_deg_h) == pytest.approx(white, rel=4 / np.sqrt(118 * 225))
    assert log.n == 225


def test_same_seed_same_log_and_different_seed_different_log():
    a = simulate_thermal_bench(seed=8, protocol=SHORT_THERMAL)
    b = simulate_thermal_bench(seed=8, protocol=SHORT_THERMAL)
    c = simulate_thermal_bench(seed=9, protocol=SHORT_THERMAL)
    np.testing.assert_array_equal(a.log.drift_deg_h, b.log.drift_deg_h)
    assert not np.allclose(a.log.drift_deg_h, c.log.drift_deg_h)
    assert a.truth["seed"] == 8
