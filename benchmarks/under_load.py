"""A warm in-process fit beside busy processes (issue 45): paper A's thermal bench (gyroid's
simulator, seed 0) fitted with every default by ``fit_log``, and by the bare script's fit
(``benchmarks/bare_thermal_fit.py``), each warm, the median of three, first on a quiet
machine and then with one busy process per core (a pure-Python loop each): does gyroid's
share of the machine fall further than the script's?

    python benchmarks/under_load.py --json benchmarks/results_under_load.json
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from datetime import date
from pathlib import Path

import numpy as np
from _report import report
from bare_thermal_fit import fit as bare_fit


def _median_seconds(run, repeats: int = 3) -> dict:
    run()  # warm: compiled, imported
    seconds = []
    for _ in range(repeats):
        started = time.perf_counter()
        run()
        seconds.append(time.perf_counter() - started)
    return {"seconds": float(np.median(seconds)), "seconds_all": seconds}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    import gyroid
    from gyroid.bench import fit_log
    from gyroid.io import write_bench_log
    from gyroid.simulation import simulate_thermal_bench

    gyroid.configure()
    log = simulate_thermal_bench(seed=0).log
    out: dict = {"date": date.today().isoformat(), "rows": int(log.n),
                 "cores": os.cpu_count()}
    with tempfile.TemporaryDirectory() as tmp:
        path = str(Path(tmp) / "bench.parquet")
        write_bench_log(path, log.columns)
        jobs = {"gyroid": lambda: fit_log(log, "thermal", seed=1),
                "bare": lambda: bare_fit(path)}
        out["quiet"] = {name: _median_seconds(job) for name, job in jobs.items()}
        busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                for _ in range(os.cpu_count() or 1)]
        try:
            out["loaded"] = {name: _median_seconds(job) for name, job in jobs.items()}
        finally:
            for process in busy:
                process.kill()
    for state in ("quiet", "loaded"):
        out[state]["ratio"] = out[state]["gyroid"]["seconds"] / out[state]["bare"]["seconds"]
    report(out, args.json)


if __name__ == "__main__":
    main()
