"""Native logs (docs/formats.md section 5): PX4 ULog, ArduPilot DataFlash, ROS 1 and ROS 2
bags (sqlite and MCAP) and MATLAB files are read with no --map in their common layouts,
each written by its format's published layout or its library's own writer; every axis in
deg/h, the temperature on the gyro's clock, the same numbers as the equivalent CSV."""

import json

import numpy as np
import pytest
from helpers import WHITE, write_dataflash, write_rosbag, write_ulog

from gyroid.cli import main
from gyroid.errors import GyroidInputError
from gyroid.io import read_log_table

RAD_TO_DEG_H = 180.0 / np.pi * 3600.0


def _imu(seed: int, n: int = 400, *, bias_deg_h=(40.0, -25.0, 90.0)) -> dict[str, np.ndarray]:
    """A still IMU warming up: per axis a bias plus 2 deg/h/degC, white noise; rad/s."""
    rng = np.random.default_rng(seed)
    t_us = (1_000_000 + 500_000 * np.arange(n)).astype(np.int64)  # 2 Hz
    temperature = 25.0 + 20.0 * (1.0 - np.exp(-np.arange(n) / (n / 3)))
    imu = {"timestamp_sample": t_us, "temperature": temperature}
    for k, axis in enumerate("xyz"):
        drift = bias_deg_h[k] + 2.0 * (temperature - 21.0) + 30.0 * rng.standard_normal(n)
        imu[axis] = drift / RAD_TO_DEG_H
    return imu


def _expected(imu: dict, *, float32: bool, temperature=None) -> dict[str, np.ndarray]:
    """The contract columns a reader must give: deg/h from the values as stored."""
    cast = (lambda v: np.asarray(v, dtype=np.float32).astype(float)) if float32 else (
        lambda v: np.asarray(v, dtype=float))
    out = {"time_s": imu["timestamp_sample"] * 1e-6,
           "temperature_C": cast(imu["temperature"]) if temperature is None else temperature}
    for axis in "xyz":
        out[f"drift_{axis}_deg_h"] = cast(imu[axis]) * RAD_TO_DEG_H
    return out


def _assert_columns(table, expected: dict[str, np.ndarray]) -> None:
    assert table.axes() == ("x", "y", "z")
    for name, values in expected.items():
        np.testing.assert_allclose(table.raw[name], values, rtol=1e-12, atol=1e-12,
                                   err_msg=name)


def test_ulog_sensor_gyro_instances(tmp_path):
    first, second = _imu(0), _imu(1)
    path = write_ulog(tmp_path / "log.ulg", [first, second])
    _assert_columns(read_log_table(path), _expected(first, float32=True))
    table = read_log_table(path, instance=1)
    _assert_columns(table, _expected(second, float32=True))
    assert table.picked["stream"] == "sensor_gyro" and table.picked["instances"] == 2
    assert table.picked["device_id"] == 1001
    with pytest.raises(GyroidInputError, match="--instance 2: the log has 2 sensor_gyro"):
        read_log_table(path, instance=2)


def test_dataflash_imu_messages(tmp_path):
    first, second = _imu(2), _imu(3)
    path = write_dataflash(tmp_path / "00000001.BIN".lower(), [first, second])
    _assert_columns(read_log_table(path, instance=1), _expected(second, float32=True))
    assert read_log_table(path).picked["format"] == "ArduPilot DataFlash"


@pytest.mark.parametrize("name", ["bag.mcap", "bag_sqlite", "bag.bag"])
def test_ros_bags_with_a_temperature_topic(tmp_path, name):
    imu = _imu(4)
    path = write_rosbag(tmp_path / name, imu, ros1=name.endswith(".bag"))
    t = imu["timestamp_sample"] * 1e-6
    every = slice(None, None, 10)  # the temperature topic, put on the gyro's clock
    expected = _expected(imu, float32=False)
    inside = t <= t[every][-1]
    expected = {k: v[inside] for k, v in expected.items()}
    expected["temperature_C"] = np.interp(t[inside], t[every], imu["temperature"][every])
    table = read_log_table(path)
    _assert_columns(table, expected)
    assert table.picked["stream"] == "/imu"
    assert table.picked["temperature"] == "/imu/temperature"
    assert table.picked["rows_outside_temperature_dropped"] == int(np.sum(~inside))


def test_mat_files_read_every_column_and_map_units(tmp_path):
    import h5py
    from scipy.io import savemat

    imu = _imu(5)
    t = imu["timestamp_sample"] * 1e-6
    rates_deg_s = np.column_stack([imu[a] for a in "xyz"]) * 180.0 / np.pi
    matrix = np.column_stack([t, rates_deg_s])  # MATLAB: n x 4 (t, x, y, z in deg/s)
    v5 = tmp_path / "gyro_v5.mat"
    savemat(v5, {"gyroBuffer": matrix, "temp": imu["temperature"]})
    v73 = tmp_path / "gyro_v73.mat"
    with h5py.File(v73, "w", userblock_size=512) as handle:  # MATLAB 7.3 stores the transpose
        handle["gyroBuffer"] = matrix.T
        handle["temp"] = imu["temperature"][None, :]
    maps = ["time_s=gyroBuffer_1", "temperature_C=temp",
            *(f"drift_{a}_deg_h=gyroBuffer_{k + 2}:deg/s" for k, a in enumerate("xyz"))]
    for path in (v5, v73):
        table = read_log_table(path)
        assert table.header == ("gyroBuffer_1", "gyroBuffer_2", "gyroBuffer_3",
                                "gyroBuffer_4", "temp")
        np.testing.assert_allclose(table.raw["gyroBuffer_3"], rates_deg_s[:, 1], rtol=1e-15)
    out = tmp_path / "fit"
    args = ["fit", *WHITE,
            str(v73), "--terms", "bias,temperature", "--axes", "y", "--out", str(out),
            "--no-progress"]
    for item in maps:
        args += ["--map", item]
    assert main(args) == 0
    w1 = json.loads((out / "fit.json").read_text())["posterior"]["w1"]
    assert abs(w1["mean"] - 2.0) < 4 * w1["sd"]


@pytest.mark.slow
def test_a_ulog_is_fitted_on_every_axis_as_its_csv(tmp_path):
    """The end-to-end promise: one gyroid fit of a ULog, every axis, the same numbers as the
    CSV of the same values (to 1e-9)."""
    imu = _imu(6)
    ulog = write_ulog(tmp_path / "log.ulg", [imu])
    columns = _expected(imu, float32=True)
    csv = tmp_path / "log.csv"  # every digit, so that both fits read the same numbers
    rows = zip(*columns.values(), strict=True)
    csv.write_text(",".join(columns) + "\n" + "\n".join(
        ",".join(repr(float(v)) for v in row) for row in rows) + "\n")
    for name, path in (("ulog", ulog), ("csv", csv)):
        assert main(["fit", *WHITE, str(path), "--terms", "bias,temperature", "--out",
                     str(tmp_path / name), "--no-progress"]) == 0
    source = json.loads((tmp_path / "ulog" / "axes.json").read_text())["source"]
    assert source["format"] == "PX4 ULog" and source["gyro_unit"] == "rad/s"
    for axis in "xyz":
        a, b = (json.loads((tmp_path / name / axis / "fit.json").read_text())["posterior"]
                for name in ("ulog", "csv"))
        for parameter in ("w0", "w1"):
            assert a[parameter]["mean"] == pytest.approx(b[parameter]["mean"], rel=1e-9)
            assert a[parameter]["sd"] == pytest.approx(b[parameter]["sd"], rel=1e-9)


@pytest.mark.parametrize(("name", "content", "message"), [
    ("bad.ulg", b"not a ulog", "not a readable ULog file"),
    ("bad.bin", b"\x00" * 10, "no IMU instances in the log"),
    ("bad.mcap", b"nothing", "not a readable ROS bag"),
    ("bad.mat", b"nothing", "not a readable MATLAB file"),
])
def test_a_damaged_native_log_gets_one_clear_message(tmp_path, capsys, name, content, message):
    path = tmp_path / name
    path.write_bytes(content)
    assert main(["fit", *WHITE, str(path), "--terms", "bias", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


@pytest.mark.slow
def test_the_imus_of_one_log_pool_as_runs(tmp_path, capsys):
    """Three gyros of one type in one ULog, each with its own bias and the type's 2 deg/h
    per degC: pooled as runs STEM#N of one axis, the type's temperature coefficient is
    recovered and the three biases differ. (Their noise is white, and pooled as such: the
    subject here is reading the instances.)"""
    biases = (40.0, 65.0, 15.0)
    instances = [_imu(10 + k, n=600, bias_deg_h=(b, 0.0, 0.0)) for k, b in enumerate(biases)]
    path = write_ulog(tmp_path / "three.ulg", instances)
    out = tmp_path / "pool"
    assert main(["pool", str(path), "--instances", "all", "--axis", "x", "--terms",
                 "bias,temperature", "--noise", "white", "--out", str(out)]) == 0
    record = json.loads((out / "pool.json").read_text())
    assert record["runs"] == ["three#0", "three#1", "three#2"]
    lo, hi = record["population"]["w1"]["ci95"]
    assert lo < 2.0 < hi
    w0 = [record["per_run"][f"three#{k}"]["w0"]["mean"] for k in range(3)]
    assert w0[1] > w0[0] > w0[2]
    capsys.readouterr()
    assert main(["pool", str(path), "--instances", "0,3", "--axis", "x", "--terms", "bias",
                 "--out", str(tmp_path / "bad")]) == 2
    assert "there is no instance 3" in capsys.readouterr().err


def test_native_readers_carry_the_accelerometer_in_g(tmp_path):
    """Contract section 6: the accelerometer without --map, in g on the gyro's clock (a
    ULog's sensor_accel on its own clock, interpolated; DataFlash's and ROS's on the gyro's
    samples); a log without one has no ax_g."""
    first, second = _imu(5), _imu(6)
    t_us = second["timestamp_sample"]
    second["accel_time_us"] = np.arange(t_us[0] - 100_000, t_us[-1] + 300_000, 250_000)
    tilt = np.linspace(0.0, 1.0, second["accel_time_us"].size)
    second["accel"] = 9.80665 * np.column_stack([tilt, 0.0 * tilt, -np.sqrt(1 - tilt**2)])
    path = write_ulog(tmp_path / "log.ulg", [first, second])
    assert "ax_g" not in read_log_table(path).header
    table = read_log_table(path, instance=1)
    stored = second["accel"].astype(np.float32).astype(float) / 9.80665
    for k, axis in enumerate("xyz"):
        expected = np.interp(t_us * 1e-6, second["accel_time_us"] * 1e-6, stored[:, k])
        np.testing.assert_allclose(table.raw[f"a{axis}_g"], expected, atol=1e-6)
    assert table.picked["accelerometer_stream"] == "sensor_accel"

    dataflash = read_log_table(write_dataflash(tmp_path / "log.bin", [first]))
    np.testing.assert_allclose(dataflash.raw["az_g"], -1.0, rtol=1e-6)
    np.testing.assert_allclose(dataflash.raw["ax_g"], 0.0)

    bag = read_log_table(write_rosbag(tmp_path / "bag.mcap", first))
    np.testing.assert_allclose(bag.raw["az_g"], 9.81 / 9.80665)
    without = read_log_table(write_rosbag(tmp_path / "bag2.mcap", first, with_accel=False))
    assert "az_g" not in without.header
