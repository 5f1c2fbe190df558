"""Experiment (issue 43): every real log in the registry, held out, gyroid's defaults against
what a user without gyroid writes, on the same rows.

Each case trains on part of a real log and predicts the rest: its held-out window means
(means over ``--window`` seconds of the measured drift) against each method's prediction.
Methods, all fitted on the training rows only:

* gyroid: ``gyroid fit TRAIN --terms TERMS`` with every default (``--noise auto``), then
  ``gyroid compensate TEST``: its ``compensated_means.csv`` (the predictive band of each
  window mean: model and noise) and both exit codes (0: the fit or compensation calls itself
  usable; 3: refused);
* least squares: ordinary least squares in the same regressors as a script would take them
  (the bias; with a thermometer, the bias and the temperature), its band the OLS interval of
  the window mean (model standard error and the residual sd over root n, white noise);
* cubic: the PX4 recipe (``process_sensor_caldata.py``: a 3rd-order ``numpy.polyfit`` of the
  rate against the temperature about the range's midpoint; ArduPilot's tempcal fits the same
  cubic about 35 degC and drops the constant, which its start-up gyro calibration sets, so
  its prediction of a window mean is this one's), no band.

Cases (``GYROID_DATA`` holds the logs as ``../shared/data/real/``):

* pan_tvac: LSM6DSM in thermal vacuum, 25 bursts; even bursts train, odd test
  (interpolation in temperature); windows of one burst;
* astropi_sensehat: 81 h; the first half trains, the second tests; 10-minute windows;
* mpu6050: the 10-minute run trains, each other run of the unit tests (other orientations
  and days); 15-second windows, bias and bias + temperature;
* adis16405: run 1 trains, runs 2-6 test, bias only (no thermometer); 10-minute windows;
  and again with each test run's first 600 s setting its bias (``--rezero 600``, a
  firmware's start-up calibration; the windows then start after it, and the start-up mean
  is a peer's prediction too);
* pooled (``gyroid pool`` of the unit's other runs, each under its default noise; the
  held-out run compensated with the pool's predictive for a new run): each ADIS16405 run
  and each MPU6050 run held out in turn, bias only; least squares is then the mean of the
  other runs' rows.

A test run that is another power-on than the training rows' (the MPU6050's and ADIS16405's
other runs) is compensated with ``--another-run``: a fit of one run cannot state another
run's turn-on bias, so gyroid refuses those unless the training is a pool of runs.

A training set shared by several cases is fitted once.

    python experiments/real_log_study.py
    python experiments/real_log_study.py --resummarise  # the summary of the runs on file
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np
from _common import results_dir, save_run

import gyroid
from gyroid.cli import main as gyroid_main
from gyroid.io import atomic_write_text, dataset_logs, json_text
from gyroid.io._log_writer import write_bench_log

Z95 = 1.959963984540054
#: The peers' recipes compared (each where the case has it).
PEERS = ("least_squares", "cubic", "startup_mean")
#: The start-up calibration of the ADIS16405's other runs, s.
REZERO_S = 600.0


def _cases() -> list[dict]:
    """Every case: name, axis, training and test columns (contract names), terms, window."""
    cases = []
    pan = dataset_logs("pan_tvac")["pan_tvac"][0]
    burst = np.concatenate([[0], np.cumsum(np.diff(pan["time_s"]) > 60.0)])
    for axis in "xyz":
        cases.append(_case("pan_tvac", axis, pan, burst % 2 == 0, burst % 2 == 1,
                           "bias,temperature", 60.0))
    astro = dataset_logs("astropi_sensehat")["astropi_sensehat"][0]
    half = astro["time_s"] < 0.5 * astro["time_s"][-1]
    for axis in "xyz":
        cases.append(_case("astropi_sensehat", axis, astro, half, ~half, "thermal", 600.0))
    mpu = dataset_logs("mpu6050_sunsided")
    train_name = "mpu6050_set2_unmoved-with-x-pointing-forward-10min"
    for name, (columns, _) in mpu.items():
        if name == train_name:
            continue
        for axis in "xyz":
            for terms in ("bias", "bias,temperature"):
                train = mpu[train_name][0]
                cases.append(_case(f"mpu6050 -> {name.removeprefix('mpu6050_')}", axis,
                                   (train, columns), None, None, terms, 15.0,
                                   trained_on=train_name))
    adis = dataset_logs("smac_imudata")
    for k in range(2, 7):
        train, test = adis["adis_16405_imu1"][0], adis[f"adis_16405_imu{k}"][0]
        for axis in "xyz":
            cases.append(_case(f"adis16405 run 1 -> {k}", axis, (train, test), None,
                               None, "bias", 600.0, trained_on="adis_16405_imu1"))
    for k in range(2, 7):
        train, test = adis["adis_16405_imu1"][0], adis[f"adis_16405_imu{k}"][0]
        for axis in "xyz":
            case = _case(f"adis16405 run 1 -> {k}, start-up", axis, (train, test), None,
                         None, "bias", 600.0, trained_on="adis_16405_imu1")
            cases.append(case | {"rezero_s": REZERO_S})
    adis_runs = {name: log for name, log in adis.items() if name.startswith("adis_16405")}
    for unit, runs, window_s in (("adis16405", adis_runs, 600.0), ("mpu6050", mpu, 15.0)):
        names = sorted(runs)
        for held in names:
            for axis in "xyz":
                cases.append(_pooled_case(unit, held, axis, runs, window_s))
    return cases


def _pooled_case(unit: str, held: str, axis: str, runs: dict, window_s: float) -> dict:
    """The unit's other runs pooled, ``held`` predicted; least squares on their rows."""
    others = [_axis_columns(runs[name][0], axis) for name in sorted(runs) if name != held]
    train = {k: np.concatenate([o[k] for o in others]) for k in ("time_s", "drift_deg_h")}
    test = _axis_columns(runs[held][0], axis)
    short = held.removeprefix("adis_16405_").removeprefix("mpu6050_")
    return {"case": f"{unit} pooled -> {short}", "axis": axis, "train": train, "test": test,
            "terms": "bias", "window_s": window_s, "pool": others, "another_run": True,
            "fit_key": (f"{unit} without {held}", axis, "bias")}


def _case(name, axis, columns, train_rows, test_rows, terms, window_s, trained_on=None
          ) -> dict:
    if isinstance(columns, tuple):
        train, test = (_axis_columns(c, axis) for c in columns)
    else:
        both = _axis_columns(columns, axis)
        train = {k: v[train_rows] for k, v in both.items()}
        test = {k: v[test_rows] for k, v in both.items()}
    return {"case": name, "axis": axis, "train": train, "test": test, "terms": terms,
            "window_s": window_s, "another_run": trained_on is not None,
            "fit_key": (trained_on or name, axis, terms)}


def _axis_columns(columns: dict, axis: str) -> dict:
    out = {"time_s": np.asarray(columns["time_s"], dtype=float),
           "drift_deg_h": np.asarray(columns[f"drift_{axis}_deg_h"], dtype=float)}
    if "temperature_C" in columns:
        out["temperature_C"] = np.asarray(columns["temperature_C"], dtype=float)
    return out


def _windows(time_s: np.ndarray, window_s: float) -> np.ndarray:
    """Each row's window (consecutive windows of ``window_s`` from the first row), as
    ``gyroid compensate --window`` forms them."""
    index = np.floor((time_s - time_s[0]) / window_s).astype(int)
    return np.unique(index, return_inverse=True)[1]


def _peers(case: dict, part: np.ndarray, test: dict) -> dict:
    """Least squares and the cubic: each window mean's prediction (and least squares'
    band) on the scored rows ``test``; with a start-up calibration, its mean too (a
    firmware's recipe: the bias is the mean of the first seconds at rest)."""
    train = case["train"]
    n = int(part.max()) + 1
    counts = np.bincount(part, minlength=n)
    thermal = "temperature" in case["terms"] and "temperature_C" in train
    design = (np.column_stack([np.ones(train["time_s"].size), train["temperature_C"]])
              if thermal else np.ones((train["time_s"].size, 1)))
    new = (np.column_stack([np.ones(test["time_s"].size), test["temperature_C"]])
           if thermal else np.ones((test["time_s"].size, 1)))
    beta, *_ = np.linalg.lstsq(design, train["drift_deg_h"], rcond=None)
    residual = train["drift_deg_h"] - design @ beta
    sigma2 = float(residual @ residual) / max(1, residual.size - design.shape[1])
    covariance = sigma2 * np.linalg.inv(design.T @ design)
    mean_design = np.column_stack([np.bincount(part, new[:, j], n) / counts
                                   for j in range(new.shape[1])])
    ls = mean_design @ beta
    half = Z95 * np.sqrt(np.einsum("ij,jk,ik->i", mean_design, covariance, mean_design)
                         + sigma2 / counts)
    out = {"least_squares": (ls, ls - half, ls + half)}
    if "temperature_C" in train and np.ptp(train["temperature_C"]) > 0:
        mid = 0.5 * (train["temperature_C"].min() + train["temperature_C"].max())
        coefficients = np.polyfit(train["temperature_C"] - mid, train["drift_deg_h"], 3)
        cubic = np.polyval(coefficients, test["temperature_C"] - mid)
        out["cubic"] = (np.bincount(part, cubic, n) / counts, None, None)
    return out


def one(case: dict, folder: Path, seed: int, fits: dict) -> dict:
    """One case; ``fits`` holds the fits (folder, exit code) made so far, by training set."""
    started = time.time()
    write_bench_log(folder / "test.csv", case["test"], ())
    if case["fit_key"] not in fits and "pool" in case:
        paths = [folder / f"run{k}.csv" for k in range(len(case["pool"]))]
        for path, columns in zip(paths, case["pool"], strict=True):
            write_bench_log(path, columns, ())
        code = gyroid_main(["pool", *map(str, paths), "--terms", case["terms"], "--out",
                            str(folder / "fit"), "--seed", str(seed)])
        fits[case["fit_key"]] = (folder / "fit", code)
    elif case["fit_key"] not in fits:
        write_bench_log(folder / "train.csv", case["train"], ())
        code = gyroid_main(["fit", str(folder / "train.csv"), "--terms", case["terms"],
                            "--out", str(folder / "fit"), "--seed", str(seed)])
        fits[case["fit_key"]] = (folder / "fit", code)
    fit_dir, fit_code = fits[case["fit_key"]]
    result = {"case": case["case"], "axis": case["axis"], "terms": case["terms"],
              "window_s": case["window_s"], "fit_exit": fit_code,
              "pooled": "pool" in case, "another_run": case["another_run"],
              "rezero_s": case.get("rezero_s")}
    test, rezero = case["test"], case.get("rezero_s")
    startup = (test["time_s"] < test["time_s"][0] + rezero if rezero
               else np.zeros(test["time_s"].size, dtype=bool))
    test = {k: v[~startup] for k, v in test.items()}
    part = _windows(test["time_s"], case["window_s"])
    n = int(part.max()) + 1
    measured = np.bincount(part, test["drift_deg_h"], n) / np.bincount(part, minlength=n)
    methods = _peers(case, part, test)
    if rezero:
        methods["startup_mean"] = (np.full(n, np.mean(case["test"]["drift_deg_h"][startup])),
                                   None, None)
    if fit_code in (0, 3):
        compensate_code = gyroid_main(
            ["compensate", str(folder / "test.csv"), "--fit", str(fit_dir), "--out",
             str(folder / "comp"), "--window", str(case["window_s"])]
            + (["--another-run"] if case["another_run"] else [])
            + (["--rezero", str(rezero)] if rezero else []))
        result["compensate_exit"] = compensate_code
        if compensate_code in (0, 3):
            rows = list(csv.DictReader(open(folder / "comp" / "compensated_means.csv")))
            column = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}
            assert np.allclose(column["drift_mean_deg_h"], measured, rtol=1e-6, atol=1e-6)
            methods["gyroid"] = (column["model_mean_deg_h"], column["band95_lo_deg_h"],
                                 column["band95_hi_deg_h"])
    result["windows"] = n
    for method, (predicted, low, high) in methods.items():
        error = measured - predicted
        entry = {"rms_deg_h": float(np.sqrt(np.mean(error**2)))}
        if low is not None and np.all(np.isfinite(low)):
            entry["band_holds"] = float(np.mean((measured >= low) & (measured <= high)))
        result[method] = entry
    result["seconds"] = round(time.time() - started, 1)
    return result


def summarise(runs: list[dict]) -> dict:
    gyroid_runs = [r for r in runs if "gyroid" in r]
    trusted = [r for r in gyroid_runs if r["fit_exit"] == 0 and r.get("compensate_exit") == 0]
    best_peer = [min(r[m]["rms_deg_h"] for m in PEERS if m in r)
                 for r in gyroid_runs]
    ratio = [r["gyroid"]["rms_deg_h"] / b for r, b in zip(gyroid_runs, best_peer, strict=True)]
    trusted_ratio = [x for r, x in zip(gyroid_runs, ratio, strict=True) if r in trusted]
    return {
        "cases": len(runs),
        "gyroid_predicted": len(gyroid_runs),
        "trusted_rms_over_best_peer_median": float(np.median(trusted_ratio or [math.nan])),
        "trusted_rms_over_best_peer_max": float(max(trusted_ratio, default=math.nan)),
        "trusted_no_worse_than_best_peer": sum(x <= 1.0 + 1e-9 for x in trusted_ratio),
        "gyroid_trusted": len(trusted),
        "trusted_holding_80pct": sum(r["gyroid"]["band_holds"] >= 0.8 for r in trusted),
        "trusted_band_holds_min": min((r["gyroid"]["band_holds"] for r in trusted),
                                      default=math.nan),
        "untrusted_band_holds_median": float(np.median(
            [r["gyroid"]["band_holds"] for r in gyroid_runs if r not in trusted] or [math.nan])),
        "least_squares_band_holds_median": float(np.median(
            [r["least_squares"]["band_holds"] for r in runs])),
        "gyroid_rms_over_best_peer_median": float(np.median(ratio)),
        "gyroid_no_worse_than_best_peer": sum(x <= 1.0 + 1e-9 for x in ratio),
        "gyroid_rms_over_best_peer_max": float(max(ratio)),
        **_by_kind(runs, trusted),
    }


def _by_kind(runs: list[dict], trusted: list[dict]) -> dict:
    """The pooled cases, and the single-run fits applied to another power-on."""
    pooled = [r for r in runs if r.get("pooled")]
    single = [r for r in runs if r.get("another_run") and not r.get("pooled")
              and not r.get("rezero_s")]
    startup = [r for r in runs if r.get("rezero_s")]
    pooled_trusted = [r for r in pooled if r in trusted]
    return {
        "pooled_cases": len(pooled),
        "pooled_trusted": len(pooled_trusted),
        "pooled_trusted_holding_80pct": sum(r["gyroid"]["band_holds"] >= 0.8
                                            for r in pooled_trusted),
        "pooled_trusted_band_holds_median": float(np.median(
            [r["gyroid"]["band_holds"] for r in pooled_trusted] or [math.nan])),
        "pooled_least_squares_band_holds_median": float(np.median(
            [r["least_squares"]["band_holds"] for r in pooled] or [math.nan])),
        "another_run_single_fit_cases": len(single),
        "another_run_single_fit_refused": sum(r.get("compensate_exit") == 3 for r in single),
        "startup_cases": len(startup),
        "startup_trusted": sum(r in trusted for r in startup),
        "startup_trusted_holding_80pct": sum(r["gyroid"]["band_holds"] >= 0.8
                                             for r in startup if r in trusted),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--only", default=None, help="run the cases whose name starts so")
    parser.add_argument("--resummarise", action="store_true",
                        help="recompute the summary of the results file's runs (no fits)")
    args = parser.parse_args()
    if args.resummarise:
        path = results_dir("real_log_study") / "results.json"
        record = json.loads(path.read_text())
        record["results"]["summary"] = summarise(record["results"]["runs"])
        atomic_write_text(path, json_text(record))
        print(json.dumps(record["results"]["summary"], indent=2))
        return
    gyroid.configure()
    started = time.time()
    runs, fits = [], {}
    with tempfile.TemporaryDirectory() as scratch:
        for k, case in enumerate(_cases()):
            if args.only and not case["case"].startswith(args.only):
                continue
            folder = Path(scratch) / f"case_{k:03d}"
            folder.mkdir()
            runs.append(one(case, folder, args.seed, fits))
            print(runs[-1], flush=True)
    save_run(results_dir("real_log_study"), seed=args.seed, config={"only": args.only},
             results={"summary": summarise(runs), "runs": runs}, started=started)


if __name__ == "__main__":
    main()
