"""How gyroid's cost grows with a log's length, against the bare script a competent
researcher writes in an hour (benchmarks/bare_thermal_fit.py), in one run.

    python benchmarks/scaling.py --rows 1e4 1e5 1e6 1e7 --json benchmarks/results_scaling.json

For each length: a thermal bench log (paper A's schedule, sampled fast enough to give that
many rows over 10.3 h), written as parquet; then, each in a fresh process with its wall time
and peak memory (the process and its children):

* ``load``: gyroid's reader (every cell of every contract column validated, time checked;
  imports included) against ``pyarrow.parquet.read_table`` and a NumPy array per column
  (what a script fits from); building the model's inputs (dT/dt, the identifiability
  check) is part of ``fit``;
* ``fit``: ``gyroid fit LOG --terms thermal`` end to end, as a user runs it (``--noise
  auto``; reading, rate window choice, point fit, emcee to convergence, checks, fit.json,
  posterior.nc, figures);
* ``fit_ieee``: the same with ``--noise white+flicker+rw`` (IEEE 952's noise, the model
  ``--noise auto`` turns to; the log's block means, at most 1000, are filtered), up to
  ``--ieee-rows``;
* ``bare``: the bare script (read, Savitzky-Golay dT/dt, normal equations, emcee on
  sufficient statistics with DE moves for 3000 steps; no checks, no files);
* ``bare_correlated``: the bare script for correlated noise, what ``gyroid fit`` assumes
  by default (benchmarks/bare_correlated_fit.py: least squares, the residual's Allan slopes,
  generalised least squares on at most 1000 block means; no checks, no files);
* ``compensate``: ``gyroid compensate LOG --fit FIT`` (the log with its own fit; the
  compensated CSV, compensate.json, two figures, the checks) against ``bare_compensate``
  (benchmarks/bare_compensate.py: pyarrow, the same dT/dt and posterior means, a NumPy
  polynomial, the CSV, allantools before and after);
* ``discrepancy``: ``gyroid discrepancy LOG --terms thermal`` (up to ``--discrepancy-rows``).

``--gm-rows N``: a log of N rows with a Gauss-Markov bias instability (0.05 deg/h, 600 s
correlation time) beside the white noise, fitted with ``--noise white+gm``: its time, peak
memory, exit code and how far its coefficients and noise levels lie from the truth (in
posterior sd). A white-noise log would not do: white+gm's extra levels are not identified
there (its sampler runs to its cap and the fit is refused).

``imports`` (once per run, in fresh processes): the libraries alone, no work. ``bare``: what
the bare script imports (NumPy, pyarrow, SciPy's signal, emcee); ``fit_libraries``: what
``gyroid fit``'s outputs need on top (JAX in float64, equinox, optimistix, ArviZ with
matplotlib, xarray, and the dask and distributed that xarray imports to write netCDF);
``fit_modules``: gyroid's own modules a fit runs through, with those libraries. It is
the floor under a small log's fit: with twice the bare script as the budget, what is left
after the imports is what the fit's own work may cost.

``--repeat N`` runs each timed command N times and reports the median (every run's time is
kept in ``seconds_all``).

``--stream-rows N``: a log too long to hold (a day at ~1 kHz is 8.6e7 rows), written by
``gyroid simulate thermal --rate-hz F --format parquet`` chunk by chunk (``simulate_streamed``:
its time and peak memory), then only ``load_pyarrow`` and ``gyroid fit LOG --terms thermal``
with its default ``--noise auto``: gyroid reads it as a stream of batches reduced to block
means. The bare script, which holds every row, is not run at that length.

Both fits must agree (w1 and wD within 3 posterior sd of each other) or the row says so.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
_MEASURE = (
    "import json, resource, subprocess, sys, time\n"
    "start = time.perf_counter()\n"
    "done = subprocess.run(sys.argv[1:], capture_output=True, text=True)\n"
    "print(json.dumps({'seconds': time.perf_counter() - start, 'code': done.returncode,\n"
    "  'peak_mb': resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,\n"
    "  'stdout': done.stdout[-2000:], 'stderr': done.stderr[-2000:]}))\n"
)
_LOAD = (
    "import json, sys, time\n"
    "start = time.perf_counter()\n"
    "if sys.argv[1] == 'gyroid':\n"
    "    from gyroid.io import load_bench_log\n"
    "    load_bench_log(sys.argv[2])\n"
    "else:\n"
    "    import numpy as np, pyarrow.parquet as pq\n"
    "    table = pq.read_table(sys.argv[2])\n"
    "    columns = {c: np.asarray(table.column(c).to_numpy(), dtype=float)\n"
    "               for c in table.column_names}\n"
    "print(json.dumps({'seconds': time.perf_counter() - start}))\n"
)

#: What each import set loads (``imports``: see the module docstring).
_IMPORTS = {
    "bare": "import numpy, pyarrow.csv, pyarrow.parquet, scipy.signal, emcee",
    "fit_libraries": (
        "import warnings; warnings.simplefilter('ignore', FutureWarning)\n"
        "import numpy, pyarrow.csv, pyarrow.parquet, scipy.signal, emcee\n"
        "import jax; jax.config.update('jax_enable_x64', True)\n"
        "import equinox, optimistix, arviz, matplotlib.pyplot, dask, distributed"),
    "fit_modules": (
        "import gyroid._config; gyroid._config.configure()\n"
        "import gyroid.pipeline._fit_file, gyroid.reports._write, gyroid.plotting\n"
        "from gyroid.io._arviz import load_arviz; load_arviz()\n"
        "import dask, distributed"),
}


def import_floor() -> dict:
    """Seconds (median of :data:`REPEAT` fresh processes) each of :data:`_IMPORTS` takes."""
    timed = "import time; start = time.perf_counter()\n{}\nprint(time.perf_counter() - start)"
    floor = {}
    for name, code in _IMPORTS.items():
        runs = [float(subprocess.run([sys.executable, "-c", timed.format(code)],
                                     capture_output=True, text=True, check=True).stdout)
                for _ in range(REPEAT)]
        floor[name] = {"seconds": sorted(runs)[len(runs) // 2], "seconds_all": runs}
    return floor


#: Runs of each timed command (``--repeat``); the median time is reported, with every run's.
REPEAT = 1


def measure(*command: str) -> dict:
    """Wall time and peak memory of ``command`` in a fresh process: the median of
    :data:`REPEAT` runs (this machine's times vary by tens of per cent between runs), every
    run's time in ``seconds_all``."""
    runs = []
    for _ in range(REPEAT):
        out = subprocess.run([sys.executable, "-c", _MEASURE, *command], capture_output=True,
                             text=True, check=True)
        runs.append(json.loads(out.stdout))
    order = sorted(range(len(runs)), key=lambda i: runs[i]["seconds"])
    middle = dict(runs[order[len(runs) // 2]])
    middle["seconds_all"] = [r["seconds"] for r in runs]
    return middle


def make_log(rows: int, folder: Path, seed: int = 1, name: str | None = None) -> Path:
    """Paper A's thermal schedule sampled fast enough for ``rows`` rows, simulated with
    ``seed``, as ``folder/NAME.parquet`` (default name: the row count)."""
    from gyroid.io import write_bench_log
    from gyroid.simulation import ThermalProtocol, simulate_thermal_bench

    protocol = ThermalProtocol()
    rate_hz = rows / protocol.duration_s
    sim = simulate_thermal_bench(seed=seed, protocol=protocol.stretched(None, rate_hz))
    path = folder / f"{name or f'thermal_{rows:.0e}'}.parquet"
    write_bench_log(path, sim.log.columns)
    return path


def streamed_length(rows: int, folder: Path) -> dict:
    """A log of ``rows`` rows (paper A's schedule, sampled ``rows`` times) written by
    ``gyroid simulate thermal --format parquet``, chunk by chunk; pyarrow reading it; gyroid
    fitting it as a stream."""
    from gyroid.simulation import ThermalProtocol

    rate_hz = rows / ThermalProtocol().duration_s
    simulate = measure(sys.executable, "-m", "gyroid", "simulate", "thermal", "--rate-hz",
                       repr(rate_hz), "--format", "parquet", "--seed", "1",
                       "--out", str(folder / "simulated"))
    log = folder / "simulated" / "bench.parquet"
    if simulate["code"] != 0:
        return {"rows": rows, "simulate_streamed": simulate}
    import pyarrow.parquet as pq

    row: dict = {"rows": pq.read_metadata(log).num_rows, "rate_hz": rate_hz,
                 "simulate_streamed": {k: simulate[k] for k in ("seconds", "peak_mb", "code")}}
    load = measure(sys.executable, "-c", _LOAD, "pyarrow", str(log))
    row["load_pyarrow"] = {"seconds": json.loads(load["stdout"])["seconds"],
                           "peak_mb": load["peak_mb"]}
    fit_dir = folder / f"fit_{rows:.0e}"
    fit = measure(sys.executable, "-m", "gyroid", "fit", str(log), "--terms", "thermal",
                  "--out", str(fit_dir), "--no-progress")
    row["fit_streamed"] = {k: fit[k] for k in ("seconds", "peak_mb", "code")}
    if fit["code"] in (0, 3):
        record = json.loads((fit_dir / "fit.json").read_text())
        truth = json.loads((folder / "simulated" / "truth.json").read_text())["parameters"]
        row["fit_streamed"] |= {
            "block_means": record["block_means"], "noise_choice": record["noise_choice"],
            "failed": [c for c, v in record["checks"].items() if not v["passed"]],
            "mean": {k: record["posterior"][k]["mean"] for k in ("w0", "w1", "w2", "wD")},
            "sd": {k: record["posterior"][k]["sd"] for k in ("w0", "w1", "w2", "wD")},
            "truth": {k: truth[k] for k in ("w0", "w1", "w2", "wD")}}
    else:
        row["fit_streamed"]["stderr"] = fit["stderr"]
    log.unlink()
    return row


#: The correlated part of ``--gm-rows``' logs: a bias instability and its correlation time.
GM_NOISE = {"bias_instability_deg_h": 0.05, "correlation_time_s": 600.0}


def gm_length(rows: int, folder: Path) -> dict:
    """A thermal log of ``rows`` rows with white + Gauss-Markov noise (:data:`GM_NOISE`),
    fitted with ``--noise white+gm``; the fit's distance from the truth in posterior sd."""
    from gyroid.io import write_bench_log
    from gyroid.simulation import GyroNoise, ThermalProtocol, simulate_thermal_bench

    protocol = ThermalProtocol()
    noise = GyroNoise(**GM_NOISE)
    sim = simulate_thermal_bench(seed=2, noise=noise,
                                 protocol=protocol.stretched(None, rows / protocol.duration_s))
    log = folder / f"gm_{rows:.0e}.parquet"
    write_bench_log(log, sim.log.columns)
    out = folder / f"fit_gm_{rows:.0e}"
    fit = measure(sys.executable, "-m", "gyroid", "fit", str(log), "--terms", "thermal",
                  "--noise", "white+gm", "--out", str(out), "--no-progress")
    row: dict = {"rows": rows, "gm_noise": GM_NOISE,
                 "fit_gm": {k: fit[k] for k in ("seconds", "seconds_all", "peak_mb", "code")}}
    if fit["code"] not in (0, 3):
        row["fit_gm"]["stderr"] = fit["stderr"]
        return row
    record = json.loads((out / "fit.json").read_text())
    truth = {**sim.truth["parameters"], "sigma_deg_h": sim.truth["noise"]["white_sd_deg_h"],
             "sigma_gm_deg_h": noise.bias_instability_deg_h / 0.6174,
             "tau_gm_s": noise.correlation_time_s}
    posterior = {**record["posterior"], **record["noise"]["posterior"]}
    row["fit_gm"] |= {
        "block_means": record["block_means"],
        "failed": [c for c, v in record["checks"].items() if not v["passed"]],
        "steps": record["convergence"]["sampler"]["steps"],
        "z": {k: (posterior[k]["mean"] - truth[k]) / posterior[k]["sd"] for k in truth},
        "truth": truth}
    return row


def one_length(rows: int, folder: Path, discrepancy_rows: int, ieee_rows: int) -> dict:
    log = make_log(rows, folder)
    row: dict = {"rows": rows}
    for reader in ("gyroid", "pyarrow"):
        # Peak memory through the wrapper: a process forked from this one (which has just
        # simulated the log) would report this one's peak as its own.
        load = measure(sys.executable, "-c", _LOAD, reader, str(log))
        row[f"load_{reader}"] = {"seconds": json.loads(load["stdout"])["seconds"],
                                 "peak_mb": load["peak_mb"]}
    fit_dir = folder / f"fit_{rows:.0e}"
    fit = measure(sys.executable, "-m", "gyroid", "fit", str(log), "--terms", "thermal",
                  "--out", str(fit_dir), "--no-progress")
    row["fit"] = {k: fit[k] for k in ("seconds", "seconds_all", "peak_mb", "code")}
    if rows <= ieee_rows:
        ieee_dir = folder / f"fit_ieee_{rows:.0e}"
        ieee = measure(sys.executable, "-m", "gyroid", "fit", str(log), "--terms", "thermal",
                       "--out", str(ieee_dir), "--no-progress", "--noise", "white+flicker+rw")
        row["fit_ieee"] = {k: ieee[k] for k in ("seconds", "peak_mb", "code")}
        if ieee["code"] in (0, 3):
            record = json.loads((ieee_dir / "fit.json").read_text())
            row["fit_ieee"]["block_means"] = record["block_means"]
            row["fit_ieee"]["sd"] = {k: record["posterior"][k]["sd"]
                                     for k in ("w0", "w1", "w2", "wD")}
        else:
            row["fit_ieee"]["stderr"] = ieee["stderr"]
    for key, script in (("bare", "bare_thermal_fit.py"),
                        ("bare_correlated", "bare_correlated_fit.py")):
        bare = measure(sys.executable, str(HERE / script), str(log))
        row[key] = {k: bare[k] for k in ("seconds", "seconds_all", "peak_mb", "code")}
        if bare["code"] == 0:
            row[key].update(json.loads(bare["stdout"].strip().splitlines()[-1]))
    bare = row["bare"]
    if fit["code"] in (0, 3):
        row |= compensate_rows(log, fit_dir, folder)
        record = json.loads((fit_dir / "fit.json").read_text())
        row["fit"]["noise_choice"] = record["noise_choice"]
        posterior = record["posterior"]
        row["fit"]["mean"] = {k: posterior[k]["mean"] for k in ("w0", "w1", "w2", "wD")}
        row["fit"]["sd"] = {k: posterior[k]["sd"] for k in ("w0", "w1", "w2", "wD")}
        if bare["code"] == 0:
            row["agree"] = all(
                abs(row["fit"]["mean"][k] - row["bare"]["mean"][k]) < 3 * row["fit"]["sd"][k]
                for k in ("w1", "wD"))
    else:
        row["fit"]["stderr"] = fit["stderr"]
    if rows <= discrepancy_rows:
        disc = measure(sys.executable, "-m", "gyroid", "discrepancy", str(log), "--terms",
                       "thermal", "--out", str(folder / f"disc_{rows:.0e}"))
        row["discrepancy"] = {k: disc[k] for k in ("seconds", "peak_mb", "code")}
    return row


def compensate_rows(log: Path, fit_dir: Path, folder: Path) -> dict:
    """``gyroid compensate`` of the log with its own fit, against the bare compensation
    (benchmarks/bare_compensate.py: the same posterior means, no figures or checks)."""
    out = folder / f"comp_{log.stem}"
    gyroid = measure(sys.executable, "-m", "gyroid", "compensate", str(log), "--fit",
                     str(fit_dir), "--out", str(out))
    bare = measure(sys.executable, str(HERE / "bare_compensate.py"), str(log), str(fit_dir),
                   str(folder / f"bare_{log.stem}.csv"))
    keys = ("seconds", "seconds_all", "peak_mb", "code")
    row = {"compensate": {k: gyroid[k] for k in keys},
           "bare_compensate": {k: bare[k] for k in keys}}
    if gyroid["code"] in (0, 3):
        row["compensate"]["rms_after_deg_h"] = json.loads(
            (out / "compensate.json").read_text())["rms_after_deg_h"]
    if bare["code"] == 0:
        row["bare_compensate"].update(json.loads(bare["stdout"].strip().splitlines()[-1]))
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", nargs="*", type=float, default=[1e4, 1e5, 1e6])
    parser.add_argument("--discrepancy-rows", type=float, default=1e6)
    parser.add_argument("--ieee-rows", type=float, default=1e6)
    parser.add_argument("--stream-rows", nargs="*", type=float, default=[])
    parser.add_argument("--gm-rows", nargs="*", type=float, default=[])
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--repeat", type=int, default=1,
                        help="runs of each timed command; the median is reported")
    args = parser.parse_args()
    global REPEAT
    REPEAT = max(1, args.repeat)
    results = []
    imports = import_floor()
    print(json.dumps({"imports": imports}), flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for rows in args.stream_rows:
            started = time.perf_counter()
            results.append(streamed_length(int(rows), Path(tmp)))
            print(json.dumps(results[-1]), f"({time.perf_counter() - started:.0f} s)",
                  flush=True)
        for rows in args.gm_rows:
            started = time.perf_counter()
            results.append(gm_length(int(rows), Path(tmp)))
            print(json.dumps(results[-1]), f"({time.perf_counter() - started:.0f} s)",
                  flush=True)
        for rows in args.rows:
            started = time.perf_counter()
            row = one_length(int(rows), Path(tmp), int(args.discrepancy_rows),
                             int(args.ieee_rows))
            results.append(row)
            print(json.dumps(row), f"({time.perf_counter() - started:.0f} s)", flush=True)
    if args.json:
        from gyroid.io import atomic_write_text

        atomic_write_text(args.json, json.dumps({"command": " ".join(sys.argv),
                                                 "imports": imports, "results": results},
                                                indent=1))


if __name__ == "__main__":
    main()
