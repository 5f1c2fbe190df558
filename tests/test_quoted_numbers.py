"""Every number the README quotes from a study is the one its results file holds: each test
writes the README's phrase from `experiments/results/NAME/results.json` (which the named
command writes) and finds it in the README, so a re-run that changes a number, or an edit
of the README that drifts from the file, fails here. Times are excepted (they are stated
with their machine and load, and change from run to run)."""

import json
import re
from pathlib import Path

import pytest
from scipy import stats

ROOT = Path(__file__).parent.parent
README = re.sub(r"\s+", " ", (ROOT / "README.md").read_text())


def _results(name: str) -> dict:
    return json.loads((ROOT / "experiments" / "results" / name / "results.json").read_text()
                      )["results"]


def _quoted(*phrases: str) -> None:
    missing = [p for p in phrases if p not in README]
    assert not missing, f"the README does not say what the results file holds: {missing}"


def test_sbc_of_the_bench_fits():
    cases = _results("sbc").values()
    names = [{k: v for k, v in case.items() if k != "trustworthy_fraction"} for case in cases]
    ks = min(p["ks_pvalue"] for case in names for p in case.values())
    cover = [p["coverage"]["90%"] for case in names for p in case.values()]
    assert ks > 0.2 and all(case["trustworthy_fraction"] == 1.0 for case in cases)
    _quoted("rank histogram is uniform (KS p > 0.2)",
            f"cover the truth {100 * min(cover):.3g}-{100 * max(cover):.3g} % of the time",
            f"all {200 * len(names)} fits call themselves trustworthy")


def test_sbc_of_the_pooled_lots():
    for key, lot in _results("pool_sbc").items():
        runs = key.removeprefix("lot_")
        mean = lot["mean"]["coverage"]["0.9"]
        sd = lot["between_sd"]["coverage"]["0.9"]
        band = "({:.3f}-{:.3f})".format(*mean["band99"])
        _quoted(f"| {runs} | {lot['datasets']} | {mean['observed']:.3f} {band} | "
                f"{sd['observed']:.3f} {band} | {lot['seconds_median']:.2g} | "
                f"{lot['trustworthy']} of {lot['datasets']} |")


def test_the_discrepancy_study_beyond_the_catalogue():
    runs = _results("discrepancy_beyond_catalogue")["runs"]

    def count(case: str, test) -> str:
        return f"{sum(bool(test(r)) for r in runs[case])} of {len(runs[case])}"

    _quoted(f"`bias_step`, {count('step (catalogued)', lambda r: r['added'] == ['bias_step'])}",
            f"`unexplained`, {count('step (not catalogued)', lambda r: r['unexplained'])} "
            "(noise time constant at its cap)",
            f"`extra:pressure_mbar`, {count('pressure, --extra-columns on', lambda r: r['added'] == ['extra:pressure_mbar'])}, nothing else",  # noqa: E501
            f"| 2.5 h sinusoid, 0.15 deg/h (4) | `unexplained`, "
            f"{count('sinusoid 2.5 h', lambda r: r['unexplained'])} |")
    assert all(r["tau_at_cap"] for r in runs["step (not catalogued)"])
    assert all(r["unexplained"] for r in runs["pressure, --extra-columns off"])
    nulls = [r for case, rs in runs.items() if case.startswith("null") for r in rs]
    quiet = sum(not r["added"] and not r["unexplained"] for r in nulls)
    _quoted(f"nothing added, nothing unexplained: {quiet} of {len(nulls)}")
    daily = runs["sinusoid 24 h"]
    cubic = sum(set(r["added"]) == {"warmup", "temperature_cubic"} for r in daily)
    trend = sum(set(r["added"]) == {"warmup", "time_trend"} for r in daily)
    _quoted(f"`warmup` + `temperature_cubic` ({cubic}) or `time_trend` ({trend})")
    assert cubic + trend == len(daily) and all(r["called_stand_in"] for r in daily)


def test_the_mems_thermal_benches_under_ieee_noise():
    """IEEE 952's noise: the trusted fits' 95 % intervals cover the truths at the nominal
    rate (inside the binomial 99 % band), the refusals quoted as they are."""
    counts = _results("mems_thermal_bench_ieee")["per_noise"]["white+flicker+rw"]
    trusted = counts["fits"] - counts["refused"]
    inside, total = counts["coefficients_inside_95"]
    _quoted(f"`--noise white+flicker+rw` trusted {trusted} of {counts['fits']} fits and "
            f"refused {counts['refused']} ",
            f"{inside} of the {total} trusted coefficients lie inside their 95 % intervals")
    assert stats.binom(total, 0.95).ppf(0.005) <= inside <= stats.binom(total, 0.95).ppf(0.995)


@pytest.mark.parametrize("noise", ["white", "white+gm"])
def test_the_mems_thermal_benches(noise):
    results = _results("mems_thermal_bench")
    counts = results["per_noise"][noise]
    _quoted(f"`--noise {noise}` refused {counts['refused']} of {counts['fits']}")
    assert results["silent_wrong"] == 0
    if noise == "white+gm":
        worst = max(abs(z) for r in results["runs"] if r["noise"] == noise
                    for z in r["z"].values())
        _quoted(f"its coefficients were up to {worst:.0f} sd from the truths")
