"""Issue 13's input failures: each ends with one clear message (exit 2) or is read right;
vendors' columns and units through --map; wrapped encoder angles; gappy Allan deviation."""

import gzip

import numpy as np
import pytest
from helpers import SHORT_MAGNETIC, WHITE, write_log

from gyroid.cli import main
from gyroid.errors import GyroidInputError
from gyroid.io import load_bench_log, load_roll_log
from gyroid.simulation import FlightProfile, roll_log_text, simulate_flight, simulate_magnetic_bench
from gyroid.workflows import allan_deviation


@pytest.fixture(scope="module")
def magnetic_columns():
    return dict(simulate_magnetic_bench(seed=1, protocol=SHORT_MAGNETIC).log.columns)


@pytest.fixture(scope="module")
def roll_columns():
    sim = simulate_flight(profile=FlightProfile(duration_s=20.0, period_s=2.0), seed=2)
    return dict(sim.columns)


def _run(args, capsys):
    code = main(args)
    return code, capsys.readouterr().err


def test_unwritable_out_is_one_message(tmp_path, capsys, magnetic_columns):
    path = write_log(tmp_path / "bench.csv", magnetic_columns)
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    code, err = _run(["fit", *WHITE, str(path), "--terms", "magnetic", "--out",
                      str(blocker / "fit")], capsys)
    assert code == 2 and "cannot write there" in err and "internal error" not in err


def test_an_absurd_value_names_its_row(tmp_path, capsys, magnetic_columns):
    columns = {k: v.copy() for k, v in magnetic_columns.items()}
    columns["drift_deg_h"][9] = 1e300
    path = write_log(tmp_path / "bench.csv", columns)
    code, err = _run(["fit", *WHITE, str(path), "--terms", "magnetic", "--out",
                      str(tmp_path / "o")], capsys)
    assert code == 2 and "row 10" in err and "not a plausible value" in err
    assert not (tmp_path / "o").exists()


def test_semicolon_separated_with_decimal_commas_is_read(tmp_path, magnetic_columns):
    names = ["time_s", "drift_deg_h", "Hx_uT", "Hy_uT", "Hz_uT"]
    rows = [";".join(f"{magnetic_columns[n][i]:.6f}".replace(".", ",") for n in names)
            for i in range(magnetic_columns["time_s"].size)]
    path = tmp_path / "semicolon.csv"
    path.write_text("# exported by a vendor tool\n" + ";".join(names) + "\n" + "\n".join(rows))
    log = load_bench_log(path, "magnetic")
    np.testing.assert_allclose(log.drift_deg_h, magnetic_columns["drift_deg_h"], atol=1e-6)


def test_missing_drift_column_says_how_to_map_it(tmp_path, magnetic_columns):
    columns = dict(magnetic_columns)
    columns["gyro_x"] = columns.pop("drift_deg_h")
    path = write_log(tmp_path / "bench.csv", columns)
    with pytest.raises(GyroidInputError, match=r"always needs the measured drift.*--map "
                                               r"drift_deg_h="):
        load_bench_log(path, "magnetic")


def test_vendor_columns_and_units_through_map(tmp_path, magnetic_columns):
    deg_h_per_rad_s = 3600 * 180 / np.pi
    vendor = {"t_ms": magnetic_columns["time_s"] * 1000.0,
              "gyro_x": magnetic_columns["drift_deg_h"] / deg_h_per_rad_s,
              "mag_x": magnetic_columns["Hx_uT"] / 100.0,  # gauss
              "mag_y": magnetic_columns["Hy_uT"] * 1000.0,  # nT
              "mag_z": magnetic_columns["Hz_uT"] * 1e-6,  # T
              "temp": magnetic_columns["temperature_C"] + 273.15}
    path = write_log(tmp_path / "vendor.csv", vendor)
    out = tmp_path / "fit"
    assert main(["fit", *WHITE,
                 str(path), "--terms", "magnetic", "--out", str(out), "--no-progress",
                 "--map", "time_s=t_ms:ms", "--map", "drift_deg_h=gyro_x:rad/s",
                 "--map", "Hx_uT=mag_x:G", "--map", "Hy_uT=mag_y:nT",
                 "--map", "Hz_uT=mag_z:T", "--map", "temperature_C=temp:K"]) in (0, 3)
    from gyroid.io import parse_column_maps

    maps = parse_column_maps(["time_s=t_ms:ms", "drift_deg_h=gyro_x:rad/s", "Hx_uT=mag_x:G",
                              "Hy_uT=mag_y:nT", "Hz_uT=mag_z:T", "temperature_C=temp:K"])
    log = load_bench_log(path, "magnetic", column_map=maps)
    for name in ("time_s", "drift_deg_h", "Hx_uT", "Hy_uT", "Hz_uT", "temperature_C"):
        np.testing.assert_allclose(log.columns[name], magnetic_columns[name], rtol=1e-8,
                                   atol=1e-6)
    with pytest.raises(GyroidInputError, match="unknown unit 'furlong'"):
        parse_column_maps(["drift_deg_h=gyro_x:furlong"])


def test_each_command_names_the_other_for_the_wrong_log(tmp_path, capsys, magnetic_columns,
                                                        roll_columns):
    bench = write_log(tmp_path / "bench.csv", magnetic_columns)
    roll = tmp_path / "roll.csv"
    roll.write_text(roll_log_text(roll_columns))
    code, err = _run(["roll", "fit", str(bench), "--out", str(tmp_path / "r")], capsys)
    assert code == 2 and "use 'gyroid fit'" in err
    code, err = _run(["fit", *WHITE,
                      str(roll), "--terms", "magnetic", "--out", str(tmp_path / "b")],
                     capsys)
    assert code == 2 and "use 'gyroid roll fit'" in err


def test_gzip_log_is_read_by_the_cli(tmp_path, magnetic_columns):
    path = write_log(tmp_path / "bench.csv", magnetic_columns)
    packed = tmp_path / "bench.csv.gz"
    packed.write_bytes(gzip.compress(path.read_bytes()))
    assert load_bench_log(packed, "magnetic").n == magnetic_columns["time_s"].size


def test_wrapped_encoder_angle_is_unwrapped_with_a_note(tmp_path, roll_columns):
    plain = tmp_path / "plain.csv"
    plain.write_text(roll_log_text(roll_columns))
    wrapped_columns = dict(roll_columns)
    wrapped_columns["gs_angle_deg"] = np.mod(roll_columns["gs_angle_deg"], 360.0)
    wrapped = tmp_path / "wrapped.csv"
    wrapped.write_text(roll_log_text(wrapped_columns))
    reference = load_roll_log(plain)
    log = load_roll_log(wrapped)
    assert log.notes and "unwrapped" in log.notes[0]
    offset = log.gs_angle_deg[0] - reference.gs_angle_deg[0]
    np.testing.assert_allclose(log.gs_angle_deg - offset, reference.gs_angle_deg, atol=1e-6)
    assert abs(offset % 360.0) < 1e-6 or abs(offset % 360.0 - 360.0) < 1e-6


def test_an_encoder_jump_that_is_not_a_whole_turn_is_refused(tmp_path, roll_columns):
    columns = dict(roll_columns)
    angle = roll_columns["gs_angle_deg"].copy()
    angle[500:] -= 200.0
    columns["gs_angle_deg"] = angle
    path = tmp_path / "jump.csv"
    path.write_text(roll_log_text(columns))
    with pytest.raises(GyroidInputError, match=r"jumps by .* at row 501 .*not a whole turn"):
        load_roll_log(path)


def test_allan_deviation_of_a_burst_log_claims_no_tau_it_cannot_resolve():
    """Case 5: 5 s bursts at 50 Hz every 5 min of white noise. Pooled over bursts, the
    curve keeps slope -1/2 up to a quarter burst, and the bias instability is unresolved."""
    rng = np.random.default_rng(3)
    starts = np.arange(0.0, 6 * 3600.0, 300.0)
    time_s = (starts[:, None] + np.arange(250)[None, :] / 50.0).ravel()
    rate = 100.0 + 30.0 * rng.standard_normal(time_s.size)
    adev = allan_deviation(rate, 0.02, time_s=time_s)
    merit = adev.figures_of_merit()
    assert merit["segments"] == starts.size
    assert merit["tau_range_s"][1] <= 5.0 / 4 + 1e-9
    assert not merit["bias_instability_resolved"] and "gappy" in merit["note"]
    # White noise: sigma(tau) = s / sqrt(tau / tau0) at every resolved tau (5 % at tau0).
    expected = 30.0 / np.sqrt(adev.tau_s / 0.02)
    np.testing.assert_allclose(adev.adev_deg_h[:5], expected[:5], rtol=0.05)


def test_extra_column_terms_are_fitted_but_refused_where_they_cannot_apply(tmp_path, capsys):
    """fit --terms ...,extra:COLUMN works; compensate and propagate refuse such a fit with one
    message (its term is relative to the fitted log's own mean; a flight has no column)."""
    import numpy as np

    from gyroid.cli import main
    from gyroid.io import write_bench_log

    rng = np.random.default_rng(0)
    t = np.arange(0.0, 7200.0)
    pressure = 1.0 + 0.5 * np.sin(t / 600.0)
    columns = {"time_s": t, "drift_deg_h": 1.0 + 0.2 * pressure + 0.3 * rng.standard_normal(
        t.size), "pressure": pressure}
    write_bench_log(tmp_path / "log.csv", columns)
    assert main(["fit", *WHITE,
                 str(tmp_path / "log.csv"), "--terms", "bias,extra:pressure", "--out",
                 str(tmp_path / "fit"), "--no-progress"]) in (0, 3)
    fit = __import__("json").loads((tmp_path / "fit" / "fit.json").read_text())
    post = fit["posterior"]["w_extra_pressure"]
    assert abs(post["mean"] - 0.2) < 4 * post["sd"]
    assert main(["fit", *WHITE, str(tmp_path / "log.csv"), "--terms", "bias,extra:nope", "--out",
                 str(tmp_path / "f2")]) == 2
    capsys.readouterr()
    assert main(["compensate", str(tmp_path / "log.csv"), "--fit", str(tmp_path / "fit"),
                 "--out", str(tmp_path / "c")]) == 2
    assert "extra:pressure" in capsys.readouterr().err
    assert main(["propagate", str(tmp_path / "fit"), "--out", str(tmp_path / "p")]) == 2


def test_a_unit_that_is_not_its_columns_is_one_clear_error():
    """Converting a column from a unit it does not have names the column and its units."""
    from gyroid.io._units import converter

    np.testing.assert_allclose(converter("temperature_C", "K")(np.array([273.15])), [0.0])
    with pytest.raises(GyroidInputError, match=r"'furlong' is not a unit of temperature_C "
                                               r"\(units degC, C, K, degF, F\)"):
        converter("temperature_C", "furlong")
