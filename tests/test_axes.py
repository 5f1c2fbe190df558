"""Axes as a dimension (docs/formats.md section 5): a log of three gyro axes fitted and
compensated by one command, each axis exactly as the log of that axis alone, a folder per
axis and axes.json; exit 3 when any axis must not be used, naming it."""

import json

import numpy as np
import pytest
from helpers import WHITE, write_log

from gyroid.cli import main

TERMS = "bias,temperature"
#: Per axis: bias (deg/h), temperature slope (deg/h/degC), white noise (deg/h).
AXES = {"x": (3.0, 0.2, 0.5), "y": (-1.0, -0.1, 0.5), "z": (10.0, 0.05, 0.5)}


def _three_axis_log(seed: int, n: int = 600, wander_z: float = 0.0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    time_s = 10.0 * np.arange(n)
    temperature = 25.0 + 15.0 * np.sin(2 * np.pi * time_s / time_s[-1])
    columns = {"time_s": time_s, "temperature_C": temperature}
    for axis, (bias, slope, sd) in AXES.items():
        drift = bias + slope * (temperature - 21.0) + sd * rng.standard_normal(n)
        if axis == "z" and wander_z:  # a bias wander the white-noise fit cannot describe
            drift += wander_z * np.cumsum(rng.standard_normal(n)) / np.sqrt(n)
        columns[f"drift_{axis}_deg_h"] = drift
    return columns


@pytest.mark.slow
def test_three_axes_in_one_command_equal_three_logs_of_one(tmp_path):
    columns = _three_axis_log(0)
    log = write_log(tmp_path / "imu.csv", columns)
    out = tmp_path / "fit"
    assert main(["fit", *WHITE, str(log), "--terms", TERMS, "--out", str(out),
                 "--no-progress"]) == 0
    record = json.loads((out / "axes.json").read_text())
    assert list(record["axes"]) == ["x", "y", "z"]
    assert all(entry == {"trustworthy": True, "exit": 0, "folder": axis}
               for axis, entry in record["axes"].items())
    assert record["source"]["path"] == str(log)
    for axis in "xy":
        alone = write_log(tmp_path / f"{axis}.csv", {
            "time_s": columns["time_s"], "temperature_C": columns["temperature_C"],
            "drift_deg_h": columns[f"drift_{axis}_deg_h"]})
        single = tmp_path / f"fit_{axis}"
        assert main(["fit", *WHITE, str(alone), "--terms", TERMS, "--out", str(single),
                     "--no-progress"]) == 0
        one = json.loads((single / "fit.json").read_text())["posterior"]
        many = json.loads((out / axis / "fit.json").read_text())["posterior"]
        for name in ("w0", "w1"):
            assert many[name]["mean"] == pytest.approx(one[name]["mean"], rel=1e-9)
            assert many[name]["sd"] == pytest.approx(one[name]["sd"], rel=1e-9)
        assert (out / axis / "posterior.nc").exists()

    # Compensating the same kind of log: every axis with its own fit.
    new = write_log(tmp_path / "imu2.csv", _three_axis_log(1))
    comp = tmp_path / "comp"
    assert main(["compensate", str(new), "--fit", str(out), "--out", str(comp)]) == 0
    assert json.loads((comp / "axes.json").read_text())["axes"]["z"]["exit"] == 0
    for axis in "xyz":
        summary = json.loads((comp / axis / "compensate.json").read_text())
        assert summary["rms_after_deg_h"] < 0.7  # the white noise, 0.5, and its sampling
    # One axis chosen: its files in OUT itself.
    single = tmp_path / "comp_y"
    assert main(["compensate", str(new), "--fit", str(out), "--axes", "y", "--out",
                 str(single)]) == 0
    assert (single / "compensate.json").exists() and not (single / "axes.json").exists()


@pytest.mark.slow
def test_an_axis_that_must_not_be_used_is_named_and_the_others_written(tmp_path, capsys):
    log = write_log(tmp_path / "imu.csv", _three_axis_log(2, wander_z=60.0))
    out = tmp_path / "fit"
    # under white noise, which the z axis's wander breaks (auto would model it)
    assert main(["fit", *WHITE, str(log), "--terms", TERMS, "--out", str(out), "--no-progress",
                 "--noise", "white"]) == 3
    err = capsys.readouterr().err
    assert "axis z must not be used (exit 3); x, y may" in err and "axis z:" in err
    record = json.loads((out / "axes.json").read_text())["axes"]
    assert record["z"]["exit"] == 3 and record["x"]["exit"] == record["y"]["exit"] == 0
    assert all((out / axis / "fit.json").exists() for axis in "xyz")


@pytest.mark.parametrize(("args", "message"), [
    (["--axes", "x,q"], "has no gyro axis 'q' (its axes are x, y, z)"),
    (["--axes", ","], "name the axes"),
])
def test_bad_axes_are_refused_before_fitting(tmp_path, capsys, args, message):
    log = write_log(tmp_path / "imu.csv", _three_axis_log(3, n=50))
    assert main(["fit", *WHITE, str(log), "--terms", TERMS, "--out", str(tmp_path / "o"),
                 "--no-progress", *args]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_discrepancy_searches_each_axis(tmp_path):
    """Every axis's missing temperature effect found from the bias alone, in one command."""
    log = write_log(tmp_path / "imu.csv", _three_axis_log(4))
    out = tmp_path / "disc"
    assert main(["discrepancy", str(log), "--terms", "bias", "--out", str(out)]) in (0, 3)
    record = json.loads((out / "axes.json").read_text())
    assert list(record["axes"]) == ["x", "y", "z"]
    for axis in "xyz":
        assert "temperature" in json.loads((out / axis / "discrepancy.json").read_text()
                                           )["added"]


@pytest.mark.parametrize(("trusted", "says"), [
    ({"x": False, "y": False, "z": False}, "axes x, y, z must not be used (exit 3): none of"),
    ({"x": True, "y": False, "z": True}, "axis y must not be used (exit 3); x, z may"),
])
def test_the_multi_axis_verdict_names_the_axes_that_may_be_used(capsys, trusted, says):
    """Issue 43: 'axes x, y, z must not be used (exit 3); the others may' had been printed
    when there were no others."""
    from gyroid.cli.report import report_axes
    from gyroid.errors import UntrustworthyResult
    from gyroid.inference import Check, CheckReport
    from gyroid.pipeline._axes import PerAxis

    class Item:
        def __init__(self, ok: bool):
            self.checks = CheckReport((Check("fit", ok, "error", None, None, "a check"),))
            self.trustworthy = ok

    with pytest.raises(UntrustworthyResult):
        report_axes(PerAxis({axis: Item(ok) for axis, ok in trusted.items()}, {}))
    assert says in capsys.readouterr().err
