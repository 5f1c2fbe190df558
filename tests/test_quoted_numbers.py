"""Every number the documentation (the README and docs/*.md, read as one text) quotes from
a study is the one its results file holds: each test writes the phrase from
`experiments/results/NAME/results.json` (which the named command writes) and finds it in
the documentation, so a re-run that changes a number, or an edit that drifts from the
file, fails here. Times are excepted (they are stated
with their machine and load, and change from run to run)."""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

ROOT = Path(__file__).parent.parent
README = re.sub(r"\s+", " ", " ".join(
    path.read_text() for path in (ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")))))


def _results(name: str) -> dict:
    return json.loads((ROOT / "experiments" / "results" / name / "results.json").read_text()
                      )["results"]


def _quoted(*phrases: str) -> None:
    missing = [p for p in phrases if p not in README]
    assert not missing, f"the documentation does not say what its results file holds: {missing}"


def test_sbc_of_the_bench_fits():
    """Uniform ranks for every coefficient: the smallest of their KS p-values above 1 % over
    their number (Bonferroni: a calibrated sampler fails this one run in a hundred; the
    smallest of 13 uniform p-values lies below 0.2 most runs, so the observed smallest is
    quoted, not asserted). The data are each model's own, so a fit called untrustworthy is
    a check's false alarm: only the predictive check's (family rate
    :data:`~gyroid.inference._predictive.PREDICTIVE_P`), as often as its binomial 99.9 %
    bound allows."""
    from scipy import stats

    from gyroid.inference._predictive import PREDICTIVE_P

    results = _results("sbc")
    cases = results.values()
    extra = ("trustworthy_fraction", "untrusted_by")
    names = [{k: v for k, v in case.items() if k not in extra} for case in cases]
    coefficients = [p for case in names for k, p in case.items() if k != "sigma_deg_h"]
    ks = min(p["ks_pvalue"] for p in coefficients)
    cover = [p["coverage"]["90%"] for case in names for p in case.values()]
    assert ks > 0.01 / len(coefficients)
    fits = 200 * len(names)
    untrusted = round(sum(200 * (1 - case["trustworthy_fraction"]) for case in cases))
    alarms = {name for case in cases for name in case["untrusted_by"]}
    assert alarms <= {"predictive"}
    assert untrusted <= stats.binom.ppf(0.999, fits, PREDICTIVE_P)
    sigma = results["thermal_sampled_sigma"]["sigma_deg_h"]
    assert sigma["ks_pvalue"] > 0.01  # the thermometer carried, sigma calibrated as well
    _quoted(f"every coefficient's rank histogram is uniform (KS p >= {_floor(ks, 2)})",
            f"cover the truth {100 * min(cover):.3g}-{100 * max(cover):.3g} % of the time",
            f"{fits - untrusted} of the {fits} fits call themselves trustworthy",
            f"`sigma_deg_h` is calibrated too (KS p {sigma['ks_pvalue']:.2g}, mean rank "
            f"{_sigma_mean_rank():.2f}, 90 % coverage {100 * sigma['coverage']['90%']:.3g} %)")


def _floor(value: float, digits: int) -> str:
    """``value`` rounded down to ``digits`` decimals, as text (a quoted lower bound)."""
    import math

    return f"{math.floor(value * 10**digits) / 10**digits:.{digits}f}"


def _sigma_mean_rank() -> float:
    import numpy as np

    ranks = np.load(ROOT / "experiments" / "results" / "sbc" / "ranks.npz")
    return float(ranks["thermal_sampled_sigma:sigma_deg_h"].mean())


def test_sbc_of_the_pooled_lots():
    for key, lot in _results("pool_sbc").items():
        runs = key.removeprefix("lot_")
        mean = lot["mean"]["coverage"]["0.9"]
        sd = lot["between_sd"]["coverage"]["0.9"]
        band = "({:.3f}-{:.3f})".format(*mean["band99"])
        _quoted(f"| {runs} | {lot['datasets']} | {mean['observed']:.3f} {band} | "
                f"{sd['observed']:.3f} {band} | {lot['seconds_median']:.2g} | "
                f"{lot['trustworthy']} of {lot['datasets']} |")


def test_the_discrepancy_power_study():
    path = ROOT / "experiments" / "results" / "discrepancy_power" / "results.json"
    seeds = json.loads(path.read_text())["config"]["seeds_per_point"]
    results = _results("discrepancy_power")
    rows = [r for effect in results["detection"].values() for r in effect]
    detections = sum(round(r["exact_detection_rate"] * seeds) for r in rows)
    extra = sum(round(r["found_with_extra_rate"] * seeds) for r in rows)
    nulls = 2 * seeds * len(results["false_positive"])
    gained = sum(round(rate * 2 * seeds) for rate in results["false_positive"].values())
    _quoted(f"{seeds} seeds per point",
            f"{'none' if extra == 0 else extra} of the {detections} detections brought a "
            "second, spurious effect",
            f"{'none' if gained == 0 else gained} of the {nulls} null logs gained anything")


def test_the_discrepancy_study_beyond_the_catalogue():
    runs = _results("discrepancy_beyond_catalogue")["runs"]

    def count(case: str, test) -> str:
        return f"{sum(bool(test(r)) for r in runs[case])} of {len(runs[case])}"

    _quoted(f"`bias_step`, {count('step (catalogued)', lambda r: r['added'] == ['bias_step'])}",
            f"`unexplained`, {count('step (not catalogued)', lambda r: r['unexplained'])} "
            "(noise slower than bias instability)",
            f"`extra:pressure_mbar`, {count('pressure, --extra-columns on', lambda r: r['added'] == ['extra:pressure_mbar'])}, nothing else",  # noqa: E501
            f"| 2.5 h sinusoid, 0.15 deg/h (4) | `unexplained`, "
            f"{count('sinusoid 2.5 h', lambda r: r['unexplained'])} |")
    assert all(r["noise_too_slow"] for r in runs["step (not catalogued)"])
    assert all(r["unexplained"] for r in runs["pressure, --extra-columns off"])
    nulls = [r for case, rs in runs.items() if case.startswith("null") for r in rs]
    quiet = sum(not r["added"] and not r["unexplained"] for r in nulls)
    _quoted(f"nothing added, nothing unexplained: {quiet} of {len(nulls)}")
    daily = runs["sinusoid 24 h"]
    unexplained = sum(r["unexplained"] and not r["added"] for r in daily)
    cubic = sum(set(r["added"]) == {"warmup", "temperature_cubic"} for r in daily)
    trend = sum(set(r["added"]) == {"warmup", "time_trend"} for r in daily)
    _quoted(f"`unexplained` ({unexplained}), or `warmup` + `temperature_cubic` ({cubic}) or "
            f"`time_trend` ({trend})")
    assert unexplained + cubic + trend == len(daily)
    assert all(r["called_stand_in"] for r in daily if r["added"])


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


def test_the_mems_thermal_benches_rechecked():
    """The same benches re-run with the default's levels explored beside white+gm's: the
    fits whose truths lie outside their intervals warn with a range over both noise models
    that holds every truth (no silent wrong answer), as the docs say."""
    results = _results("mems_thermal_bench_recheck")
    white, gm = results["per_noise"]["white"], results["per_noise"]["white+gm"]
    runs = [r for r in results["runs"] if r["noise"] == "white+gm"]
    missed = sum(r["trustworthy"] and not all(r["inside_95"].values()) for r in runs)
    in_range = sum(sum(r["inside_range"].values()) for r in runs)
    gains = [r["other_noise_model"]["log_likelihood_gain"] for r in runs]
    worst = max(abs(z) for r in runs if r["trustworthy"] for z in r["z"].values())
    _quoted(f"a truth outside its 95 % interval, up to {worst:.1f} sd, every check passing",
            f"`--noise white+gm` refused {gm['refused']} of {gm['fits']}, "
            f"{missed} of {gm['fits']} still had a truth outside its 95 % interval, and "
            f"{gm['warned_range_holds_truths']} of {gm['fits']} warned",
            f"better by {min(gains):.1f}-{max(gains):.1f} nats",
            f"holds {in_range} of the {4 * len(runs)} truths: "
            f"{results['silent_wrong']} silent wrong answers",
            f"`--noise white` still refused {white['refused']} of {white['fits']}")
    assert results["silent_wrong"] == 0 and in_range == 4 * len(runs)
    assert all(g > 0 for g in gains)


def test_the_noise_fits_against_the_allan_readings():
    """gyroid noise on six grades: every interval and bound covers at its nominal rate (in
    its binomial band), the filtered phone log's N too; the docs state the flicker and the
    bumps it reads where there are none, and each error comparison they state holds in the
    file."""
    grades = _results("noise_coverage")["summary"]
    terms = {g: v["terms"] for g, v in grades.items()}
    for grade, per_term in terms.items():
        for name, entry in per_term.items():
            for key in ("ci90", "upper_bound"):
                low, high = entry[f"{key}_band_99"]
                assert low <= entry[f"{key}_inside"] <= high, (grade, name, key)
    gm = terms["gm"]
    _quoted(f"gyroid trusts {grades['gm']['trustworthy']} of {grades['gm']['datasets']} and "
            f"holds N ({gm['N']['ci90_inside']} of {gm['N']['resolved']}), K "
            f"({gm['K']['ci90_inside']} of {gm['K']['resolved']} intervals, "
            f"{gm['K']['upper_bound_inside']} of {grades['gm']['datasets'] - gm['K']['resolved']}"
            f" bounds) and G ({gm['G']['ci90_inside']} of {gm['G']['resolved']} intervals, "
            f"{gm['G']['upper_bound_inside']} of "
            f"{grades['gm']['datasets'] - gm['G']['resolved']} bounds)",
            f"{grades['gm']['false_detections']['B']} of the {grades['gm']['datasets']} logs "
            "report a bias instability B",
            f"in all but {grades['gm']['false_detections_excluding_zero']['B']} of them B's 90 %"
            " interval reaches zero",
            f"(with an interval that excludes zero in "
            f"{grades['mems']['false_detections_excluding_zero']['G']} and "
            f"{grades['phone']['false_detections_excluding_zero']['G']} of them)",
            "A noise fit takes " + "-".join(f"{v:.2f}" for v in (
                min(g["fit_seconds_median"] for g in grades.values()),
                max(g["fit_seconds_median"] for g in grades.values()))) + " s per log",
            f"G is reported for {grades['mems']['false_detections']['G']} of the "
            f"{grades['mems']['datasets']} MEMS logs and {grades['phone']['false_detections']['G']}"
            f" of the {grades['phone']['datasets']} phone logs")
    # what each fit states against the overlapping Allan deviation (allan_interval): a
    # right model is refused rarely (at most 1 % of logs, one-sided 99 %), the truth itself
    # lies outside the 99 % intervals at two levels about as rarely, and the 95 % bar that
    # the docs say refuses right models does
    datasets = sum(g["datasets"] for g in grades.values())
    refused = sum(g["allan_interval"]["refused"] for g in grades.values())
    assert refused <= stats.binom.ppf(0.99, datasets, 0.01)
    truth = {g: v["allan_interval"]["truth_outside_at_two_or_more"] for g, v in grades.items()
             if v["allan_interval"]["truth_outside_at_two_or_more"] is not None}
    closed = sum(grades[g]["datasets"] for g in truth)
    at_99 = sum(v["0.99"] for v in truth.values())
    at_95 = sum(v["0.95"] for v in truth.values())
    assert at_99 <= stats.binom.ppf(0.99, closed, 0.01) and at_95 > 2 * at_99 + 5
    names = {"fog": "fog", "tactical": "tactical", "mems": "MEMS", "gm": "Gauss-Markov",
             "mems_spikes": "spiky MEMS"}
    _quoted(f"It refuses {'none' if refused == 0 else refused} of the {datasets} logs",
            f"in {at_95} of {closed} logs ("
            + ", ".join(f"{names[g]} {truth[g]['0.95']}" for g in truth)
            + f"), outside the 99 % ones in {at_99}")
    spiky, clean = terms["mems_spikes"], terms["mems"]
    assert all(spiky[t][k] == clean[t][k] for t in clean for k in (
        "resolved", "ci90_inside", "upper_bound_inside"))  # the spikes kept out

    def n_error(per_term, method):
        return f"{100 * per_term['N']['error_where_resolved'][method]['median']:.1f} %"

    _quoted(f"(trusted {grades['mems_spikes']['trustworthy']} of "
            f"{grades['mems_spikes']['datasets']}; N {spiky['N']['ci90_inside']} of "
            f"{spiky['N']['resolved']}, B {spiky['B']['ci90_inside']} of "
            f"{spiky['B']['resolved']} intervals and {spiky['B']['upper_bound_inside']} of "
            f"{grades['mems_spikes']['datasets'] - spiky['B']['resolved']} bounds, Q "
            f"{spiky['Q']['ci90_inside']} of {spiky['Q']['resolved']}",
            f"the Allan slopes' median error from {n_error(clean, 'slope')} to "
            f"{n_error(spiky, 'slope')}, the `allan-variance` package's from "
            f"{n_error(clean, 'allan_variance')} to {n_error(spiky, 'allan_variance')}")
    k_gm = gm["K"]["error_where_resolved"]
    _quoted(f"of {100 * k_gm['gyroid']['median']:.0f} % against "
            f"{100 * k_gm['slope']['median']:.0f} % for the Allan slopes and "
            f"{100 * k_gm['allan_variance']['median']:.0f} % for the package, over "
            f"{gm['K']['resolved']} logs")
    order = ("fog", "tactical", "mems")
    b = [terms[g]["B"] for g in order]
    n = [terms[g]["N"] for g in order]
    phone = terms["phone"]
    _quoted(f"gyroid trusts {grades['phone']['trustworthy']} of {grades['phone']['datasets']}",
            f"holds B ({phone['B']['ci90_inside']} of {phone['B']['resolved']} intervals, "
            f"{phone['B']['upper_bound_inside']} of "
            f"{grades['phone']['datasets'] - phone['B']['resolved']} bounds)",
            f"N's intervals cover {phone['N']['ci90_inside']} of "
            f"{phone['N']['resolved']} (band {phone['N']['ci90_band_99'][0]}-"
            f"{phone['N']['ci90_band_99'][1]}; "
            f"median error {100 * phone['N']['error_where_resolved']['gyroid']['median']:.1f} %, "
            f"against {100 * phone['N']['error_where_resolved']['slope']['median']:.1f} % for "
            f"the Allan slopes and "
            f"{100 * phone['N']['error_where_resolved']['allan_variance']['median']:.0f} % for")
    _quoted(f"On {sum(grades[g]['datasets'] for g in order)} static logs of three grades",
            "B: " + ", ".join(f"{e['ci90_inside']} of {e['resolved']}" for e in b)
            + " resolved intervals; N: " + ", ".join(str(e["ci90_inside"]) for e in n)
            + f" of {grades['fog']['datasets']})")

    def error(grade, name, method, where="resolved"):
        entry = terms[grade][name][f"error_where_{where}"][method]
        return None if entry is None else entry["median"]

    for grade in order:
        for name in terms[grade]:
            if terms[grade][name]["resolved"]:
                assert error(grade, name, "gyroid") < error(grade, name, "slope")
                if name != "K":
                    assert error(grade, name, "gyroid") < error(grade, name, "allan_variance")
    percent = lambda values: f"{min(values):.0f}-{max(values):.0f} %"  # noqa: E731
    slope_b = percent([100 * error(g, "B", "slope") for g in order])
    package_b = percent([100 * error(g, "B", "allan_variance") for g in order])
    _quoted(f"(B: {percent([100 * error(g, 'B', 'gyroid') for g in order])} against "
            f"{slope_b} and {package_b})",
            f"for K, in the {terms['fog']['K']['resolved']} and "
            f"{terms['tactical']['K']['resolved']} logs that resolved it, about as accurate (FOG "
            f"{100 * error('fog', 'K', 'gyroid'):.0f} % against that package's "
            f"{100 * error('fog', 'K', 'allan_variance'):.0f} %, tactical "
            f"{100 * error('tactical', 'K', 'gyroid'):.0f} % against "
            f"{100 * error('tactical', 'K', 'allan_variance'):.0f} %)",
            "for K, a median error of "
            + percent([100 * error(g, "K", "slope", "unresolved") for g in order])
            + " by grade")


def test_the_mems_thermal_benches_under_the_default_noise_choice():
    """--noise auto, the default: what it chose and how the trusted fits cover."""
    results = _results("mems_thermal_bench_auto")
    counts = results["per_noise"]["auto"]
    runs = results["runs"]
    chosen = sum(r["noise_used"] == "white+flicker+rw" for r in runs)
    trusted = counts["fits"] - counts["refused"]
    inside, total = counts["coefficients_inside_95"]
    seconds = [r["seconds"] for r in runs]
    worst = max(abs(v) for r in runs for v in r["z"].values())
    _quoted(f"(binomial 99 % band 70-80; the largest miss {worst:.2f} sd), "
            f"{min(seconds):.1f}-{max(seconds):.1f} s per")
    _quoted(f"auto chose white+flicker+rw {chosen} of {len(runs)}",
            f"{trusted} of {counts['fits']} fits trusted, {inside} of the {total} coefficients "
            "inside their 95 % intervals",
            "(binomial 99 % band {:.0f}-{:.0f})".format(*stats.binom(total, 0.95).ppf(
                [0.005, 0.995])))
    assert stats.binom(total, 0.95).ppf(0.005) <= inside <= stats.binom(total, 0.95).ppf(0.995)


def test_the_noise_fits_of_the_real_mpu6050_runs():
    results = _results("noise_real_logs")
    agreement, runs = results["agreement"], results["runs"]
    refused = [r for r in runs if not r["trustworthy"]]
    spiky = [r for r in refused if "outliers" in r["errors"]]
    assert all(r["dispersion"] == 1.0 for r in runs)
    prefiltered = sum("prefilter" in r["failed"] for r in runs)
    spread_y = agreement["y"]["spread_max_over_min"]
    _quoted(f"gyroid trusts {agreement['trusted']} of the {agreement['series']} axis-runs",
            "lies within {:.2f}-{:.2f}x of the Allan-slope reading".format(
                *agreement["N_over_slope"]),
            "{:.2f}-{:.2f}x of the `allan-variance` package's".format(
                *agreement["N_over_allan_variance"]),
            f"It refuses {len(refused)}: in {_number_word(len(spiky))}, more samples lie far "
            "from their neighbours",
            f"`prefilter` warning, on {prefiltered} of the {len(runs)} axis-runs), no run "
            "scatters beyond chance",
            *(f"(`{name}`)" for r in refused if r not in spiky for name in r["errors"]),
            f"(axis y: {min(spread_y.values()):.2f}-{max(spread_y.values()):.2f}x")


def _number_word(n: int) -> str:
    return {1: "one", 2: "two", 3: "three", 4: "four", 5: "five"}.get(n, str(n))


def test_the_noise_of_the_unit_behind_six_real_runs():
    """The six ADIS16405 runs pooled, and the MTi-G run refused (noise_unit_runs)."""
    results = _results("noise_unit_runs")
    units, mtig = results["units"], results["mtig_cont_imu1"]
    widths = {}
    for axis in ("x", "y"):
        n = units[axis]["terms"]["N"]
        medians = [v["median"] for v in n["runs"].values()]
        assert n["runs_inside"] == len(medians) == 6 and units[axis]["trustworthy"]
        lo, hi = n["new_run_ci90"]
        assert lo < min(medians) and max(medians) < hi
        widths[axis] = max(50 * (v["ci90"][1] - v["ci90"][0]) / v["median"]
                           for v in n["runs"].values())
    x, y = units["x"]["terms"]["N"], units["y"]["terms"]["N"]
    medians = [v["median"] for v in x["runs"].values()]
    _quoted(f"+/-{widths['x']:.1f} %",
            f"{min(medians):.2f}-{max(medians):.2f} deg/sqrt(h)",
            "the unit's is {:.2f} (90 %: {:.2f}-{:.2f})".format(x["unit_median"],
                                                                *x["unit_ci90"]),
            "a new run should read {:.2f}-{:.2f}".format(*x["new_run_ci90"]),
            "(y: {:.2f}, {:.2f}-{:.2f}, all six)".format(y["unit_median"], *y["new_run_ci90"]))
    # held out: each run against the interval the other five give a new run
    held = results["held_out"]
    inside = {axis: held[axis]["N"]["inside"] for axis in ("x", "y", "z")}
    assert all(held[axis]["N"]["of"] == 6 for axis in inside)
    misses = {axis: [k for k, v in held[axis]["N"]["runs"].items() if not v["inside"]]
              for axis in inside}
    assert set(inside.values()) == {5} and all(m == ["adis_16405_imu5"] for m in misses.values())
    above = []
    for axis in inside:
        runs = held[axis]["N"]["runs"]
        others = [v["median"] for k, v in runs.items() if k != "adis_16405_imu5"]
        above.append(100 * (runs["adis_16405_imu5"]["median"] / np.mean(others) - 1))
    x5 = held["x"]["N"]["runs"]["adis_16405_imu5"]
    b_inside = sum(held[a]["B"]["inside"] for a in held if "B" in held[a])
    b_of = sum(held[a]["B"]["of"] for a in held if "B" in held[a])
    assert b_inside == b_of
    _quoted("5 of 6 runs on every axis",
            f"{min(above):.1f}-{max(above):.1f} % above",
            f"(x: {x5['median']:.2f} against their interval up to {x5['new_run_ci90'][1]:.2f})",
            f"in all {b_of} runs where both resolve it")
    # the overlapping Allan deviation: the check's interval met everywhere, the median model
    # alone against the 95 % interval missed at two levels or more on some runs
    bar = [r["allan_interval"] for r in results["runs"]]
    assert all(not b["missed_s"] for b in bar)
    median_misses = sum(len(b["median_outside_95_s"]) >= 2 for b in bar)
    _quoted(f"every one of the {len(bar)} axis-runs meets the 99 % interval at every averaging "
            f"time", f"averaging times on {median_misses} of the {len(bar)}")
    gm = mtig["gauss_markov"]
    assert not mtig["trustworthy"] and mtig["failed"] == ["outliers"]
    _quoted(f"is refused ({100 * mtig['outliers']:.1f} % of its samples",
            f"at 328 s is {mtig['adev_deg_h']['327.68']:.1f} deg/h",
            f"as G ({gm['mean']:.0f} deg/h, correlation time {gm['tau_s']:.1f} s)",
            f"B below {mtig['B']['upper_bound_95']:.1f} deg/h")


def test_the_streamed_fit_of_a_log_too_long_to_hold():
    """benchmarks/results_streaming.json: the fits of the streamed logs exited 0 as block
    means, and their coefficients lie as close to paper A's truths as the README says."""
    from gyroid.simulation import PAPER_A_THERMAL

    rows = json.loads((ROOT / "benchmarks" / "results_streaming.json").read_text())["results"]
    worst = 0.0
    for row in rows:
        fit = row["fit_streamed"]
        assert fit["code"] == 0 and fit["block_means"]["rows"] == row["rows"]
        assert fit["block_means"]["means"] <= 1000
        worst = max(worst, *(abs(fit["mean"][k] - v) / fit["sd"][k]
                             for k, v in PAPER_A_THERMAL.items()))
    assert [row["rows"] for row in rows] == [21_000_000, 100_000_000]
    assert all("white+flicker+rw" in row["fit_streamed"]["noise_choice"] for row in rows)
    _quoted("Under the default's IEEE 952 noise on the means every check passed, and the "
            f"four coefficients lie within {math.ceil(10 * worst) / 10:.1f} posterior sd of "
            "the truths")
    long, short = rows[1], rows[0]
    _quoted(f"chunk by chunk in {long['simulate_streamed']['seconds']:.0f} s and "
            f"{long['simulate_streamed']['peak_mb'] / 1000:.1f} GB",
            f"took {long['fit_streamed']['seconds']:.0f} s and "
            f"{long['fit_streamed']['peak_mb'] / 1000:.2f} GB end to end, against "
            f"{long['load_pyarrow']['seconds']:.0f} s and "
            f"{long['load_pyarrow']['peak_mb'] / 1000:.1f} GB",
            f"at 2.1 x 10^7 rows {short['fit_streamed']['seconds']:.1f} s and "
            f"{short['fit_streamed']['peak_mb'] / 1000:.2f} GB (pyarrow "
            f"{short['load_pyarrow']['seconds']:.1f} s, "
            f"{short['load_pyarrow']['peak_mb'] / 1000:.1f} GB)")
    assert all(not row["fit_streamed"]["failed"] for row in rows)


def test_the_thermometer_carried_into_dt_dt():
    runs = _results("eiv_calibration")
    n = 30

    def count(fraction):
        return round(fraction * n)

    fine, noisy = runs["thermometer_0.01C"], runs["thermometer_0.05C"]
    carried, left = fine["carried"], fine["left_out"]
    worst = max(count(f) for f in carried["outside_95"].values())
    assert carried["trustworthy"] == 1.0 and carried["whiteness_failed"] == 0.0
    assert worst <= 2  # the binomial 95 % band for 30 at 5 % reaches 4
    _quoted(f"are {count(carried['trustworthy'])} of {n} trusted, none fails whiteness, and "
            f"at most {worst} of {n} truths fall outside",
            f"wD's z-scores average +{carried['z_mean']['wD']:.2f}",
            f"left out, {count(left['whiteness_failed'])} of {n} fail whiteness "
            f"({count(left['trustworthy'])} of {n} trusted)",
            f"carried, {count(noisy['carried']['trustworthy'])} of {n} trusted and at most "
            f"{max(count(f) for f in noisy['carried']['outside_95'].values())} of {n} outside",
            f"left out, none trusted (wD's estimate averages "
            f"{noisy['left_out']['z_mean']['wD']:.1f} sd")
    assert noisy["left_out"]["trustworthy"] == 0.0


def test_the_thermometer_carried_under_the_default_noise():
    runs = _results("eiv_calibration_ieee")
    n = 30

    def outside(way):
        return [round(f * n) for f in way["outside_95"].values()]

    fine, noisy = runs["thermometer_0.01C"], runs["thermometer_0.05C"]
    z_sd = noisy["carried"]["z_sd"].values()
    fixed = noisy["carried_window_1200s"]
    # within the binomial 95 % band for 30 intervals at 5 % (at most 4 outside), every way
    assert max(max(outside(w)) for w in (fine["carried"], noisy["carried"], fixed)) <= 4
    _quoted(f"with a 0.01 degC thermometer at most {max(outside(fine['carried']))} of {n}",
            f"with 0.05 degC, up to {max(outside(noisy['carried']))} of {n}",
            f"the z-scores' sd is {min(z_sd):.2f} to {max(z_sd):.2f}",
            f"(z-scores' sd {min(fixed['z_sd'].values()):.2f} to "
            f"{max(fixed['z_sd'].values()):.2f}, at most {max(outside(fixed))} of {n} outside)")


def test_the_white_fits_that_carry_the_thermometer_pass_where_they_failed():
    runs = json.loads((ROOT / "benchmarks" / "results_scaling_eiv.json").read_text())["results"]
    assert [r["rows"] for r in runs] == [10_000, 100_000]
    # the fits' verdicts and agreement, not their times (those are stated with their load)
    assert all(r["fit"]["code"] == 0 and r["agree"] for r in runs)
    _quoted("now exit 0 (the thermometer's noise carried into dT/dt, its residuals are white)",
            "Both fits still agree.")


def test_the_small_logs_end_to_end_against_the_bare_scripts():
    runs = json.loads((ROOT / "benchmarks" / "results_scaling_small.json").read_text()
                      )["results"]
    assert [r["rows"] for r in runs] == [10_000, 100_000]
    assert all(r["fit"]["code"] == 0 and r["agree"] and r["compensate"]["code"] == 0
               and r["fit"]["noise_choice"].startswith("auto: white") for r in runs)
    fit = [r["fit"]["seconds"] / r["bare"]["seconds"] for r in runs]
    compensate = [r["compensate"]["seconds"] / r["bare_compensate"]["seconds"] for r in runs]
    spread = max(max(v["seconds_all"]) / min(v["seconds_all"]) - 1 for r in runs
                 for k, v in r.items() if isinstance(v, dict) and "seconds_all" in v)
    _quoted(f"{fit[0]:.1f}x and {fit[1]:.1f}x, where the 2x the issue asks for is not met",
            f"{compensate[0]:.1f}x and {compensate[1]:.1f}x",
            f"differ by up to {100 * spread:.0f} % in the file",
            f"{runs[1]['compensate']['seconds']:.1f} s and "
            f"{runs[1]['compensate']['peak_mb'] / 1000:.2f} GB in the file")


def _seconds(value: float) -> str:
    return f"{value:.1f} s" if value < 9.95 else f"{value:.0f} s"


def _took(run: dict, joint: str = ", ") -> str:
    return f"{_seconds(run['seconds'])}{joint}{run['peak_mb'] / 1000:.2f} GB"


def test_the_scaling_table_is_the_results_file():
    file = json.loads((ROOT / "benchmarks" / "results_scaling.json").read_text())
    runs = file["results"]
    assert [r["rows"] for r in runs] == [10**k for k in range(4, 8)]
    assert all(r["fit"]["code"] == 0 and r["agree"] and r["compensate"]["code"] == 0
               for r in runs)
    for k, r in enumerate(runs, start=4):
        ieee = r.get("fit_ieee")
        assert ieee is None or ieee["code"] == 0  # it ended in an internal error once
        load = " / ".join(f"{x:.2f} s" if x < 1 else _seconds(x) for x in
                          (r["load_gyroid"]["seconds"], r["load_pyarrow"]["seconds"]))
        _quoted(f"| 10^{k} | {load} | {_took(r['fit'])} | {_took(r['bare'])} | "
                f"{r['fit']['seconds'] / r['bare']['seconds']:.1f}x | {_took(r['compensate'])} | "
                f"{_took(r['bare_compensate'])} | {_took(ieee) if ieee else 'not run'} | "
                f"{_took(r['discrepancy'])} |")
    ratio = [r["fit"]["seconds"] / r["bare"]["seconds"] for r in runs]
    compensate = [r["compensate"]["seconds"] / r["bare_compensate"]["seconds"] for r in runs]
    load = [r["load_gyroid"]["seconds"] / r["load_pyarrow"]["seconds"] for r in runs]
    _quoted(f"gyroid's fit is {min(ratio[:3]):.1f}-{max(ratio[:3]):.1f}x the bare script up "
            f"to 10^6 rows and {ratio[3]:.1f}x at 10^7",
            f"Compensation is {min(compensate):.1f}-{max(compensate):.1f}x the bare one",
            f"Loading is {min(load):.1f}-{max(load):.1f}x pyarrow's")


def test_the_white_gm_fits_are_the_results_file():
    runs = json.loads((ROOT / "benchmarks" / "results_scaling_gm.json").read_text())["results"]
    assert [r["rows"] for r in runs] == [10**5, 10**6]
    fits = [r["fit_gm"] for r in runs]
    assert all(f["code"] == 0 and not f["failed"] and f["block_means"] for f in fits)
    worst = max(abs(z) for f in fits for z in f["z"].values())
    assert worst < 3  # seven coefficients and levels per fit
    _quoted(f"{_took(fits[0], ' and ')} at 10^5 rows, {_took(fits[1], ' and ')} at 10^6, "
            "both converged and "
            f"trusted, every coefficient and noise level within {worst:.1f} posterior sd")


def test_the_white_gm_calibration_is_the_results_file():
    results = _results("white_gm_calibration")
    inside = results["inside_90"]
    others = [v for k, v in inside.items() if k != "wD"]
    _quoted(f"wD's posterior sits {results['z_mean']['wD']:.2f} sd above its truth on average "
            f"({inside['wD']} of {results['datasets']} inside its 90 % interval, the other "
            f"coefficients and noise levels {min(others)}-{max(others)} of "
            f"{results['datasets']}; all {results['trustworthy']} fits trusted themselves)",
            f"`noise_prior_dependence` warned on {results['noise_prior_dependence_warned']} of "
            f"{results['datasets']}, {results['warned_under_other_model']} of them because "
            "the default")


def test_the_import_floor_is_the_results_file():
    imports = json.loads((ROOT / "benchmarks" / "results_scaling_small.json").read_text()
                         )["imports"]
    seconds = {k: v["seconds"] for k, v in imports.items()}
    _quoted(f"emcee) {seconds['bare']:.2f} s;",
            f"to write netCDF) {seconds['fit_libraries']:.1f} s",
            f"gyroid's own modules with all of those {seconds['fit_modules']:.1f} s")


def test_the_demo_time_is_the_results_file():
    demo = json.loads((ROOT / "benchmarks" / "results_demo.json").read_text())["demo"]
    _quoted(f"{demo['warm_seconds']:.0f} s with JAX's compilation cache warm, "
            f"{demo['cold_seconds']:.0f} s cold, "
            f"{demo['cold_peak_total_rss_mb'] / 1000:.1f} GB in its two processes together",
            f"{demo['cold_seconds']:.0f} s / {demo['warm_seconds']:.0f} s, "
            f"{demo['cold_peak_total_rss_mb'] / 1000:.1f} GB |")


def _fog_phrases() -> dict[str, str]:
    """The FOG bench study's sentences (experiments/fog_thermal_bench.py)."""
    import numpy as np

    summary = _results("fog_thermal_bench")["summary"]
    smooth, raised = summary["smooth"], summary["raised_cosine"]
    n = smooth["fits"]
    lo, hi = stats.binom(n, 0.95).ppf([0.005, 0.995])
    inside = smooth["inside_95"]
    z_sd = smooth["z_sd"]
    beyond = smooth["exit_0_beyond_3_3_sd"]
    out = {"smooth": (
        f"on the smooth profile the default trusted {n - smooth['exit_3']} of {n} fits; their "
        f"95 % intervals held the truths {inside['w0']}, {inside['w1']}, {inside['w2']} and "
        f"{inside['wD']} times of {n} for w0, w1, w2 and wD (binomial 99 % band "
        f"{lo:.0f}-{hi:.0f}), the z-scores' sd {min(z_sd.values()):.2f}-"
        f"{max(z_sd.values()):.2f} (w1's {z_sd['w1']:.2f}), and {beyond} trusted fit"
        f"{'' if beyond == 1 else 's'} had a truth more than 3.3 sd away")}
    runs = [r for r in _results("fog_thermal_bench")["runs"] if r["profile"] == "smooth"]
    worst = max((r for r in runs if r["trustworthy"]),
                key=lambda r: max(abs(v) for v in r["z"].values()))
    name = max(worst["z"], key=lambda k: abs(worst["z"][k]))
    known, ratio = smooth["z_sd_known_noise"], smooth["noise_median_over_truth"]
    out["known"] = (
        f"({name} at {abs(worst['z'][name]):.1f} sd, seed {worst['seed']}; the issue's bound "
        f"is not met). With the noise levels pinned at their truths the same log's {name} is "
        f"{abs(worst['z_known_noise'][name]):.1f} sd away and {name}'s z-scores' sd over the "
        f"{n} logs is {known[name]:.2f}")
    out["medians"] = (
        f"the posterior medians of B and K sit at {ratio['B_deg_h']:.2f} and "
        f"{ratio['K_deg_h_sqrt_h']:.2f} of their truths (medians over the {n} logs; N's at "
        f"{ratio['N_deg_sqrt_h']:.2f})")
    raised_ratio = raised["noise_median_over_truth"]
    out["raised_noise"] = (f"(B's median {raised_ratio['B_deg_h']:.2f}x its truth, N's "
                           f"{raised_ratio['N_deg_sqrt_h']:.2f}x")
    samplers = [r["sampler"] for r in _results("fog_thermal_bench")["runs"]]
    if all(m == "psis" for m in samplers):
        out["sampler"] = (f"All {len(samplers)} default fits were sampled by importance "
                          "sampling (its Pareto k below 0.7 on each)")
    else:
        out["sampler"] = f"{samplers.count('psis')} of the {len(samplers)} default fits"
    rc = [r for r in _results("fog_thermal_bench")["runs"] if r["profile"] == "raised_cosine"]
    windows = sorted({r["rate_window_s"] for r in rc})
    out["raised_window"] = (f"The window is the marginal likelihood's ({windows[0]:.0f}-"
                            f"{windows[-1]:.0f} s" if len(windows) > 1 else
                            f"marginal likelihood's ({windows[0]:.0f} s on every log)")
    gaps = [float(m.split(" is ")[1].split(" posterior sd")[0]) for r in rc
            for m in r["failed_messages"] if "point estimate of B_deg_h" in m]
    if gaps:
        out["raised_modes"] = (f"(its B {min(gaps):.0f}-{max(gaps):.0f} posterior sd from the "
                               "mode's)")
    raised_sd, raised_in = raised["z_sd"].values(), raised["inside_95"]
    beyond = raised["exit_0_beyond_3_3_sd"]
    out["raised"] = (
        f"On the raised-cosine profile {raised['exit_3']} of {raised['fits']} refused (exit 3);"
        f" their intervals held the truths {raised_in['w0']}, {raised_in['w1']}, "
        f"{raised_in['w2']} and {raised_in['wD']} times of {raised['fits']}, the z-scores' sd "
        f"{min(raised_sd):.2f}-{max(raised_sd):.2f}, and "
        f"{'no' if beyond == 0 else beyond} trusted fit{'' if beyond < 2 else 's'} had a "
        "truth more than 3.3 sd away")
    default = _results("fog_thermal_bench_white_only")["runs"]
    white = {r["seed"]: r for r in _results("fog_thermal_bench_white_only_white")["runs"]}
    ratios = {k: [r["sd"][k] / white[r["seed"]]["sd"][k] for r in default]
              for k in ("w0", "w1", "w2", "wD")}
    medians = [float(np.median(v)) for v in ratios.values()]
    largest = max(max(v) for v in ratios.values())
    trusted = sum(r["trustworthy"] for r in default)
    only = _results("fog_thermal_bench_white_only")["summary"]["smooth"]
    out["white_only"] = (
        f"the default's posterior sds were {min(medians):.2f}-{max(medians):.2f}x "
        f"`--noise white`'s (medians per coefficient over {len(default)} seeds; at most "
        f"{largest:.2f}x), {trusted} of {len(default)} default fits trusted, and their truths "
        f"inside every 95 % interval (a z-scores' sd of {min(only['z_sd'].values()):.2f}-"
        f"{max(only['z_sd'].values()):.2f}: the intervals are conservative; re-run on "
        f"2026-12-01 with the thermometer's two oscillators, a median "
        f"{only['median_seconds']:.0f} s a fit")
    assert all(v == len(default) for v in only["inside_95"].values())
    white_seconds = _results("fog_thermal_bench_white_only_white")["summary"]["smooth"][
        "median_seconds"]
    out["seconds"] = (f"a median {smooth['median_seconds']:.0f} s in that run, two such fits "
                      f"side by side and another study's beside them "
                      f"(`experiments/results/fog_thermal_bench/`), against "
                      f"{white_seconds:.1f} s for `--noise white`")
    return out


def test_the_fog_benches_under_the_default_noise():
    _quoted(*_fog_phrases().values())


def test_real_log_study():
    results = _results("real_log_study")
    s, runs = results["summary"], results["runs"]
    usable = [r for r in runs if r["fit_exit"] == 0 and r.get("compensate_exit") == 0]
    under = sorted(100 * r["gyroid"]["band_holds"] for r in usable
                   if r["gyroid"]["band_holds"] < 0.8)
    assert len(under) == s["gyroid_trusted"] - s["trusted_holding_80pct"]
    assert s["another_run_single_fit_refused"] == s["another_run_single_fit_cases"]
    _quoted(f"| gyroid, fit and compensation both usable (exit 0) | {s['gyroid_trusted']} | "
            f"median {s['trusted_rms_over_best_peer_median']:.3f}, at most "
            f"{s['trusted_rms_over_best_peer_max']:.3g}; no worse in "
            f"{s['trusted_no_worse_than_best_peer']} | at least 80 % in "
            f"{s['trusted_holding_80pct']}" + (
                f"; {' % and '.join(f'{x:.0f}' for x in under)} % in {len(under)} |"
                if len(under) > 1 else f"; {under[0]:.0f} % in one |" if under else " |"),
            f"| gyroid, refused (exit 3) | {s['cases'] - s['gyroid_trusted']} | | median "
            f"{100 * s['untrusted_band_holds_median']:.0f} % |",
            f"| least squares | {s['cases']} | | median "
            f"{100 * s['least_squares_band_holds_median']:.0f} % |",
            f"{s['cases']} cases on every axis",
            f"{s['another_run_single_fit_cases']} cases where a fit of one run predicts another",
            f"Pooled, {s['pooled_trusted']} of {s['pooled_cases']} cases are usable",
            f"held a median {100 * s['pooled_least_squares_band_holds_median']:.0f} % over the "
            f"{s['pooled_cases']} pooled cases",
            f"no worse than the best peer's in {s['gyroid_no_worse_than_best_peer']}.")
    single = [r for r in runs if r["another_run"] and not r["pooled"] and not r["rezero_s"]]
    low = sum(r["gyroid"]["band_holds"] < 0.8 for r in single)
    _quoted(f"held under 80 % in {low} of the {len(single)}")

    def ratio(r: dict) -> float:
        return r["gyroid"]["rms_deg_h"] / min(r[m]["rms_deg_h"] for m in (
            "least_squares", "cubic", "startup_mean") if m in r)

    adis = [r for r in runs if r["case"].startswith("adis16405 pooled")]
    adis_ratio = [ratio(r) for r in adis]
    holds = [r["gyroid"]["band_holds"] for r in adis]
    _quoted(f"(median ratio {np.median(adis_ratio):.2f}, at most {max(adis_ratio):.2f}, no "
            f"worse in {sum(x <= 1 + 1e-9 for x in adis_ratio)} of {len(adis)}), with bands "
            f"that held {100 * min(holds):.0f}-{100 * max(holds):.0f} %")
    startup = [r for r in runs if r["rezero_s"]]
    usable = [r for r in startup if r["fit_exit"] == 0 and r["compensate_exit"] == 0]
    better = sum(r["gyroid"]["rms_deg_h"] < r["least_squares"]["rms_deg_h"] for r in startup)
    over_ls = np.median([r["gyroid"]["rms_deg_h"] / r["least_squares"]["rms_deg_h"]
                         for r in usable])
    assert s["startup_trusted"] == len(usable)
    _quoted(f"With a 600 s start-up calibration, {len(usable)} of the {len(startup)} "
            "single-run cases are usable",
            f"better in {better} of {len(startup)}, a median ratio of {over_ls:.2f}")
    refused = [100 * r["gyroid"]["band_holds"] for r in startup if r["compensate_exit"] == 3]
    low_usable = [r for r in usable if r["gyroid"]["band_holds"] < 0.8]
    _quoted(" % and ".join(f"{x:.0f}" for x in refused) + " % in band",
            *(f"with {round(r['gyroid']['band_holds'] * r['windows'])} of its {r['windows']} "
              "windows in band" for r in low_usable))
    mpu = [ratio(r) for r in runs if r["case"].startswith("mpu6050 pooled")]
    _quoted(f"better in {sum(x > 1 + 1e-9 for x in mpu)} of {len(mpu)} pooled cases, up to "
            f"{max(mpu):.1f}x")
    _per_recipe(runs)


def _per_recipe(runs: list[dict]) -> None:
    """The real-log study read per recipe (issue 63): each recipe's median ratio over the
    usable answers it has, and the answers worse than 2x."""
    usable = [r for r in runs if r["fit_exit"] == 0 and r["compensate_exit"] == 0]

    def over(recipe: str, rows: list[dict]) -> np.ndarray:
        return np.array([r["gyroid"]["rms_deg_h"] / r[recipe]["rms_deg_h"] for r in rows
                         if r.get(recipe) and r[recipe].get("rms_deg_h")])

    ls = over("least_squares", usable)
    worse = [r for r in usable if r["gyroid"]["rms_deg_h"] > 2 * r["least_squares"]["rms_deg_h"]]
    assert worse and all(r["pooled"] and r["case"].startswith("mpu6050") for r in worse)
    rest = over("least_squares", [r for r in usable
                                  if not (r["pooled"] and r["case"].startswith("mpu6050"))])
    cubic, startup = over("cubic", usable), over("startup_mean", usable)
    holds = np.array([r["gyroid"]["band_holds"] for r in usable])
    _quoted(f"against least squares a median ratio of {np.median(ls):.3f} over {ls.size} "
            f"answers, no worse in {int(np.sum(ls <= 1))}, and worse than 2x in {len(worse)}",
            f"(without those, {np.median(rest):.3f} over {rest.size}, at most {rest.max():.2f})",
            f"against PX4's cubic {np.median(cubic):.3f} over the {cubic.size} answers it has",
            f"against a start-up calibration's mean {np.median(startup):.3f} over {startup.size}",
            f"{int(np.sum(holds >= 0.8))} of the {holds.size} usable answers held at least 80 % "
            f"of their window means (a median of {100 * np.median(holds):.0f} %)")
    assert np.sum(holds >= 0.8) >= 0.9 * holds.size


def test_window_bands_cost():
    results = _results("window_bands")
    runs = results["runs"]
    passed = [r["inside"] for r in runs if r["window_bands"]]
    refused = [r for r in runs if not r["window_bands"]]
    assert results["fits_trustworthy"] == results["pairs"]
    which = (" (" + ", ".join(f"{round(r['inside'] * r['windows'])} of its {r['windows']} "
                              "windows in band" for r in refused) + ")") if refused else ""
    _quoted(f"{len(refused)} of {results['pairs']} refused{which}, the "
            f"{'other ' if refused else ''}{len(passed)} held {100 * min(passed):.0f}-"
            f"{100 * max(passed):.0f} %")


def test_sbc_of_the_default_fit():
    names = ("w0", "w1", "N_deg_sqrt_h", "B_deg_h", "K_deg_h_sqrt_h")
    s = _results("sbc_ieee_substeps")["summary"]
    ks = [f"{s[k]['ks_pvalue']:.3f}" for k in names]
    cover = [f"{100 * s[k]['coverage']['90%']:g}" for k in names]
    assert min(s[k]["ks_pvalue"] for k in names) > 0.01
    point = _results("sbc_ieee")["summary"]["w0"]
    _quoted(f"{s['importance_sampled']} of 200 sampled by importance sampling, "
            f"{s['trustworthy']} trusted, {s['median_seconds']:.1f} s a fit",
            f"(KS p {', '.join(ks[:4])} and {ks[4]} for",
            f"cover {', '.join(cover[:4])} and {cover[4]} %",
            f"KS p {point['ks_pvalue']:.3f}; its 50 % and 95 % intervals covered "
            f"{100 * point['coverage']['50%']:g} % and {100 * point['coverage']['95%']:g} %")


def test_default_sampler_benchmark():
    r = json.loads((ROOT / "benchmarks" / "results_default_sampler.json").read_text())
    assert r["importance"]["trustworthy"] and r["emcee"]["trustworthy"]
    for name, a in r["importance"]["posterior"].items():  # the same posterior: the means
        b = r["emcee"]["posterior"][name]  # within 4 Monte-Carlo se of their difference
        assert abs(a["mean"] - b["mean"]) < 4.0 * b["sd"] * math.sqrt(2.0 / 400.0), name
    _quoted(f"{r['importance']['median_seconds']:.2f} s a fit, against "
            f"{r['emcee']['median_seconds']:.2f} s with emcee in the same run")


def test_pooling_a_correlated_lot():
    """experiments/pool_noise.py: the white pool against --noise auto on one lot (the runs
    differ: the white pool's p-values are right to be small)."""
    results = _results("pool_noise")
    white, auto = results["white"], results["auto"]

    def ps(pool):
        return ", ".join(f"{pool['cochran_q_p'][k]:.2g}" for k in ("w0", "w1", "w2"))

    assert white["trustworthy"] and auto["trustworthy"]
    _quoted(f"the white pool trusted itself and its Cochran's Q said the runs differ in w0, "
            f"w1 and w2 (p {ps(white)}, from the white sds)",
            f"found the runs differ in w0, w1 and w2 too (p {ps(auto)})",
            f"in {auto['seconds']:.1f} s against {white['seconds']:.1f} s")
    assert "residual_whiteness" not in auto["failed"]
    _quoted(f"their blocks varying {auto['whiteness_inflation']:.1f}x as much as the noise "
            "model allows")


def test_the_flicker_and_walk_prior_study():
    """fog_thermal_bench.py --flicker-walk-median 0.003 on the FOG and white-only logs."""
    import numpy as np

    fog = _results("fog_thermal_bench_prior_hundredth")
    smooth = fog["summary"]["smooth"]
    worst = next(r for r in fog["runs"] if r["seed"] == 25)
    white = {r["seed"]: r for r in _results("fog_thermal_bench_white_only_white")["runs"]}
    runs = _results("fog_thermal_bench_white_only_prior_hundredth")["runs"]
    medians = [float(np.median([r["sd"][k] / white[r["seed"]]["sd"][k] for r in runs]))
               for k in ("w0", "w1", "w2", "wD")]
    _quoted(f"sds were {min(medians):.2f}-{max(medians):.2f}x white's",
            f"w1's z-scores' sd fell only to {smooth['z_sd']['w1']:.2f}",
            f"seed 25's w1 still lay {abs(worst['z']['w1']):.1f} sd from its truth")


def test_many_small_logs():
    """benchmarks/results_batch.json: gyroid batch against the bare loop."""
    r = json.loads((ROOT / "benchmarks" / "results_batch.json").read_text())
    default, white, bare = r["gyroid_batch"], r["gyroid_batch_white"], r["bare_loop"]
    assert default["code"] == white["code"] == bare["code"] == 0
    assert default["fitted"] == white["fitted"] == r["logs"]
    _quoted(f"took {default['seconds']:.1f} s with its default noise (IEEE 952; all "
            f"{default['fitted']} fitted) and {white['seconds']:.1f} s with `--noise white`, "
            f"against {bare['seconds']:.1f} s",
            f"{r['gyroid_batch_over_bare']:.1f}x and {r['gyroid_batch_white_over_bare']:.1f}x "
            "slower")


def test_one_long_axis_searched():
    """benchmarks/results_discrepancy_long.json: the discrepancy search on 90 000 rows."""
    r = json.loads((ROOT / "benchmarks" / "results_discrepancy_long.json").read_text())
    plain, hidden = r["cases"]["plain"], r["cases"]["hidden_warmup"]
    assert plain["rows"] == hidden["rows"] == 90000
    assert plain["code"] == hidden["code"] == 0 and plain["added"] == []
    assert hidden["added"] == ["warmup"]
    _quoted(f"thermal` in a fresh process: {plain['seconds']:.1f} s with nothing to find",
            f"{hidden['seconds']:.1f} s with a hidden start-up transient")


def test_a_fit_beside_busy_processes():
    """benchmarks/results_under_load.json: a warm fit quiet and loaded."""
    r = json.loads((ROOT / "benchmarks" / "results_under_load.json").read_text())
    quiet, loaded = r["quiet"], r["loaded"]
    _quoted(f"quiet, {quiet['gyroid']['seconds']:.2f} s against {quiet['bare']['seconds']:.2f} s "
            f"({quiet['ratio']:.1f}x)",
            f"{loaded['gyroid']['seconds']:.2f} s against {loaded['bare']['seconds']:.2f} s "
            f"({loaded['ratio']:.1f}x)",
            f"({loaded['gyroid']['seconds'] / quiet['gyroid']['seconds']:.1f}x against "
            f"{loaded['bare']['seconds'] / quiet['bare']['seconds']:.1f}x)")


def test_help_times():
    """benchmarks/results_help.json: --help in a fresh process."""
    r = json.loads((ROOT / "benchmarks" / "results_help.json").read_text())["help"]
    _quoted(f"`gyroid --help` {r['gyroid']['seconds']:.2f} s and `gyroid fit --help` "
            f"{r['gyroid_fit']['seconds']:.2f} s")


def test_small_logs_under_the_default_noise():
    """benchmarks/results_scaling_small_ieee.json: gyroid fit, compensate and discrepancy
    against the bare scripts (white noise, and correlated noise by Allan slopes and GLS) at
    10^4-10^6 rows, the default fit IEEE 952 noise."""
    record = json.loads((ROOT / "benchmarks" / "results_scaling_small_ieee.json").read_text())
    rows = record["results"]
    assert [r["rows"] for r in rows] == [10_000, 100_000, 1_000_000]
    assert all("white+flicker+rw" in r["fit"]["noise_choice"] and r["agree"] for r in rows)
    floor = record["imports"]["fit_modules"]["seconds"]

    def three(values, fmt):
        return f"{fmt.format(values[0])}, {fmt.format(values[1])} and {fmt.format(values[2])}"

    fit = [r["fit"]["seconds"] for r in rows]
    budget = [2 * r["bare"]["seconds"] + floor for r in rows]
    over = [f / b for f, b in zip(fit, budget, strict=True)]
    fair = [r["bare_correlated"] for r in rows]
    _quoted(f"{fit[0]:.1f} s\nat 10^4 rows, {fit[1]:.1f} s at 10^5 and {fit[2]:.1f} s at 10^6"
            .replace("\n", " "),
            f"peak memory {min(r['fit']['peak_mb'] for r in rows) / 1000:.2f}-"
            f"{max(r['fit']['peak_mb'] for r in rows) / 1000:.2f} GB",
            "white-noise script's " + three([r["bare"]["seconds"] for r in rows], "{:.2f}")
            + " s",
            "`gyroid compensate` " + three([r["compensate"]["seconds"] for r in rows], "{:.1f}")
            + " s, against " + three([r["bare_compensate"]["seconds"] for r in rows], "{:.1f}"),
            "`gyroid discrepancy` " + three([r["discrepancy"]["seconds"] for r in rows],
                                            "{:.1f}"),
            f"import floor, {floor:.2f} s in this run: {min(budget):.1f}-{max(budget):.1f} s",
            (f"the fit is {min(over):.1f}x it at every length"
             if f"{min(over):.1f}" == f"{max(over):.1f}" else
             f"the fit is {min(over):.1f}-{max(over):.1f}x it"),
            three([f["seconds"] for f in fair], "{:.2f}") + " s, "
            + three([f / c["seconds"] for f, c in zip(fit, fair, strict=True)], "{:.1f}x")
            + " faster",
            "w1's sd " + three([f["sd"]["w1"] for f in fair], "{:.2g}") + " against gyroid's "
            + three([r["fit"]["sd"]["w1"] for r in rows], "{:.2g}"))
    assert max(over) < 1.25  # the stated "1.2x at every length"


def test_the_pooled_fog_lots():
    """experiments/results/pool_fog_lots: the white pool's false alarms against the
    default's on lots whose runs do not differ."""
    summary = _results("pool_fog_lots")["summary"]
    white, auto = summary["white"], summary["auto"]
    alarms = white["false_alarms_p_below_0_01"]
    _quoted(f"the white pool trusted {white['trusted']} of {summary['lots']} and each of those "
            f"{white['trusted_with_a_false_alarm']} said the runs differ",
            f"({alarms['w1']}, {alarms['w2']} and {alarms['wD']} such false alarms of "
            f"{summary['lots']} lots)",
            f"the default trusted {auto['trusted']} of {summary['lots']} with "
            f"{sum(auto['false_alarms_p_below_0_01'].values())} false alarms of "
            f"{3 * summary['lots']} tests",
            f"at {auto['median_seconds']:.0f} s a lot against {white['median_seconds']:.1f} s")
    assert all(v == summary["lots"] for v in (*white["covered95"].values(),
                                              *auto["covered95"].values()))


def test_the_fog_benches_with_a_measured_noise():
    """experiments/results/fog_thermal_bench_static_40h: the bench fitted with noise priors
    from 40 h of the gyro at rest."""
    runs = _results("fog_thermal_bench_static_40h")["runs"]
    resolved = {t: sum(r["static_noise_fit"]["terms"][t]["resolved"] for r in runs)
                for t in ("B", "K")}
    summary = _results("fog_thermal_bench_static_40h")["summary"]["smooth"]
    inside = summary["inside_95"]
    worst = next(r for r in runs if r["seed"] == 25)["z"]["w1"]
    _quoted(f"resolved B in {resolved['B']} of {len(runs)} runs and K in {resolved['K']}",
            f"trusted {summary['fits'] - summary['exit_3']} of {summary['fits']}, held the "
            f"truths {inside['w0']}, {inside['w1']}, {inside['w2']} and {inside['wD']} times",
            f"(z-scores' sd {min(summary['z_sd'].values()):.2f}-"
            f"{max(summary['z_sd'].values()):.2f}, w1's {summary['z_sd']['w1']:.2f})",
            f"w1 still lay {abs(worst):.1f} sd away (exit 0)")
    assert summary["exit_0_beyond_3_3_sd"] == 1


def test_the_fog_benches_with_the_models_own_flicker():
    """fog_thermal_bench.py --flicker markov: the misses follow the noise levels' inference,
    not the simulator's flicker."""
    runs = _results("fog_thermal_bench_markov")["runs"]
    smooth = _results("fog_thermal_bench_markov")["summary"]["smooth"]
    z_sd, known = smooth["z_sd"], smooth["z_sd_known_noise"]
    inside = smooth["inside_95"]
    far = {r["seed"]: r for r in runs
           if r["trustworthy"] and any(abs(v) > 3.3 for v in r["z"].values())}
    assert sorted(far) == [3, 13] and smooth["exit_0_beyond_3_3_sd"] == 2

    def ratio(seed, name):
        return far[seed]["noise_median"][name] / {"B_deg_h": 0.01, "K_deg_h_sqrt_h": 0.005}[name]

    _quoted(f"calibrated (z-scores' sd {min(known.values()):.2f}-{max(known.values()):.2f})",
            f"held the truths {inside['w0']}, {inside['w1']}, {inside['w2']} and "
            f"{inside['wD']} times of 30 (z-scores' sd {min(z_sd.values()):.2f}-"
            f"{max(z_sd.values()):.2f})",
            f"seed 3 (w1 {abs(far[3]['z']['w1']):.1f} sd) and seed 13 (wD "
            f"{abs(far[13]['z']['wD']):.1f} sd, {abs(far[13]['z_known_noise']['wD']):.1f} with "
            "the levels pinned)",
            f"lay at {ratio(3, 'B_deg_h'):.2f} and {ratio(3, 'K_deg_h_sqrt_h'):.2f}, and "
            f"{ratio(13, 'B_deg_h'):.2f} and {ratio(13, 'K_deg_h_sqrt_h'):.2f}, of their")
    higher = _results("fog_thermal_bench_markov_prior_hundredth")
    z_sd = higher["summary"]["smooth"]["z_sd"]
    worst = {r["seed"]: r["z"] for r in higher["runs"]
             if r["trustworthy"] and any(abs(v) > 3.3 for v in r["z"].values())}
    assert sorted(worst) == [13]
    seed3 = next(r["z"] for r in higher["runs"] if r["seed"] == 3)
    _quoted(f"the z-scores' sd fell to {min(z_sd.values()):.2f}-{max(z_sd.values()):.2f} and "
            f"seed 3's w1 lay {abs(seed3['w1']):.1f} sd away; seed 13's wD still lay "
            f"{abs(worst[13]['wD']):.1f} sd away")
    warm = _results("fog_thermal_bench_warmup_strong_markov")
    summary = warm["summary"]["smooth"]
    far = {r["seed"]: r["z"] for r in warm["runs"]
           if r["trustworthy"] and any(abs(v) > 3.3 for v in r["z"].values())}
    assert sorted(far) == [0, 13]
    _quoted(f"{summary['fits'] - summary['exit_3']} of 30 were trusted, the intervals held "
            f"the truths {min(summary['inside_95'].values())} to "
            f"{max(summary['inside_95'].values())} times of 30, tau's z-scores' sd was "
            f"{summary['z_sd']['tau_warmup_min']:.2f}",
            f"seed 0 (w1 {abs(far[0]['w1']):.1f} sd) and seed 13 (wD {abs(far[13]['wD']):.1f} sd)")


def test_the_fog_benches_with_a_warm_up():
    """experiments/results/fog_thermal_bench_warmup(_strong): thermal,warmup under the
    default noise, the time constant importance-sampled."""
    weak = _results("fog_thermal_bench_warmup")["summary"]["smooth"]
    strong_runs = _results("fog_thermal_bench_warmup_strong")["runs"]
    strong = _results("fog_thermal_bench_warmup_strong")["summary"]["smooth"]
    weighed = [sum(r["sampler"] == "psis" for r in _results(name)["runs"])
               for name in ("fog_thermal_bench_warmup", "fog_thermal_bench_warmup_strong")]
    _quoted(f"importance sampling weighed {weighed[0]} and {weighed[1]} of the 30 fits")
    trusted = [r for r in strong_runs if r["trustworthy"]]
    far = {r["seed"]: r["z"] for r in trusted if any(abs(v) > 3.3 for v in r["z"].values())}
    _quoted(f"{weak['exit_3']} of {weak['fits']} fits refused",
            f"the {weak['fits'] - weak['exit_3']} trusted had every truth within",
            f"the six truths {min(weak['inside_95'].values())} to "
            f"{max(weak['inside_95'].values())} times of 30",
            f"{len(trusted)} of {strong['fits']} were trusted",
            f"the truths {min(strong['inside_95'].values())} to "
            f"{max(strong['inside_95'].values())} times of 30",
            f"{len(far)} trusted fits had a truth more than 3.3 sd away",
            f"seed 8 (wD {far[8]['wD']:.1f} sd, tau {abs(far[8]['tau_warmup_min']):.1f})",
            f"seed 28 (tau {abs(far[28]['tau_warmup_min']):.1f};",
            f"their sd is {strong['z_sd']['tau_warmup_min']:.2f})")
    assert weak["exit_0_beyond_3_3_sd"] == 0
    windows = sorted({next(r for r in strong_runs if r["seed"] == s)["rate_window_s"]
                      for s in (8, 28)})
    _quoted(f"({windows[1]:.0f} and {windows[0]:.0f} s here)")


def test_the_noise_prior_dependence_on_the_fog_benches():
    """The warning noise_prior_dependence over the FOG bench studies (README)."""
    fog = _results("fog_thermal_bench")["summary"]
    markov = _results("fog_thermal_bench_markov")["summary"]["smooth"]
    white = _results("fog_thermal_bench_white_only")["summary"]["smooth"]
    static = _results("fog_thermal_bench_static_40h")["summary"]["smooth"]

    def span(summary):
        values = summary["sd_widening_median"].values()
        return f"{min(values):.2f}-{max(values):.2f}"

    studies = (fog["smooth"], fog["raised_cosine"], markov, white)
    assert all(s["noise_prior_dependence_warned"] == s["fits"] for s in studies)
    assert all(v == s["fits"] for s in studies for v in s["inside_allowed_range"].values())
    assert all(s["exit_0_beyond_3_3_sd_unwarned"] == 0 for s in (*studies, static))
    _quoted(f"warned on 30 of 30 smooth FOG logs (median ratios over the logs "
            f"{span(fog['smooth'])} across the four coefficients), 30 of 30 raised-cosine "
            f"ones ({span(fog['raised_cosine'])}), 30 of 30 with the model's own flicker "
            f"({span(markov)}) and 20 of 20 white-only logs ({span(white)}: larger",
            f"every truth on every one of those {sum(s['fits'] for s in studies)} logs",
            f"it warned on {static['noise_prior_dependence_warned']} of {static['fits']} "
            f"({span(static)})")
    weak = _results("fog_thermal_bench_warmup")["summary"]["smooth"]
    strong = _results("fog_thermal_bench_warmup_strong")
    missed = {r["seed"]: r["allowed_noise"]["warned"] for r in strong["runs"]
              if r["trustworthy"] and any(abs(v) > 3.3 for v in r["z"].values())}
    assert missed == {8: True, 28: True}
    strong = strong["summary"]["smooth"]
    _quoted(f"it warned on {weak['noise_prior_dependence_warned']} of {weak['fits']} (w = 0.05 "
            f"deg/h) and {strong['noise_prior_dependence_warned']} of {strong['fits']} (w = "
            "0.2 deg/h)")


def test_the_datasheet_priors_on_the_fog_benches():
    """``--noise FILE.toml`` on the smooth FOG benches (experiments/fog_thermal_bench.py
    --datasheet): coverage inside the binomial 99 % band at 95 %, and widths beside the
    default fit's interval and range on the same logs."""
    summary = _results("fog_thermal_bench_datasheet")["summary"]["smooth"]
    fits, inside = summary["fits"], summary["inside_95"]
    low = stats.binom.ppf(0.005, fits, 0.95)
    assert all(low <= n <= fits for n in inside.values())
    sheet = summary["datasheet"]
    ratio = sheet["width_over_default_interval"].values()
    over_range = sheet["width_over_default_range"].values()
    z = summary["z_sd"].values()
    runs = _results("fog_thermal_bench_datasheet")["runs"]
    far = [r for r in runs if any(abs(v) > 3.3 for v in r["z"].values())]
    assert [(r["seed"], r["allowed_noise"]["warned"], r["allowed_noise"]["inside_range"]["w1"])
            for r in far] == [(25, True, True)]
    _quoted(f"seed 25's w1 again {abs(far[0]['z']['w1']):.1f} sd away, warned")
    _quoted(f"trusted {fits - summary['exit_3']} of {fits} and held the truths "
            + ", ".join(str(inside[k]) for k in ("w0", "w1", "w2")) + f" and {inside['wD']} "
            f"times of {fits} (z-scores' sd {min(z):.2f}-{max(z):.2f}",
            f"were {min(ratio):.2f}-{max(ratio):.2f}x as wide as the default fit's",
            f"and {min(over_range):.2f}-{max(over_range):.2f}x the default's range")


def test_real_log_on_three_axes():
    r = json.loads((ROOT / "benchmarks" / "results_real_log.json").read_text())
    fit, compensate = (sorted(r["seconds_all"][k])[len(r["seconds_all"][k]) // 2]
                       for k in ("fit", "compensate"))
    assert not r["within_budget"] and set(r["exit_codes"].values()) == {0}
    _quoted(f"`gyroid fit --terms bias` took {fit:.1f} s and `gyroid compensate` "
            f"{compensate:.1f} s (medians of three), against {r['bare_s']:.2f} s",
            f"columns: {r['gyroid_over_bare']:.1f}x", f"floor ({r['import_floor_s']:.1f} s in "
            f"the same run): {r['budget_s']:.1f} s, not met")


def test_where_a_fit_s_time_goes():
    """benchmarks/results_profile_fit.json: one process's first and warm fit, its outputs,
    and a profiled warm fit's stages."""
    r = json.loads((ROOT / "benchmarks" / "results_profile_fit.json").read_text())
    seconds, stages = r["seconds"], r["stages_s"]
    assert seconds["first_fit"] > seconds["warm_fit"]  # "the difference JAX tracing"
    _quoted(f"the first fit in a process {seconds['first_fit']:.1f} s, a warm one "
            f"{seconds['warm_fit']:.1f} s",
            f"the figures {seconds['write']:.1f} s, {seconds['block_log_likelihoods']:.2f} s of "
            "it the block log-likelihoods",
            f"a warm fit spends {stages['rate_window_marginal_search']:.2f} s in the dT/dt",
            f"{stages['importance_sampling']:.2f} s in importance sampling, "
            f"{stages['rate_window_least_squares']:.2f} s in least squares' window",
            f"{stages['final_mode']:.2f} s in the final mode, "
            f"{stages['noise_priors_check']:.2f} s in the noise priors' check and "
            f"{stages['thermometer_rate_error_match']:.2f} s matching",
            f"{100 * r['compiled_share']:.0f} % of it in compiled XLA calls")


def test_a_new_run_compensated_with_a_pool():
    """experiments/results/pool_new_run_bands: a held-out FOG run's window means against the
    bands of its lot's pool."""
    import numpy as np

    record = _results("pool_new_run_bands")
    summary, lots = record["summary"], record["lots"]
    assert set(summary["pool_exit"]) == set(summary["compensate_exit"]) == {0}
    assert summary["window_bands_refused"] == 0
    halfwidths = [lot["band_halfwidth_deg_h"] for lot in lots]
    largest = max(abs(z) for lot in lots for z in lot["z"])
    seconds = [lot["seconds"] for lot in lots]
    _quoted(f"all {summary['windows']} window means of the {summary['scored']} new runs lay "
            f"inside their 95 %" if summary["in_band_min"] == 1.0 else "never",
            f"has an sd of {summary['z_sd_all_windows']:.2f} over all windows",
            f"the largest {largest:.2f})",
            f"half-widths {min(halfwidths):.3f}-{max(halfwidths):.2f} deg/h (median "
            f"{np.median(halfwidths):.2f})",
            f"A lot took {np.median(seconds):.0f} s (median), and up to {max(seconds):.0f} s",
            f"warned `between_run_sd_identified` on "
            f"{summary['pool_failed_checks']['between_run_sd_identified']} of {summary['lots']} "
            f"lots, and `noise_prior_dependence` on "
            f"{summary['pool_failed_checks']['noise_prior_dependence']})")


def test_a_held_out_cycle_after_a_bias_step():
    """The default fit predicts a held-out chamber cycle worse than least squares only
    where a bias step meets the temperature program's turn (dT/dt's jump), and refuses
    there; the same steps away from the turn leave its coefficients right."""
    results = _results("held_out_cycles")
    runs = results["runs"]

    def span(values, digits=2):
        low, high = f"{min(values):.{digits}f}", f"{max(values):.{digits}f}"
        return low if low == high else f"{low}-{high}"

    def z(variant, names):
        return [abs(r["default"]["z"][n]) for r in runs if r["variant"] == variant
                for n in names]

    steps, mid, none = (results[v] for v in ("steps", "steps_mid_cycle", "one_bias"))
    assert min(steps["default"]["held_out_over_least_squares"]) > 1.0
    assert steps["default"]["trustworthy"] == 0
    assert max(mid["default"]["held_out_over_least_squares"]) < 1.0
    assert max(z("steps_mid_cycle", ("w1", "w2", "wD"))) < 2.0
    assert none["default"]["trustworthy"] == len(none["least_squares_rms_deg_h"])
    stepped = [r["with_bias_step"] for r in runs if r["variant"] == "steps"]
    assert not any(r["trustworthy"] for r in stepped)
    assert all("rate_estimate" in r["failed"] and r["rate_window_s"] == 7200.0 for r in stepped)
    assert mid["default"]["trustworthy"] == 0
    added = [r["discrepancy_added"] for r in runs if r["variant"] == "steps"]
    assert all("bias_step" in a for a in added)
    times = [a["bias_step"]["t_step_h"] for a in added]
    _quoted(f"wD lies {span(z('steps', ('wD',)), 1)} sd below its truth, w1 and w2 "
            f"{span(z('steps', ('w1', 'w2')), 1)} sd",
            f"the walk K {span(steps['default']['K_deg_h_sqrt_h'], 1)} deg/h/sqrt(h)",
            f"{span(steps['default']['held_out_over_least_squares'])}x least squares'",
            f"names `bias_step` at {span(times, 1)} h",
            f"within {max(z('steps_mid_cycle', ('w1', 'w2', 'wD'))):.1f} sd of its truth and "
            f"predict {span(mid['default']['held_out_over_least_squares'])}x",
            f"the same ({span(none['default']['held_out_over_least_squares'])}x, all "
            f"{none['default']['trustworthy']} trusted)",
            f"the walk falls to {span(steps['with_bias_step']['K_deg_h_sqrt_h'])} and the "
            f"held-out error to {span(steps['with_bias_step']['held_out_over_least_squares'])}x")


def _way_spread(summary: dict, way: str, key: str,
                names: tuple[str, ...] | None = None) -> tuple[float, float]:
    """rate_error_edges: the least and greatest of a way's ``key`` over its coefficients
    (``names``, or all of them)."""
    per = summary["ways"][way]
    values = [per[n][key] for n in (per if names is None else names)]
    return min(values), max(values)


def test_the_thermometers_carrier_against_its_exact_covariance():
    """experiments/results/rate_error_edges: at the default fit's mode, the thermometer's
    noise as every fit carries it against that error's exact covariance (dense least squares
    on the same rows; its ``carried`` way is the fit's own mode), and the single oscillator
    fits carried before."""
    runs = _results("rate_error_edges")
    noisy, white, fine, fog = (runs[k]["summary"] for k in (
        "paper_a_0.05C", "paper_a_0.05C_white", "paper_a_0.01C", "fog_smooth_0.01C"))
    assert max(runs[k]["summary"]["mode_check_max"] for k in runs) < 1e-3
    moved = [_way_spread(s, "carried", "shift_median") for s in (noisy, white, fine, fog)]
    # under white noise alone the fit carries the exact covariance; what a process would do
    assert moved[1] == (0.0, 0.0) and white["one_sided_shift_sd"] is None
    instead = _way_spread(white, "oscillators_alone", "shift_median")
    widths = (_way_spread(noisy, "carried", "sd_ratio_min")[0],
              _way_spread(noisy, "carried", "sd_ratio_max")[1])
    former = _way_spread(noisy, "one_oscillator", "shift_median")
    power = noisy["low_frequency_power_ratio"]
    assert max(m[1] for m in moved) < 0.1 < former[0]
    _quoted(f"exact covariance's estimates to a median {moved[0][0]:.2f} to {moved[0][1]:.2f} "
            f"of their sd with a 0.05 degC thermometer (sds {widths[0]:.2f} to "
            f"{widths[1]:.2f} times the exact ones), {moved[2][0]:.2f} to {moved[2][1]:.2f} "
            f"with 0.01 degC and "
            f"{moved[3][1]:.2f} on the FOG bench above, over {noisy['seeds']} seeds each",
            f"with {power[0]:.2f} to {power[1]:.2f} of the estimator's power at low "
            f"frequencies and blind to the one-sided rows, moved them a median "
            f"{former[0]:.2f} to {former[1]:.2f}.",
            f"alike ({power[0]:.2f} to {power[1]:.2f} of the estimator's low-frequency power",
            f"Under white noise the fit carries the exact covariance; the process there would "
            f"have moved the estimates a median {instead[0]:.2f} to {instead[1]:.2f} of their "
            f"sd")
    # the one-sided rows weighed: read by the process on the FOG bench, exact on paper A's
    papers = (noisy, fine, runs["paper_a_0.05C_window_1200s"]["summary"])
    weighed = [s["one_sided_shift_sd"] for s in papers]
    alone = [_way_spread(s, "oscillators_alone", "shift_median") for s in papers]
    assert fog["one_sided_exact"] == 0 and all(s["one_sided_exact"] == s["seeds"]
                                               for s in papers)
    assert fog["one_sided_shift_sd"][1] <= 0.1 < min(w[0] for w in weighed)
    _quoted(f"Over the same seeds that was every FOG log ({fog['one_sided_shift_sd'][0]:.2f} "
            f"to {fog['one_sided_shift_sd'][1]:.2f} sd), and none of paper A's "
            f"({min(w[0] for w in weighed):.2f} to {max(w[1] for w in weighed):.2f}): there "
            f"a process alone moved them a median {min(a[0] for a in alone):.2f} to "
            f"{max(a[1] for a in alone):.2f}.")
