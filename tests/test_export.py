"""gyroid export (docs/formats.md section 5): the parameter files, evaluated with each
firmware's published formula, reproduce gyroid's fitted temperature polynomial over the
fitted range; the terms the firmware cannot represent are named with the drift they leave."""

import json
import math

import numpy as np
import pytest
from helpers import write_log

from gyroid.cli import main
from gyroid.workflows._export import recentre

TERMS = "bias,temperature,temperature_sq,temperature_rate"
DEG_H = math.pi / 180.0 / 3600.0  # rad/s per deg/h


@pytest.fixture(scope="module")
def fit_dir(tmp_path_factory):
    """A three-axis warm-up log (quadratic in temperature, with a dT/dt term) fitted."""
    root = tmp_path_factory.mktemp("export")
    rng = np.random.default_rng(7)
    time_s = 10.0 * np.arange(900)
    temperature = 15.0 + 30.0 * (1.0 - np.exp(-time_s / 3000.0))
    rate = np.gradient(temperature, time_s) * 3600.0
    columns = {"time_s": time_s, "temperature_C": temperature}
    for k, axis in enumerate("xyz"):
        t = temperature - 21.0
        columns[f"drift_{axis}_deg_h"] = (5.0 * (k - 1) + 0.3 * t + 0.004 * t**2 + 0.05 * rate
                                          + 0.2 * rng.standard_normal(time_s.size))
    log = write_log(root / "imu.csv", columns)
    assert main(["fit", str(log), "--terms", TERMS, "--out", str(root / "fit"),
                 "--no-progress"]) in (0, 3)
    return root / "fit"


def _polynomial(fit_dir, axis):
    """gyroid's fitted polynomial (posterior means of w0, w1, w2 about t0) of one axis."""
    record = json.loads((fit_dir / axis / "fit.json").read_text())
    w = [record["posterior"][n]["mean"] for n in ("w0", "w1", "w2")] + [0.0]
    return np.array(w), record["t0_C"], record["input_ranges"]["temperature_C"]


def _gyroid(w, t0, temperature):
    return sum(w[k] * (temperature - t0) ** k for k in range(4))


def test_px4_parameters_reproduce_the_fitted_polynomial(fit_dir, tmp_path):
    out = tmp_path / "px4"
    assert main(["export", str(fit_dir), "--to", "px4", "--out", str(out),
                 "--device-id", "2293768"]) == 0
    rows = [line.split("\t") for line in (out / "gyro_thermal.params").read_text().splitlines()
            if not line.startswith("#")]
    assert all(r[0] == "1" and r[1] == "1" and r[4] in ("6", "9") for r in rows)
    params = {r[2]: float(r[3]) for r in rows}
    assert params["TC_G0_ID"] == 2293768
    low, high, tref = params["TC_G0_TMIN"], params["TC_G0_TMAX"], params["TC_G0_TREF"]
    for a, axis in enumerate("xyz"):
        w, t0, (lo, hi) = _polynomial(fit_dir, axis)
        assert (low, high) == (lo, hi) and tref == pytest.approx(0.5 * (lo + hi))
        temperature = np.linspace(low, high, 50)
        px4 = sum(params[f"TC_G0_X{k}_{a}"] * (temperature - tref) ** k for k in range(4))
        np.testing.assert_allclose(px4 / DEG_H, _gyroid(w, t0, temperature), rtol=1e-9)
        # Beyond the range PX4 clips the temperature: the value at TMAX.
    record = json.loads((out / "export.json").read_text())
    assert record["axes"]["x"]["left_out_terms"] == ["temperature_rate"]
    assert record["axes"]["x"]["truncation_rms_deg_h"] > 0.0
    assert np.asarray(record["axes"]["y"]["covariance"]).shape == (4, 4)
    text = (out / "gyro_thermal.params").read_text()
    assert "left out temperature_rate" in text and "deg/h RMS" in text


def test_ardupilot_parameters_reproduce_the_fitted_corrections(fit_dir, tmp_path):
    out = tmp_path / "ap"
    assert main(["export", str(fit_dir), "--to", "ardupilot", "--out", str(out)]) == 0
    params = dict(line.split(",") for line in (out / "gyro_thermal.parm").read_text()
                  .splitlines() if not line.startswith("#"))
    params = {k: float(v) for k, v in params.items()}
    assert params["INS_TCAL1_ENABLE"] == 1
    low, high = params["INS_TCAL1_TMIN"], params["INS_TCAL1_TMAX"]
    temperature = np.linspace(low, high, 50)
    t_cal = 0.5 * (low + high)  # the start-up calibration's temperature

    for axis in "xyz":
        w, t0, _ = _polynomial(fit_dir, axis)
        c = [params[f"INS_TCAL1_GYR{k}_{axis.upper()}"] for k in (1, 2, 3)]

        def p(u, c=c):
            return (c[0] + (c[1] + c[2] * u) * u) * u * 1e-6

        correction = p(temperature - 35.0) - p(t_cal - 35.0)  # ArduPilot's correct_sensor
        expected = _gyroid(w, t0, temperature) - _gyroid(w, t0, t_cal)
        np.testing.assert_allclose(correction / DEG_H, expected, rtol=1e-9,
                                   atol=1e-9 * np.abs(expected).max())


def test_recentring_is_exact():
    rng = np.random.default_rng(0)
    w = rng.normal(size=(5, 4))
    u = np.linspace(-10, 10, 7)
    shift = 14.0  # Tref - t0
    c = recentre(w, shift)
    for row in range(5):
        np.testing.assert_allclose(np.polyval(c[row][::-1], u),
                                   np.polyval(w[row][::-1], u + shift), rtol=1e-12)


def test_a_fit_without_temperature_cannot_be_exported(tmp_path, capsys):
    log = write_log(tmp_path / "b.csv", {"time_s": np.arange(50.0),
                                         "drift_deg_h": np.random.default_rng(1).normal(
                                             size=50)})
    assert main(["fit", str(log), "--terms", "bias", "--out", str(tmp_path / "f"),
                 "--no-progress"]) in (0, 3)
    assert main(["export", str(tmp_path / "f"), "--to", "px4", "--out",
                 str(tmp_path / "e")]) == 2
    assert "has no temperature term" in capsys.readouterr().err
    assert not (tmp_path / "e").exists()
