"""The dT/dt estimator's own error is named (issue 42): where the temperature's curvature
changes faster than the window follows, its rows and the drift error bound are given; where
the temperature is smooth, nothing is said."""

import numpy as np

from gyroid.bench._rate_estimate import rate_estimate
from gyroid.models import temperature_rate_deg_c_per_h
from gyroid.simulation import ThermalProtocol, simulate_thermal_bench


def _temperature(transition_min: float):
    columns = simulate_thermal_bench(
        seed=1, protocol=ThermalProtocol(transition_min=transition_min)).log.columns
    return columns["time_s"], columns["temperature_C"]


def _true_rate(time_s, transition_min: float) -> np.ndarray:
    return ThermalProtocol(transition_min=transition_min).temperature(time_s)[1]


def test_smooth_transitions_pass_and_fast_ones_are_named_with_their_drift_error():
    time_s, temperature = _temperature(60.0)
    assert rate_estimate(time_s, temperature, 1200.0, 2.0, 0.05).passed
    time_s, temperature = _temperature(10.0)
    check = rate_estimate(time_s, temperature, 1200.0, 2.0, 0.05)
    assert not check.passed and check.severity == "warning"
    assert "0.2" in check.message and "estimator's error" in check.message
    # the drift error it states (|wD| x the two estimates' difference) against the true one:
    # |wD| x the estimate's largest error from the simulator's analytic rate (82 deg/h)
    error = np.abs(temperature_rate_deg_c_per_h(time_s, temperature, 1200.0)
                   - _true_rate(time_s, 10.0))
    stated = float(check.message.split("up to ")[1].split(" deg/h")[0])
    assert 0.5 < stated / (2.0 * error.max()) < 2.0


def test_a_model_without_a_rate_term_is_not_judged():
    time_s, temperature = _temperature(10.0)
    check = rate_estimate(time_s, temperature, 1200.0, None, 0.05)
    assert check.passed and check.message == "no dT/dt term"
