"""A three-axis real log fitted and compensated from the command line (issue 45), against
the NumPy script a user writes for it in an hour, in one run.

The log: the registry's ADIS16405 (``smac_imudata``, ``GYROID_DATA`` or the cache): its
first static run (10^6 rows at 100 Hz on three axes) trains, its second is compensated,
both as gyroid's CSV. gyroid: ``gyroid fit train.csv --terms bias --out fit`` (every
default: three axes, IEEE 952 noise, checks, figures) then ``gyroid compensate test.csv
--fit fit --out comp``, each a fresh process. The script (``bare``): pyarrow reads both
CSVs, least squares per axis (the bias: the mean, with its standard error), the compensated
columns written as CSV with pyarrow; a fresh process too. The import floor (the libraries
the contract's outputs need, as ``benchmarks/scaling.py`` measures it) is measured in the
same run. The issue's budget: gyroid within 3x the script plus that floor.

    python benchmarks/real_log.py --json benchmarks/results_real_log.json
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _report import report
from scaling import import_floor

import gyroid
from gyroid.io import dataset_logs
from gyroid.io._log_writer import write_bench_log

BARE = r'''
import itertools, sys
import numpy as np
import pyarrow as pa, pyarrow.csv as pacsv

def read(path):
    with open(path, "rb") as handle:
        skip = sum(1 for _ in itertools.takewhile(lambda l: l.startswith(b"#"), handle))
    return pacsv.read_csv(path, read_options=pacsv.ReadOptions(skip_rows=skip))

train, test = read(sys.argv[1]), read(sys.argv[2])
out = {"time_s": test["time_s"]}
for axis in "xyz":
    y = train[f"drift_{axis}_deg_h"].to_numpy()
    bias = y.mean()
    se = y.std(ddof=1) / np.sqrt(y.size)
    out[f"drift_{axis}_deg_h"] = test[f"drift_{axis}_deg_h"]
    out[f"compensated_{axis}_deg_h"] = pa.array(test[f"drift_{axis}_deg_h"].to_numpy() - bias)
    print(axis, bias, se)
pacsv.write_csv(pa.table(out), sys.argv[3])
'''


def _columns(run: dict) -> dict[str, np.ndarray]:
    return {name: np.asarray(values, dtype=float) for name, values in run.items()}


def _timed(command: list[str]) -> tuple[float, int]:
    start = time.perf_counter()
    code = subprocess.run(command, capture_output=True, text=True).returncode
    return time.perf_counter() - start, code


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    gyroid.configure()
    runs = dataset_logs("smac_imudata")
    train, test = (_columns(runs[f"adis_16405_imu{k}"][0]) for k in (1, 2))
    gyroid_exe = [sys.executable, "-m", "gyroid"]
    results: dict = {"date": time.strftime("%Y-%m-%d"), "rows_train": int(train["time_s"].size),
                     "rows_test": int(test["time_s"].size), "axes": 3, "terms": "bias",
                     "repeat": args.repeat}
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        write_bench_log(folder / "train.csv", train, ())
        write_bench_log(folder / "test.csv", test, ())
        timings: dict[str, list[float]] = {"fit": [], "compensate": [], "bare": []}
        codes: dict[str, int] = {}
        for k in range(args.repeat):
            fit_dir, comp_dir = folder / f"fit{k}", folder / f"comp{k}"
            seconds, codes["fit"] = _timed([*gyroid_exe, "fit", str(folder / "train.csv"),
                                            "--terms", "bias", "--out", str(fit_dir), "-q"])
            timings["fit"].append(seconds)
            seconds, codes["compensate"] = _timed(
                [*gyroid_exe, "compensate", str(folder / "test.csv"), "--fit", str(fit_dir),
                 "--out", str(comp_dir), "-q"])
            timings["compensate"].append(seconds)
            seconds, codes["bare"] = _timed([sys.executable, "-c", BARE,
                                             str(folder / "train.csv"),
                                             str(folder / "test.csv"),
                                             str(folder / f"bare{k}.csv")])
            timings["bare"].append(seconds)
    median = {name: sorted(v)[len(v) // 2] for name, v in timings.items()}
    floor = import_floor()["fit_modules"]["seconds"]
    gyroid_s = median["fit"] + median["compensate"]
    results.update({
        "seconds_all": timings, "exit_codes": codes, "import_floor_s": floor,
        "gyroid_fit_plus_compensate_s": gyroid_s, "bare_s": median["bare"],
        "budget_s": 3.0 * median["bare"] + floor,
        "gyroid_over_bare": gyroid_s / median["bare"],
        "within_budget": gyroid_s <= 3.0 * median["bare"] + floor,
    })
    report(results, args.json)


if __name__ == "__main__":
    main()
