"""Datasheets (issue 44, docs/formats.md section 6): every common unit to IEEE Std 952's
terms, the estimators' parameters with the derivation, and a measured unit's verdict
against its datasheet. Expected values are computed here by hand from the definitions."""

import json
import math

import numpy as np
import pytest
from helpers import write_log

from gyroid.allan import fit_noise
from gyroid.cli import main
from gyroid.io._datasheet import parse_quantity, read_datasheet
from gyroid.workflows._datasheet import convert_datasheet, spec_verdicts

RAD = math.pi / 180.0


@pytest.mark.parametrize("text", [
    "0.66 deg/sqrt(h)", "0.66 deg/rt(hr)", "39.6 deg/h/sqrt(Hz)", "0.011 deg/s/sqrt(Hz)",
    f"{0.011 * RAD!r} rad/s/sqrt(Hz)", "11 mdps/sqrt(Hz)", "0.011 deg/sqrt(s)"])
def test_the_same_angle_random_walk_in_any_unit_is_the_same_n(text):
    # 1 deg/sqrt(h) = 1 deg / (60 sqrt(s)): 0.011 deg/s/sqrt(Hz) = 0.011 deg/sqrt(s) = 0.66
    assert parse_quantity("arw", text).value == pytest.approx(0.66, rel=1e-12)


def test_bias_instability_and_rate_random_walk_units():
    assert parse_quantity("bias_instability", "0.007 deg/s").value == pytest.approx(25.2)
    assert parse_quantity("bias_instability", "7 mdps").value == pytest.approx(25.2)
    assert parse_quantity("bias_instability", f"{0.007 * RAD!r} rad/s").value == \
        pytest.approx(25.2)
    # 1 deg/s/sqrt(s) = 3600 deg/h per sqrt(h)/60 = 216 000 deg/h/sqrt(h)
    assert parse_quantity("rate_random_walk", "1e-5 deg/s/sqrt(s)").value == \
        pytest.approx(2.16)
    assert parse_quantity("rate_random_walk", f"{1e-5 * RAD!r} rad/s^2/sqrt(Hz)").value == \
        pytest.approx(2.16)


def _sheet(tmp_path, body: str):
    path = tmp_path / "gyro.toml"
    path.write_text("[gyro]\n" + body)
    return path


def test_a_datasheet_becomes_kalibr_parameters_with_the_derivation(tmp_path, capsys):
    path = _sheet(tmp_path, 'noise_density = "0.011 deg/s/sqrt(Hz)"\n'
                            'bias_instability = "14.5 deg/h"\n'
                            'rate_random_walk = "0.5 deg/h/sqrt(h)"\nrate = "200 Hz"\n')
    out = tmp_path / "kalibr"
    assert main(["datasheet", str(path), "--to", "kalibr", "--out", str(out)]) == 0
    text = (out / "imu.yaml").read_text()
    density = 0.011 * RAD  # rad/s/sqrt(Hz): a deg/s density is the same number in rad
    walk = 0.5 * RAD / 3600.0 / 60.0
    values = dict(line.split("#")[0].split(":", 1) for line in text.splitlines()
                  if line and not line.startswith("#"))
    assert float(values["gyroscope_noise_density"]) == pytest.approx(density, rel=1e-6)
    assert float(values["gyroscope_random_walk"]) == pytest.approx(walk, rel=1e-6)
    assert float(values["update_rate"]) == 200.0
    record = json.loads((out / "datasheet.json").read_text())
    assert record["datasheet"]["terms"]["N"]["value"] == pytest.approx(0.66)
    printed = capsys.readouterr().out
    assert "gyroscope_noise_density = N (pi/180) / 60" in printed
    assert f"{density * math.sqrt(200.0):.6e} rad/s per sample" in printed
    assert "no bias-instability term" in printed


def test_without_a_walk_the_datasheet_gets_one_that_bounds_its_flicker(tmp_path):
    sheet = read_datasheet(_sheet(tmp_path, 'arw = "0.3 deg/sqrt(h)"\n'
                                            'bias_instability = "10 deg/h"\n'))
    result = convert_datasheet(sheet, "openvins", horizon_s=400.0)
    k = 0.6643 * 10.0 * 60.0 * math.sqrt(3.0 / 400.0)  # Allan deviation K/60 sqrt(T/3)
    assert result.random_walk == pytest.approx(k * RAD / 3600.0 / 60.0, rel=1e-3)
    assert "400 s" in result.walk_from
    assert "# update_rate:" in result.file.text()  # no rate: left for the user, not invented


@pytest.mark.parametrize(("body", "says"), [
    ('arw = "0.3 deg/h"\n', "mdps/sqrt(hz)"),
    ('arw = 0.3\n', "give a number and a unit"),
    ('gyro_noise = "0.3 deg/sqrt(h)"\n', "is not a key gyroid reads"),
])
def test_a_bad_datasheet_gets_one_message_naming_the_key_and_the_units(tmp_path, capsys,
                                                                       body, says):
    path = _sheet(tmp_path, body)
    assert main(["datasheet", str(path), "--to", "json", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_a_measured_unit_is_judged_against_its_datasheet(tmp_path, capsys):
    rng = np.random.default_rng(9)
    dt, arw = 0.01, 0.5
    rate = rng.normal(0.0, 60.0 * arw / math.sqrt(dt), 100_000)
    fit = fit_noise(rate, dt)
    terms = fit.term_summaries()
    half = read_datasheet(_sheet(tmp_path, 'arw = "0.25 deg/sqrt(h)"\n'))
    same = read_datasheet(_sheet(tmp_path, 'arw = "0.5 deg/sqrt(h)"\n'
                                           'bias_instability = "100 deg/h"\n'))
    assert spec_verdicts(terms, half)["N"]["verdict"] == "above"  # twice its datasheet
    verdicts = spec_verdicts(terms, same)
    assert verdicts["N"]["verdict"] == "within"
    assert verdicts["B"]["verdict"] == "below"  # no flicker: under its bound
    log = write_log(tmp_path / "still.csv", {"time_s": dt * np.arange(rate.size),
                                             "drift_deg_h": rate})
    sheet = _sheet(tmp_path, 'arw = "0.25 deg/sqrt(h)"\n')
    assert main(["noise", str(log), "--datasheet", str(sheet), "--out",
                 str(tmp_path / "n")]) == 0
    spec = json.loads((tmp_path / "n" / "noise.json").read_text())["spec"]
    assert spec["N"]["verdict"] == "above" and spec["N"]["datasheet"] == 0.25
    assert "N against the datasheet's 0.25 deg/sqrt(h): above" in capsys.readouterr().out


def test_an_export_names_the_walk_that_bounds_the_flicker_its_model_leaves_out():
    """Issue 44: in place of a fixed 10-20x, the walk whose Allan deviation reaches the
    fitted flicker floor (at B's 95 % upper end) at 100 s, and the derivation written."""
    from gyroid.io._fitted import FittedNoise
    from gyroid.workflows._noise_export import axis_noise, export_noise

    terms = {"N": {"resolved": True, "mean": 0.5, "ci90": [0.49, 0.51]},
             "K": {"resolved": False, "mean": None, "upper_bound_95": 2.0},
             "B": {"resolved": True, "mean": 10.0, "ci90": [8.0, 12.0]}}
    tau = np.array([1.0, 10.0, 100.0])
    fitted = FittedNoise(terms, tau, np.array([30.0, 10.0, 8.0]), 0.01, True)
    axis = axis_noise(None, fitted)
    k = 0.6643 * 12.0 * 60.0 * math.sqrt(3.0 / 100.0)  # K/60 sqrt(100/3) = 0.664 B_top
    assert axis.flicker_walk == pytest.approx(k * RAD / 3600.0 / 60.0, rel=1e-3)
    result = export_noise({None: axis}, "kalibr", sample_s=0.01)
    text = result.text()
    assert "over-bounding the fitted flicker" in text and f"{axis.flicker_walk:.6e}" in text
    assert f"N (pi/180) / 60 = {0.5 * RAD / 60.0:.6e}" in text
    assert result.record["axes"]["x"]["flicker_walk"] == axis.flicker_walk


def _still_bench(tmp_path, arw: float, seed: int = 4):
    """A 2 h bench at 1 Hz of white noise only, the temperature moving (bias, w1 = 0.1)."""
    rng = np.random.default_rng(seed)
    time_s = np.arange(7200.0)
    temperature = 21.0 + 10.0 * np.sin(2.0 * math.pi * time_s / 7200.0)
    drift = 1.0 + 0.1 * (temperature - 21.0) + rng.normal(0.0, 60.0 * arw, time_s.size)
    return write_log(tmp_path / "bench.csv", {"time_s": time_s, "drift_deg_h": drift,
                                              "temperature_C": temperature})


@pytest.mark.slow
def test_a_datasheet_sets_the_noise_levels_priors_of_a_fit(tmp_path):
    """Contract section 7: ``gyroid fit --noise FILE.toml`` fits white + flicker + rate
    random walk, each level the datasheet gives a log-normal about its typical value (log-sd
    ln 2), a level it omits its default prior; fit.json's noise.priors_from names the file and
    each prior; a datasheet the log disagrees with (N a hundredth of the log's) fails
    prior_data_conflict, as any prior does."""
    log = _still_bench(tmp_path, arw=0.05)
    sheet = _sheet(tmp_path, 'noise_density = "0.05 deg/sqrt(h)"\n'
                             'bias_instability = "0.02 deg/h"\n')
    out = tmp_path / "fit"
    assert main(["fit", str(log), "--terms", "bias,temperature", "--noise", str(sheet),
                 "--out", str(out), "--no-progress"]) in (0, 3)
    record = json.loads((out / "fit.json").read_text())
    assert record["noise"]["model"] == "white+flicker+rw"
    given = record["noise"]["priors_from"]
    assert given["source"] == str(sheet)
    assert set(given["priors"]) == {"N_deg_sqrt_h", "B_deg_h"}  # K: the default prior
    for level, median in (("N_deg_sqrt_h", 0.05), ("B_deg_h", 0.02)):
        assert given["priors"][level] == record["priors"][level]
        assert f"median {median:g}" in given["priors"][level]
        assert f"log-sd {math.log(2.0):.6g}" in given["priors"][level]
    assert "datasheet" in record["noise_choice"]
    assert record["checks"]["prior_data_conflict"]["passed"]  # the log agrees with it
    wrong = _sheet(tmp_path, 'arw = "0.0005 deg/sqrt(h)"\n')
    assert main(["fit", str(log), "--terms", "bias,temperature", "--noise", str(wrong),
                 "--out", str(tmp_path / "wrong"), "--no-progress"]) in (0, 3)
    conflict = json.loads((tmp_path / "wrong" / "fit.json").read_text()
                          )["checks"]["prior_data_conflict"]
    assert not conflict["passed"] and "N_deg_sqrt_h" in conflict["message"]


def test_a_missing_or_bad_datasheet_is_one_message_before_any_log_is_read(tmp_path, capsys):
    log = _still_bench(tmp_path, arw=0.05)
    for sheet, says in ((tmp_path / "none.toml", "no such datasheet file"),
                        (_sheet(tmp_path, 'arw = "fast"\n'), "give a number and a unit")):
        assert main(["fit", str(log), "--terms", "bias", "--noise", str(sheet),
                     "--out", str(tmp_path / "fit")]) == 2
        assert says in capsys.readouterr().err
        assert not (tmp_path / "fit").exists()
