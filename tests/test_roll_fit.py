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


def test_intervals_cover_the_truth_over_many_flights(tmp_path):
    """20 short flights (30 s, a 3 s correction period; seeds 100-119) fitted with the
    default sampler (importance sampling of every parameter, emcee where its weights fail):
    each loop parameter's and noise level's 95 % interval holds the simulator's truth at a
    rate inside the binomial band of 20 draws at 0.95 (99 % two-sided), and importance
    sampling served at least 18 of the 20."""
    from scipy import stats

    from gyroid.inference import fit
    from gyroid.io import load_roll_log
    from gyroid.roll._problem import RollProblem
    from gyroid.simulation import FlightProfile, roll_log_text, simulate_flight
    from gyroid.simulation._flight import PAPER_B_PARAMS

    profile = FlightProfile(duration_s=30.0, period_s=3.0)
    truth = {"D1": PAPER_B_PARAMS["D1"], "D0": PAPER_B_PARAMS["D0"],
             "D0gs": PAPER_B_PARAMS["D0gs"], "sigma_gs_deg": profile.gs_noise_deg,
             "sigma_sins_deg_s": profile.sins_noise_deg_s,
             "sigma_m_deg_s": profile.mems_noise_deg_s}
    inside = dict.fromkeys(truth, 0)
    by_importance = 0
    for seed in range(100, 120):
        path = tmp_path / f"roll_{seed}.csv"
        path.write_text(roll_log_text(simulate_flight(seed=seed, profile=profile).columns))
        result = fit(RollProblem.from_log(load_roll_log(path)), seed=seed)
        by_importance += result.sampled.move == "psis"
        for name, value in truth.items():
            lo, hi = result.sampled.summary[name]["ci95"]
            inside[name] += lo <= value <= hi
    low = stats.binom.ppf(0.005, 20, 0.95)
    assert all(count >= low for count in inside.values()), (inside, low)
    assert by_importance >= 18, by_importance
