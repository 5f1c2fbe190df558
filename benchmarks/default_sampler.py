"""The default fit's sampler against emcee, in one process, on paper A's thermal bench
(gyroid's simulator, seed 0: 37 200 rows), every other default kept (IEEE 952 noise, the
checks): wall time of warm fits (the first of each compiles and is not counted) and the
posterior means and sds each gives.

    python benchmarks/default_sampler.py --json benchmarks/results_default_sampler.json
"""

from __future__ import annotations

import argparse
import time
from datetime import date

import numpy as np
from _report import report

import gyroid
from gyroid.bench import fit_log
from gyroid.inference import Emcee, Importance
from gyroid.simulation import simulate_thermal_bench


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    gyroid.configure()
    log = simulate_thermal_bench(seed=0).log
    out = {"date": date.today().isoformat(), "rows": int(log.n), "repeats": args.repeats}
    for name, sampler in (("importance", Importance(fallback=Emcee(progress=False))),
                          ("emcee", Emcee(progress=False))):
        fit_log(log, "thermal", seed=100, sampler=sampler)  # compiles
        seconds, fits = [], []
        for k in range(args.repeats):
            started = time.perf_counter()
            fits.append(fit_log(log, "thermal", seed=k, sampler=sampler))
            seconds.append(time.perf_counter() - started)
        summary = fits[0].posterior.summary
        out[name] = {"median_seconds": float(np.median(seconds)),
                     "method": fits[0].posterior.method,
                     "trustworthy": all(f.trustworthy for f in fits),
                     "posterior": {k: {"mean": summary[k]["mean"], "sd": summary[k]["sd"]}
                                   for k in ("w0", "w1", "w2", "wD")}}
    out["ratio"] = out["emcee"]["median_seconds"] / out["importance"]["median_seconds"]
    report(out, args.json)


if __name__ == "__main__":
    main()
