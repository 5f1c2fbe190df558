"""The discrepancy workflow on causes other than a hidden catalogued effect: outside the
catalogue, in unlisted columns, on fast logs, heating and cooling, orientations, several
axes; its command's JSON and where it looks (split from tests/test_discrepancy.py so that
two test workers share the searches)."""

import json

import numpy as np
import pytest
from helpers import check_report

from gyroid.cli import main
from gyroid.simulation import ThermalProtocol, simulate_magnetic_bench, simulate_thermal_bench
from gyroid.workflows import find_discrepancies

pytestmark = pytest.mark.slow  # the whole module: end-to-end searches


WARMUP = {"w_warmup": 1.0, "tau_warmup_min": 20.0}


def test_cli_writes_the_contract_json(tmp_path):
    out = tmp_path / "sim"
    assert main(["simulate", "magnetic", "--out", str(out), "--seed", "15",
                 "--effect", "warmup:w_warmup=0.8,tau_warmup_min=10"]) == 0
    disc = tmp_path / "disc"
    assert main(["discrepancy", str(out / "bench.csv"), "--terms", "magnetic",
                 "--out", str(disc)]) == 0
    data = json.loads((disc / "discrepancy.json").read_text())
    assert data["added"] == ["warmup"] and data["unexplained"] is None
    assert data["trustworthy"] is True
    assert data["baseline_terms"] == ["bias", "magnetic_x", "magnetic_y", "magnetic_z"]
    assert data["final_terms"] == [*data["baseline_terms"], "warmup"]
    assert data["rms_final_deg_h"] <= data["rms_baseline_deg_h"]
    step = data["steps"][0]
    assert set(step) >= {"effect", "evidence", "rms_before_deg_h", "rms_after_deg_h", "score"}
    assert (disc / "discrepancy.png").exists()


def test_where_reports_whole_windows_only():
    """The last samples of a log join the last window: no window of a few samples at the end
    (whose mean is mostly noise) can top the list."""
    from gyroid.workflows import where_largest as _where
    from gyroid.workflows._discrepancy_report import NoiseLevels

    sim = simulate_magnetic_bench(seed=3)
    log = sim.log
    residual = sim.log.drift_deg_h - sim.true_drift_deg_h
    rows = _where(log.time_s, residual, log.inputs(), NoiseLevels(0.3, 1e-6, 300.0), log,
                  top=50)
    span = log.time_s[-1] - log.time_s[0]
    window = max(span / 40.0, 60.0)
    (tail,) = [r for r in rows if r["end_s"] == log.time_s[-1]]
    assert tail["end_s"] - tail["start_s"] >= window - 2 * np.median(np.diff(log.time_s))
    assert all(abs(r["z"]) < 5 for r in rows)  # pure noise: standardised means stay small


def test_a_step_outside_the_catalogue_is_reported_unexplained():
    """Without bias_step among the candidates, a 0.4 deg/h step is soaked up by the noise
    model, whose correlation time then exceeds bias instability's: reported, never 'nothing
    missing'."""
    from gyroid.models import CANDIDATES

    sim = simulate_thermal_bench(seed=5, effects={"bias_step": {"w_step": 0.4,
                                                                "t_step_h": 5.0}})
    report = find_discrepancies(sim.log, "thermal",
                                candidates=tuple(c for c in CANDIDATES if c != "bias_step"))
    assert report.unexplained is not None
    assert report.unexplained.noise_too_slow or report.unexplained.score > 10


def _pressure_log(tmp_path):
    """A thermal bench whose drift also follows a logged chamber pressure (a two-hour
    oscillation, 0.1 deg/h rms), with a supply voltage that does nothing."""
    from gyroid.io import write_bench_log

    sim = simulate_thermal_bench(seed=7)
    columns = dict(sim.log.columns)
    t = columns["time_s"]
    rng = np.random.default_rng(1)
    pressure = 1e-3 * (1 + 0.5 * np.sin(2 * np.pi * t / 7000.0)) + 1e-5 * rng.standard_normal(
        t.size)
    columns["drift_deg_h"] = columns["drift_deg_h"] + 300.0 * (pressure - pressure.mean())
    columns["pressure_mbar"] = pressure
    columns["supply_V"] = 28.0 + 0.05 * rng.standard_normal(t.size)
    path = tmp_path / "pressure.csv"
    write_bench_log(path, columns)
    return path


def test_a_cause_in_an_unlisted_column_is_unexplained_then_found_with_extra_columns(tmp_path):
    path = _pressure_log(tmp_path)
    assert main(["discrepancy", str(path), "--terms", "thermal", "--out",
                 str(tmp_path / "off")]) == 0
    off = json.loads((tmp_path / "off" / "discrepancy.json").read_text())
    assert off["added"] == [] and off["unexplained"]["score"] > 10
    assert main(["discrepancy", str(path), "--terms", "thermal", "--out", str(tmp_path / "on"),
                 "--extra-columns"]) == 0
    on = json.loads((tmp_path / "on" / "discrepancy.json").read_text())
    assert on["added"] == ["extra:pressure_mbar"] and on["unexplained"] is None
    assert on["steps"][0]["regressor"] == "pressure_mbar"


FAST = ThermalProtocol(setpoints_C=(31.0, 40.0, 55.0), soak_min=40.0, sample_s=0.1)


@pytest.mark.parametrize("hidden", [None, "warmup"])
def test_a_fast_log_is_searched_on_means_with_the_samples_noise_and_penalty(hidden):
    # 10 Hz for 5.3 h (190 000 rows): searched on 10-sample means (it took 143 s at 10^6
    # rows sample by sample). The hidden effect is still named, the null stays quiet, and
    # the noise is reported per sample.
    effects = {"warmup": WARMUP} if hidden else None
    sim = simulate_thermal_bench(seed=12, protocol=FAST, effects=effects)
    report = find_discrepancies(sim.log, "thermal")
    check_report(report, [hidden] if hidden else [])
    assert report.rms_unit == "deg/h (of 10-sample means)"
    assert report.residual_before.size == sim.log.n // 10
    white = sim.truth["noise"]["white_sd_deg_h"]
    assert report.noise.white == pytest.approx(white, rel=0.05)  # ~0.2 % sampling error


def test_thermal_hysteresis_is_named_on_a_heating_and_cooling_log():
    """A bias that differs warming and cooling (issue 43's cool-down -> warm-up split): the
    search names thermal_hysteresis, not a lag, a trend or a step."""
    protocol = ThermalProtocol(setpoints_C=(35.0, 50.0), return_to_lab=True, sample_s=5.0)
    sim = simulate_thermal_bench(protocol=protocol, seed=2,
                                 effects={"thermal_hysteresis": {"w_hys": 0.3}})
    report = find_discrepancies(sim.log, "thermal")
    check_report(report, ["thermal_hysteresis"])
    assert report.steps[0].values["w_hys"] == pytest.approx(0.3, abs=0.08)


def test_g_sensitivity_is_found_from_the_bias_alone():
    from gyroid.simulation import OverloadProtocol, simulate_overload_bench

    sim = simulate_overload_bench(seed=8, protocol=OverloadProtocol(dwell_min=15.0))
    report = find_discrepancies(sim.log, "bias")
    assert sorted(report.added) == ["overload_x", "overload_y", "overload_z"]
    assert report.unexplained is None


def test_a_step_on_two_axes_at_once_is_named_as_shared(tmp_path, capsys):
    """Issue 43: x steps by 1 deg/h at 2 h, z by 0.4 deg/h at the same time, y not at all:
    the searches are per axis, the step is named as one cause on x and z."""
    from helpers import SHORT_THERMAL, write_log

    sims = [simulate_thermal_bench(seed=30 + k, protocol=SHORT_THERMAL) for k in range(3)]
    columns = dict(sims[0].log.columns)
    del columns["drift_deg_h"]
    elapsed_h = (columns["time_s"] - columns["time_s"][0]) / 3600.0
    for k, (axis, size) in enumerate((("x", 1.0), ("y", 0.0), ("z", 0.4))):
        columns[f"drift_{axis}_deg_h"] = (sims[k].log.columns["drift_deg_h"]
                                          + size * (elapsed_h >= 2.0))
    path = write_log(tmp_path / "three.csv", columns)
    code = main(["discrepancy", str(path), "--terms", "thermal", "--out",
                 str(tmp_path / "disc")])
    out = capsys.readouterr().out
    assert code in (0, 3)
    axes = json.loads((tmp_path / "disc" / "axes.json").read_text())
    steps = [c for c in axes["shared"] if c["cause"] == "bias_step"]
    assert len(steps) == 1 and steps[0]["axes"] == ["x", "z"], axes["shared"]
    assert steps[0]["time_h"] == pytest.approx(2.0, abs=0.05)
    assert steps[0]["sizes_deg_h"]["z"] == pytest.approx(0.4, abs=0.12)
    assert "shared: a bias step at" in out
