"""The discrepancy workflow on roll logs: paper B's overloaded stabiliser, found by hand in
the paper, is named from the data; every roll-side candidate is found when hidden; a clean
flight adds nothing."""

import json

import pytest

from gyroid.cli import main
from gyroid.io import RollLog
from gyroid.simulation import FlightProfile, roll_log_text, simulate_flight
from gyroid.workflows import find_roll_discrepancies

pytestmark = pytest.mark.slow  # the whole module: end-to-end fits

SHORT = FlightProfile(duration_s=40.0)


@pytest.mark.parametrize(
    ("hidden", "params", "profile"),
    [
        ("gs_rate_leak", {"D0": 0.0, "Denc": 0.0},
         FlightProfile(duration_s=40.0, gs_capacity_deg_s=2400.0)),
        ("roll_bias", {"Denc": 0.0}, SHORT),
        ("encoder_error", {"D0": 0.0}, SHORT),
        ("sf_nonlinearity", {"D0": 0.0, "Denc": 0.0, "D2": 2e-4}, SHORT),
    ],
)
def test_names_the_hidden_roll_effect(hidden, params, profile):
    flight = simulate_flight(params=params, profile=profile, seed=8)
    report = find_roll_discrepancies(RollLog.from_columns(flight.columns), "ideal")
    assert report.added == [hidden], report.steps
    assert report.rms_final <= report.rms_baseline
    # The same report as a bench log's, through the same loop.
    assert report.to_json()["log_kind"] == "roll" and report.steps[0].score > 20


def test_a_clean_flight_adds_nothing(tmp_path):
    sim = simulate_flight(params={"D0": 0.0, "Denc": 0.0}, profile=SHORT, seed=9)
    path = tmp_path / "roll.csv"
    path.write_text(roll_log_text(sim.columns))
    assert main(["discrepancy", str(path), "--terms", "ideal", "--out", str(tmp_path / "d")]) == 0
    report = json.loads((tmp_path / "d" / "discrepancy.json").read_text())
    assert report["added"] == [] and report["final_terms"] == report["baseline_terms"]
    assert (tmp_path / "d" / "discrepancy.png").exists()
    assert main(["discrepancy", str(path), "--terms", "thermal", "--out",
                 str(tmp_path / "e")]) == 2
