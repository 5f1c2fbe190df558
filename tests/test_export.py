"""gyroid export (docs/formats.md section 5): the parameter files, evaluated with each
firmware's published formula, reproduce gyroid's fitted temperature polynomial over the
fitted range; the terms the firmware cannot represent are named with the drift they leave."""

import json
import math

import numpy as np
import pytest
from helpers import WHITE, write_log

from gyroid.cli import main
from gyroid.workflows._export import recentre

TERMS = "bias,temperature,temperature_sq,temperature_rate"
DEG_H = math.pi / 180.0 / 3600.0  # rad/s per deg/h


@pytest.fixture(scope="module")
def fit_dir(tmp_path_factory):
    """A three-axis thermal-cycle log (quadratic in temperature, with a dT/dt term: a cycle,
    not an exponential warm-up, whose rate is a linear function of the temperature) fitted;
    its fit passes its checks."""
    root = tmp_path_factory.mktemp("export")
    rng = np.random.default_rng(7)
    time_s = 10.0 * np.arange(900)
    temperature = 30.0 - 15.0 * np.cos(2.0 * np.pi * time_s / 6000.0)
    rate = np.gradient(temperature, time_s) * 3600.0
    columns = {"time_s": time_s, "temperature_C": temperature}
    for k, axis in enumerate("xyz"):
        t = temperature - 21.0
        columns[f"drift_{axis}_deg_h"] = (5.0 * (k - 1) + 0.3 * t + 0.004 * t**2 + 0.05 * rate
                                          + 0.2 * rng.standard_normal(time_s.size))
    log = write_log(root / "imu.csv", columns)
    assert main(["fit", *WHITE, str(log), "--terms", TERMS, "--out", str(root / "fit"),
                 "--no-progress"]) == 0
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
    assert main(["fit", *WHITE, str(log), "--terms", "bias", "--out", str(tmp_path / "f"),
                 "--no-progress"]) in (0, 3)
    assert main(["export", str(tmp_path / "f"), "--to", "px4", "--out",
                 str(tmp_path / "e")]) == 2
    assert "has no temperature term" in capsys.readouterr().err
    assert not (tmp_path / "e").exists()


def _yaml_values(text: str) -> dict[str, str]:
    """``key: value`` lines of a YAML file (comments dropped)."""
    pairs = (line.split("#")[0].strip().split(":", 1) for line in text.splitlines())
    return {k.strip(): v.strip() for k, *v in pairs if v and v[0].strip()
            for v in [v[0]]}


@pytest.fixture(scope="module")
def noise_dir(tmp_path_factory):
    """Two static axes simulated by Kalibr's own discrete-time definitions (white noise of sd
    density/sqrt(dt) per sample, a bias walking by random_walk*sqrt(dt) per sample), in rad/s,
    written in deg/h and fitted by gyroid noise."""
    root = tmp_path_factory.mktemp("noise_export")
    rng = np.random.default_rng(11)
    n, dt = 60_000, 0.01
    columns = {"time_s": dt * np.arange(n)}
    for axis, density in (("x", 1.0e-3), ("y", 2.0e-3)):
        walk = 2.0e-4
        rate = (rng.normal(0.0, density / np.sqrt(dt), n)
                + np.cumsum(rng.normal(0.0, walk * np.sqrt(dt), n)))
        columns[f"drift_{axis}_deg_h"] = rate / DEG_H
    log = write_log(root / "static.csv", columns)
    assert main(["noise", str(log), "--out", str(root / "noise")]) == 0
    return root / "noise"


@pytest.mark.parametrize("target, name", [("kalibr", "imu.yaml"),
                                          ("openvins", "kalibr_imu_chain.yaml")])
def test_noise_export_gives_the_simulated_densities(noise_dir, tmp_path, target, name):
    out = tmp_path / target
    assert main(["export", str(noise_dir), "--to", target, "--out", str(out)]) == 0
    text = (out / name).read_text()
    values = _yaml_values(text)
    record = json.loads((out / "export.json").read_text())
    # The largest axis (y: 2e-3 rad/s/sqrt(Hz)) is written; each axis's own value beside.
    assert float(values["gyroscope_noise_density"]) == pytest.approx(2.0e-3, rel=0.02)
    assert record["axes"]["x"]["gyroscope_noise_density"] == pytest.approx(1.0e-3, rel=0.02)
    # A walk's estimate from 600 s has a wide posterior: within a factor 2.
    walk = float(values["gyroscope_random_walk"])
    assert 1.0e-4 < walk < 4.0e-4
    assert float(values["update_rate"]) == pytest.approx(100.0)
    assert values["rostopic"] == "/imu0"
    assert "accelerometer_noise_density:" not in values  # commented: gyroid fits gyros only
    if target == "openvins":
        assert text.startswith("%YAML:1.0") and values["model"] == '"kalibr"'


def test_exports_refuse_the_wrong_kind_of_fit(noise_dir, fit_dir, tmp_path, capsys):
    assert main(["export", str(noise_dir), "--to", "px4", "--out", str(tmp_path / "a")]) == 2
    assert "is a noise fit" in capsys.readouterr().err
    assert main(["export", str(fit_dir), "--to", "kalibr", "--out", str(tmp_path / "b")]) == 2
    assert "is not a noise fit" in capsys.readouterr().err
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


@pytest.mark.slow
def test_an_untrustworthy_fit_is_exported_with_exit_3(tmp_path, capsys):
    """An exponential warm-up: dT/dt is a linear function of T, so w1 and wD are not
    identified; the fit says so (exit 3), and so does the export of it."""
    time_s = 10.0 * np.arange(600)
    temperature = 15.0 + 30.0 * (1.0 - np.exp(-time_s / 3000.0))
    drift = 0.3 * (temperature - 21.0) + np.random.default_rng(2).normal(0.0, 0.2, 600)
    log = write_log(tmp_path / "warmup.csv", {"time_s": time_s, "temperature_C": temperature,
                                              "drift_deg_h": drift})
    assert main(["fit", *WHITE, str(log), "--terms", TERMS, "--out", str(tmp_path / "f"),
                 "--no-progress"]) == 3
    assert "collinear" in capsys.readouterr().err
    assert main(["export", str(tmp_path / "f"), "--to", "px4", "--out",
                 str(tmp_path / "e")]) == 3
    assert "NOT trustworthy" in capsys.readouterr().out
    assert not json.loads((tmp_path / "e" / "export.json").read_text()
                          )["axes"]["x"]["source_trustworthy"]


@pytest.mark.slow
def test_a_still_bag_becomes_an_estimators_noise_file(tmp_path):
    """The README's ROS path: an MCAP bag of a still IMU (sensor_msgs/Imu on /imu, rad/s),
    gyroid noise on its three axes, then a Kalibr imu.yaml naming the bag's topic."""
    from helpers import write_rosbag

    rng = np.random.default_rng(5)
    n, dt, density = 20_000, 0.01, 1.5e-3  # rad/s/sqrt(Hz) on every axis
    imu = {"timestamp_sample": (10_000 * np.arange(n)).astype(np.int64),
           "temperature": np.full(n, 25.0)}
    for axis in "xyz":
        imu[axis] = rng.normal(0.0, density / np.sqrt(dt), n)
    bag = write_rosbag(tmp_path / "still.mcap", imu, temperature_every=100)
    assert main(["noise", str(bag), "--out", str(tmp_path / "noise")]) == 0
    assert main(["export", str(tmp_path / "noise"), "--to", "kalibr", "--out",
                 str(tmp_path / "kalibr")]) == 0
    values = _yaml_values((tmp_path / "kalibr" / "imu.yaml").read_text())
    assert values["rostopic"] == "/imu"
    # The largest of three estimates, each within about 1 % (sd 0.5 %) of the truth.
    assert float(values["gyroscope_noise_density"]) == pytest.approx(density, rel=0.03)
