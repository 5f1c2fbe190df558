"""The discrepancy workflow on logs with a hidden effect, and on null logs."""


import pytest
from helpers import check_report

from gyroid import GyroNoise
from gyroid.simulation import (
    simulate_magnetic_bench,
    simulate_thermal_bench,
)
from gyroid.workflows import find_discrepancies

pytestmark = pytest.mark.slow  # the whole module: end-to-end fits

HIDDEN_THERMAL = {
    "warmup": {"w_warmup": 1.0, "tau_warmup_min": 20.0},
    "time_trend": {"w_trend": 0.05},
    "temperature_cubic": {"w3": 2e-5},
    "thermal_lag": {"tau_lag_min": 10.0},
    "bias_step": {"w_step": 0.4, "t_step_h": 5.0},
}
HIDDEN_MAGNETIC = {
    "magnetic_hysteresis": {"hys_x": 0.0, "hys_y": 0.03, "hys_z": 0.06},
    "warmup": {"w_warmup": 0.5, "tau_warmup_min": 15.0},
    "time_trend": {"w_trend": 0.05},
}


@pytest.mark.parametrize("effect", list(HIDDEN_THERMAL))
def test_names_the_hidden_thermal_effect(effect):
    sim = simulate_thermal_bench(seed=11, effects={effect: HIDDEN_THERMAL[effect]})
    report = find_discrepancies(sim.log, "thermal")
    check_report(report, [effect])
    if effect == "bias_step":  # its time to about one of the search's 38 s block means
        assert report.steps[0].values["t_step_h"] == pytest.approx(5.0, abs=0.02)


@pytest.mark.parametrize("effect", list(HIDDEN_MAGNETIC))
def test_names_the_hidden_magnetic_effect(effect):
    sim = simulate_magnetic_bench(seed=12, effects={effect: HIDDEN_MAGNETIC[effect]})
    check_report(find_discrepancies(sim.log, "magnetic"), [effect])


@pytest.mark.parametrize(
    ("bench", "noise"),
    [
        ("thermal", GyroNoise()),
        ("thermal", GyroNoise(bias_instability_deg_h=0.1, correlation_time_s=600.0)),
        ("magnetic", GyroNoise()),
        ("magnetic", GyroNoise(bias_instability_deg_h=0.1, correlation_time_s=300.0)),
    ],
)
def test_null_logs_add_nothing(bench, noise):
    simulate = simulate_thermal_bench if bench == "thermal" else simulate_magnetic_bench
    sim = simulate(seed=13, noise=noise)
    report = find_discrepancies(sim.log, bench)
    check_report(report, [])
    assert report.final_terms == report.baseline_terms


def test_a_missing_paper_effect_is_found_from_a_reduced_model():
    # The magnetic preset without magnetic_y: the residuals follow Hy.
    sim = simulate_magnetic_bench(seed=14)
    report = find_discrepancies(sim.log, "bias,magnetic_x,magnetic_z")
    check_report(report, ["magnetic_y"])
    assert report.steps[0].regressor == "Hy"
    assert abs(report.steps[0].correlation) > 0.9
