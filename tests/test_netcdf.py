"""netCDF logs (contract section 6): read without renaming or --map in the layouts xarray
and the CF conventions write (a time coordinate as datetime64 or seconds, one variable per
axis or one with an axis dimension, units from attributes), both netCDF-4 and classic;
ambiguity named, and --map choosing."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr
from helpers import SHORT_THERMAL, WHITE

from gyroid.cli import main
from gyroid.errors import GyroidInputError
from gyroid.io import parse_column_maps, read_log_table
from gyroid.simulation import simulate_thermal_bench

RAD_S_TO_DEG_H = 180.0 / np.pi * 3600.0


def _thermal_dataset(seed: int = 1) -> tuple[xr.Dataset, dict]:
    """A still IMU on a thermal bench as xarray writes it: a datetime64 clock, the gyro in
    rad/s and the accelerometer in m/s^2 along an axis dimension, the field in nT, two
    thermometers (the IMU's and the chamber's)."""
    sims = [simulate_thermal_bench(seed=seed + k, protocol=SHORT_THERMAL) for k in range(3)]
    columns = sims[0].log.columns
    n = columns["time_s"].size
    start = np.datetime64("2025-01-15T08:00:00", "ns")
    clock = start + (columns["time_s"] * 1e9).astype("timedelta64[ns]")
    gyro = np.column_stack([s.log.columns["drift_deg_h"] for s in sims]) / RAD_S_TO_DEG_H
    accel = np.tile([0.0, 0.1, -9.80665], (n, 1))
    dataset = xr.Dataset(
        {"gyro": (("time", "axis"), gyro, {"units": "rad s-1", "long_name": "angular rate"}),
         "acc": (("time", "axis"), accel, {"units": "m s-2"}),
         "mag": (("time", "axis"), np.tile([2e4, 0.0, -4e4], (n, 1)), {"units": "nT"}),
         "imu_temperature": ("time", columns["temperature_C"] + 273.15, {"units": "K"}),
         "chamber_temperature": ("time", columns["temperature_C"], {"units": "degC"})},
        coords={"time": clock, "axis": ["x", "y", "z"]})
    expected = {"time_s": (clock.astype(np.int64) / 1e9),
                "temperature_C": columns["temperature_C"], "ax_g": accel[:, 0] / 9.80665,
                "az_g": np.full(n, -1.0), "Hx_uT": np.full(n, 20.0)}
    for k, axis in enumerate("xyz"):
        expected[f"drift_{axis}_deg_h"] = sims[k].log.columns["drift_deg_h"]
    return dataset, expected


@pytest.mark.parametrize("engine", ["h5netcdf", "scipy"])  # netCDF-4 (HDF5) and classic
def test_an_xarray_file_is_read_in_contract_units(tmp_path, engine):
    dataset, expected = _thermal_dataset()
    path = tmp_path / "calibration.nc"
    dataset.to_netcdf(path, engine=engine)
    table = read_log_table(path)
    assert table.axes() == ("x", "y", "z")
    for name, values in expected.items():
        np.testing.assert_allclose(table.number_column(name), values, rtol=1e-9, atol=1e-9,
                                   err_msg=name)
    assert table.picked["temperature_C"] == "imu_temperature (K)"  # the sensor's own
    assert table.picked["drift_y_deg_h"] == "gyro[y] (rad s-1)"
    assert "gyro_x" not in table.header  # read as drift_x_deg_h only


@pytest.mark.slow
def test_a_netcdf_log_is_fitted_on_every_axis_without_renaming(tmp_path, capsys):
    dataset, _ = _thermal_dataset(seed=4)
    path = tmp_path / "calibration.nc"
    dataset.to_netcdf(path)
    code = main(["fit", str(path), "--terms", "thermal", "--out", str(tmp_path / "fit"),
                 *WHITE, "--seed", "1"])
    assert code in (0, 3), capsys.readouterr().err
    axes = json.loads((tmp_path / "fit" / "axes.json").read_text())
    assert sorted(axes["axes"]) == ["x", "y", "z"]
    assert (tmp_path / "fit" / "z" / "fit.json").is_file()


def test_per_axis_variables_and_a_cf_clock_in_seconds_since(tmp_path):
    n = 50
    rng = np.random.default_rng(2)
    rates = rng.normal(0.0, 0.01, (n, 3))
    dataset = xr.Dataset(
        {f"gyr{axis.upper()}": ("record", rates[:, k], {"units": "degree/s"})
         for k, axis in enumerate("xyz")}
        | {"T_board": ("record", np.linspace(20, 21, n), {"units": "Celsius"}),
           "t": ("record", np.arange(n) * 10, {"units": "milliseconds since 2024-06-01 "
                                                        "12:00:00"})})
    path = tmp_path / "log.nc"
    dataset.to_netcdf(path, engine="scipy")
    table = read_log_table(path)
    epoch = np.datetime64("2024-06-01T12:00:00", "s").astype(np.int64)
    np.testing.assert_allclose(table.number_column("time_s"), epoch + np.arange(n) * 0.01)
    np.testing.assert_allclose(table.number_column("drift_z_deg_h"), rates[:, 2] * 3600.0)
    np.testing.assert_allclose(table.number_column("temperature_C"), np.linspace(20, 21, n))


def test_ambiguity_is_named_and_map_chooses_with_the_files_units(tmp_path):
    n = 30
    dataset = xr.Dataset(
        {"rate": (("time", "imu"), np.ones((n, 2)), {"units": "deg/s"}),
         "temp_a": ("time", np.full(n, 20.0), {"units": "degC"}),
         "temp_b": ("time", np.full(n, 25.0), {"units": "degC"})},
        coords={"time": ("time", np.arange(n, dtype=float), {"units": "s"})})
    path = tmp_path / "two.nc"
    dataset.to_netcdf(path)
    with pytest.raises(GyroidInputError, match=r"several variables could be temperature_C "
                                               r"\(temp_a, temp_b\); choose one with --map"):
        read_log_table(path)
    maps = parse_column_maps(["temperature_C=temp_b", "drift_deg_h=rate[2]"])
    table = read_log_table(path, maps)
    assert table.number_column("temperature_C")[0] == 25.0
    assert table.number_column("drift_deg_h")[0] == 3600.0  # deg/s from the attribute
    with pytest.raises(GyroidInputError, match="units 'degC' are not a unit of drift_deg_h"):
        read_log_table(path, parse_column_maps(["drift_deg_h=temp_a"]))


def test_a_damaged_netcdf_file_gets_one_clear_message(tmp_path, capsys):
    path = tmp_path / "broken.nc"
    path.write_bytes(b"CDF\x01" + bytes(20))
    code = main(["fit", str(path), "--terms", "bias", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and "broken.nc: not a readable netCDF file" in err
    assert "Traceback" not in err


def test_a_clock_without_a_usual_name_is_mapped_with_its_unit(tmp_path):
    n = 10
    path = tmp_path / "clock.nc"
    xr.Dataset({"w": ("rec", np.ones(n), {"units": "deg/s"}),
                "clock": ("rec", np.arange(n) * 100.0)}).to_netcdf(path)
    with pytest.raises(GyroidInputError, match="name the clock with --map time_s=VARIABLE"):
        read_log_table(path)
    table = read_log_table(path, parse_column_maps(["time_s=clock:ms"]))
    np.testing.assert_allclose(table.number_column("time_s"), np.arange(n) * 0.1)
    np.testing.assert_allclose(table.number_column("drift_deg_h"), 3600.0)
