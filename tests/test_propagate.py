"""Propagation to dK: exact without uncertainty, delta method where it holds, the CLI."""

import json
from dataclasses import replace

import numpy as np
import pytest
from helpers import WHITE

from gyroid.cli import main
from gyroid.io import FittedDrift
from gyroid.models import DriftModel, RollParams, constant_flight, run_loop
from gyroid.models import _paper_b as pb
from gyroid.workflows import SCENARIOS as PRESETS
from gyroid.workflows import load_scenario, propagate

CERTAIN = replace(PRESETS["paper_b_worked"], uncompensated_sd_deg_s=0.0, mems_sf_error_sd=0.0,
                  mems_bias_sd_deg_h=0.0, encoder_deg=0.0, encoder_phase="0.0",
                  sample_s=0.05)


def _quiet_gyro(n_draws=50, spread=0.0, seed=0):
    rng = np.random.default_rng(seed)
    model = DriftModel.from_terms("thermal")
    draws = np.zeros((n_draws, 4)) + spread * rng.standard_normal((n_draws, 4)) * [1, 0.01, 1e-4,
                                                                                   0.1]
    return FittedDrift(model=model, draws=draws, t0_C=21.0)


@pytest.mark.slow
def test_without_uncertainty_dk_is_eq7_and_the_loop():
    result = propagate(_quiet_gyro(), CERTAIN, draws=20, sobol_n=20)
    samples = result.samples
    eq7 = pb.dk_overloaded(12.2 / 3600, 280e-6, 300.0, 0.0, 900.0, 5.0)
    np.testing.assert_allclose(samples["dK"], eq7, rtol=1e-9)
    assert result.dk["sd"] == pytest.approx(0.0, abs=1e-15)
    assert result.to_json()["closed_form"]["dK_eq7"] == pytest.approx(eq7, rel=1e-12)
    loop = run_loop(RollParams(D0=0.0, D0gs=12.2 / 3600, Denc=0.0),
                    constant_flight(900.0, 120.0, sample_s=0.05, uncompensated_deg_s=300.0))
    np.testing.assert_allclose(samples["dK"], float(loop.dK[0]), rtol=1e-9)


def test_monte_carlo_agrees_with_the_delta_method_where_it_should():
    # dK is bilinear in (w_H, D1gs) and linear in D0gs: with 3-8 % spreads (and w_H far
    # below the MEMS saturation, where dK jumps) the first-order
    # estimate is accurate. MC se of the mean: sd / sqrt(N); of the sd: sd / sqrt(2 N).
    scenario = replace(CERTAIN, uncompensated_deg_s=250.0, uncompensated_sd_deg_s=10.0,
                       mems_sf_error_sd=10e-6,
                       mems_bias_sd_deg_h=1.0)
    n = 4000
    result = propagate(_quiet_gyro(), scenario, draws=n, sobol_n=200, seed=3)
    mc, delta = result.dk, result.delta_method
    assert mc["mean"] == pytest.approx(delta["mean"], abs=4 * mc["sd"] / np.sqrt(n))
    assert mc["sd"] == pytest.approx(delta["sd"], rel=4 / np.sqrt(2 * n))
    # Where it should not hold: the encoder-error phase, uniform on the circle, is far from
    # linear; the delta method (which leaves it out) misses most of dK's spread.
    with_encoder = replace(scenario, encoder_deg=0.33, encoder_phase="uniform")
    summary = propagate(_quiet_gyro(), with_encoder, draws=n, sobol_n=500, seed=4).to_json()
    assert summary["dK"]["sd"] > 3 * summary["delta_method"]["sd"]
    assert summary["drivers_total"]["encoder error"] > 0.5


def test_scenario_files_and_bad_scenarios(tmp_path):
    path = tmp_path / "fast.toml"
    path.write_text('roll_rate_deg_s = 1800.0\nperiod_s = 2.0\nfitted_gyro_role = "stabiliser"\n')
    scenario = load_scenario(str(path))
    assert scenario.roll_rate_deg_s == 1800.0 and scenario.fitted_gyro_role == "stabiliser"
    bad = tmp_path / "bad.json"
    bad.write_text('{"roll_rate": 5}')
    from gyroid.errors import GyroidInputError

    with pytest.raises(GyroidInputError, match="unknown scenario key 'roll_rate'"):
        load_scenario(str(bad))
    with pytest.raises(GyroidInputError, match="neither a preset"):
        load_scenario("no_such_scenario")


@pytest.mark.slow
def test_cli_propagates_a_fitted_bench(tmp_path):
    sim, fit, out = tmp_path / "sim", tmp_path / "fit", tmp_path / "prop"
    assert main(["simulate", "thermal", "--out", str(sim), "--seed", "2"]) == 0
    assert main(["fit", *WHITE, str(sim / "bench.csv"), "--terms", "thermal", "--out", str(fit),
                 "--no-progress"]) == 0
    assert main(["propagate", str(fit), "--out", str(out), "--draws", "500"]) == 0
    data = json.loads((out / "propagate.json").read_text())
    assert data["draws"] == 500 and data["scenario"]["roll_rate_deg_s"] == 900.0
    assert set(data["dK"]) == {"mean", "sd", "ci95"}
    assert set(data["dpsi_deg"]) == {"10", "60", "120"} == set(data["dr_z_m"])
    assert set(data["drivers"]) >= {"fitted drift coefficients", "encoder error",
                                    "uncompensated rate", "stabiliser SF error"}
    assert abs(data["dK"]["mean"]) < 1e-3
    assert (out / "dk_distribution.png").exists() and (out / "drivers.png").exists()
    assert main(["propagate", str(tmp_path), "--out", str(tmp_path / "x")]) == 2
    # drivers: shares of the variance with interactions counted, summing to 1, and the
    # encoder error (which acts only with the period's end phase) is not shown as zero.
    assert sum(data["drivers"].values()) == pytest.approx(1.0)
    assert data["drivers"]["encoder error"] > 0.2 > data["drivers_first_order"]["encoder error"]
    assert "encoder error" in data["interactions"]["involving"]
    assert data["trustworthy"] and data["checks"]["fit_trustworthy"]["passed"]
    # A fit marked untrustworthy makes its propagation untrustworthy: exit 3.
    fit_json = json.loads((fit / "fit.json").read_text())
    (fit / "fit.json").write_text(json.dumps({**fit_json, "trustworthy": False}))
    assert main(["propagate", str(fit), "--out", str(tmp_path / "p2"), "--draws", "100"]) == 3
    assert not json.loads((tmp_path / "p2" / "propagate.json").read_text())["trustworthy"]
