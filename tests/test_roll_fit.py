"""Fitting the roll loop to simulated flights."""

import json

import pytest

from gyroid.cli import main

pytestmark = pytest.mark.slow  # the whole module: end-to-end fits


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    root = tmp_path_factory.mktemp("roll")
    assert main(["roll", "simulate", "--out", str(root / "sim"), "--seed", "6",
                 "--duration", "30", "--period", "3"]) == 0
    assert main(["roll", "fit", str(root / "sim" / "roll.csv"), "--out", str(root / "fit"),
                 "--no-progress"]) == 0
    truth = json.loads((root / "sim" / "truth.json").read_text())
    return json.loads((root / "fit" / "roll_fit.json").read_text()), truth, root


def test_roll_fit_recovers_d1_and_the_encoder(fitted):
    fit, truth, root = fitted
    for name in ("D1", "D0", "D0gs", "Denc"):
        lo, hi = fit["parameters"][name]["ci95"]
        assert lo <= truth["parameters"][name] <= hi, (name, lo, hi)
    assert fit["parameters"]["D1"]["sd"] < 0.01 * truth["parameters"]["D1"]
    assert fit["gs_rate_used"] and fit["confounded"] == []
    assert (root / "fit" / "posterior.nc").exists() and (root / "fit" / "pair.png").exists()


def test_confounded_pairs_are_reported_without_the_stabiliser_rate(tmp_path, fitted):
    _, _, root = fitted
    text = (root / "sim" / "roll.csv").read_text().splitlines()
    header = text[1].split(",")
    keep = [i for i, name in enumerate(header) if name != "gs_rate_deg_s"]
    lines = [text[0]] + [",".join(line.split(",")[i] for i in keep) for line in text[1:]]
    (tmp_path / "no_rate.csv").write_text("\n".join(lines) + "\n")
    assert main(["roll", "fit", str(tmp_path / "no_rate.csv"), "--out", str(tmp_path / "fit"),
                 "--no-progress"]) == 0
    fit = json.loads((tmp_path / "fit" / "roll_fit.json").read_text())
    pairs = [set(item["parameters"]) for item in fit["confounded"]]
    assert {"D0", "D0gs"} in pairs
    assert "gs_rate_deg_s" in next(i["suggestion"] for i in fit["confounded"]
                                   if set(i["parameters"]) == {"D0", "D0gs"})
    # A pair without advice of its own names the advised pairs it follows from.
    for item in fit["confounded"]:
        for cause in item.get("follows_from", []):
            assert set(cause) in pairs and set(cause) & set(item["parameters"])
        assert item["suggestion"] != "vary the manoeuvre"


def test_a_bench_log_is_refused_as_a_roll_log(tmp_path):
    (tmp_path / "b.csv").write_text("time_s,drift_deg_h\n" + "\n".join(
        f"{i},0.1" for i in range(100)) + "\n")
    assert main(["roll", "fit", str(tmp_path / "b.csv"), "--out", str(tmp_path / "x")]) == 2
    assert not (tmp_path / "x").exists()
