"""Paper A's classic estimators: the magnetic K and the setpoint-table least squares."""

import numpy as np
import pytest
from helpers import QUIET

from gyroid.io import (
    paper_a_magnetic_coefficients,
    paper_a_thermal_coefficients,
    paper_a_thermal_table,
)
from gyroid.papers import chi2_of, magnetic_k, setpoint_table_fit
from gyroid.simulation import PAPER_A_DEVICE_2, simulate_magnetic_bench


def test_k_equals_the_coefficient_on_a_noise_free_sweep():
    sim = simulate_magnetic_bench(noise=QUIET)
    for axis in "xyz":
        k = magnetic_k(sim.log, axis)
        truth = PAPER_A_DEVICE_2[f"w{axis}"]
        assert k.signed == pytest.approx(truth, abs=1e-12)
        assert k.K == pytest.approx(abs(truth), abs=1e-12)


def test_k_standard_error_is_honest():
    # Over 40 seeds the K scatter matches the reported sd (chi-square with 40 dof).
    z = []
    for seed in range(40):
        k = magnetic_k(simulate_magnetic_bench(seed=seed).log, "y")
        z.append((k.signed - PAPER_A_DEVICE_2["wy"]) / k.sd)
    z = np.asarray(z)
    assert abs(z.mean()) < 3.0 / np.sqrt(40)
    assert 0.6 < z.std() < 1.4


def test_paper_a_table_refit_and_printed_chi2():
    table = paper_a_thermal_table()
    fit = setpoint_table_fit(table.setpoint_C, table.dw_deg_h, table.sigma_deg_h)
    # papers.md: a weighted refit gives about w0 = 1.42, w1 = -0.130, w2 = 0.0039, chi2 ~ 8.
    assert fit.coefficients["w0"] == pytest.approx(1.42, abs=0.01)
    assert fit.coefficients["w1"] == pytest.approx(-0.130, abs=0.002)
    assert fit.coefficients["w2"] == pytest.approx(0.0039, abs=0.0001)
    assert fit.chi2 == pytest.approx(8.0, abs=0.5)
    assert fit.dof == 3
    printed = paper_a_thermal_coefficients()
    chi2 = chi2_of(printed, table.setpoint_C - 21.0, table.dw_deg_h, table.sigma_deg_h)
    assert 1.0e3 < chi2 < 1.4e3
    model_55 = printed["w0"] + printed["w1"] * 34 + printed["w2"] * 34**2
    assert model_55 - table.dw_deg_h[-1] == pytest.approx(0.59, abs=0.01)


def test_package_data_holds_the_papers_numbers():
    table = paper_a_thermal_table()
    np.testing.assert_array_equal(table.setpoint_C, [31, 35, 40, 45, 50, 55])
    assert table.dw_deg_h[-1] == 1.564 and table.sigma_deg_h[0] == 0.081
    assert any("Antonova" in line for line in table.source)
    mag = paper_a_magnetic_coefficients()
    assert mag[(2, 1)] == {"wx": -0.037, "wy": -0.576, "wz": -0.253}
    assert mag[(1, 2)]["wz"] == -0.041


def test_setpoint_readings_from_a_noise_free_thermal_log():
    from gyroid.papers import setpoint_readings
    from gyroid.simulation import ThermalProtocol, simulate_thermal_bench

    protocol = ThermalProtocol()
    sim = simulate_thermal_bench(noise=QUIET, protocol=protocol)
    levels, means, rms = setpoint_readings(sim.log, protocol.reading_windows_s(60.0))
    assert list(levels) == [21.0, 31.0, 35.0, 40.0, 45.0, 50.0, 55.0]
    # Each reading is the mean true drift over its 60 s window (exact on a noise-free log).
    for (_level, start, end), mean in zip(protocol.reading_windows_s(60.0), means, strict=True):
        inside = (sim.log.time_s >= start) & (sim.log.time_s < end)
        assert mean == pytest.approx(sim.true_drift_deg_h[inside].mean(), abs=1e-12)
    # Not yet the quadratic alone: the next transition's erf tail has begun (about
    # 0.2 degC/h, i.e. ~0.4 deg/h through wD) -- a limit of the erf-shaped transitions.
    t = levels - 21.0
    quadratic = 1.197 - 0.108 * t + 0.004 * t**2
    assert np.all(np.abs(means - quadratic) < 0.6)
    assert np.all(rms < 0.05)
