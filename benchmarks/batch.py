"""Many small logs at once (issue 45): ``gyroid batch`` of 40 thermal logs of 10^4 rows on
two Dask workers, against the bare script's fit (``benchmarks/bare_thermal_fit.py``:
pyarrow, a Savitzky-Golay dT/dt, the normal equations, vectorised emcee with DE moves on
sufficient statistics) looped over the same logs in one process, as a research script
would. Each command in a fresh process: wall time, and the peak memory of its largest
process (a worker's, for the batch); ``gyroid batch`` twice: with its default noise
(IEEE 952, importance-sampled) and with ``--noise white``, the model the bare script fits.
Paper A's thermal schedule, one seed per log.

    python benchmarks/batch.py --logs 40 --rows 1e4 --json benchmarks/results_batch.json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from datetime import date
from pathlib import Path

from _report import report
from scaling import make_log, measure

_LOOP = """
import sys
sys.path.insert(0, {here!r})
from bare_thermal_fit import fit
for path in sys.argv[1:]:
    fit(path)
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", type=int, default=40)
    parser.add_argument("--rows", type=float, default=1e4)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    here = str(Path(__file__).resolve().parent)
    out: dict = {"date": date.today().isoformat(), "logs": args.logs, "rows": int(args.rows),
                 "workers": args.workers}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        paths = [str(make_log(int(args.rows), folder, seed=seed, name=f"log_{seed:03d}"))
                 for seed in range(1, args.logs + 1)]
        batch = [sys.executable, "-m", "gyroid", "batch", *paths, "--terms", "thermal",
                 "--workers", str(args.workers), "-q"]
        out["gyroid_batch"] = measure(*batch, "--out", str(folder / "default"))
        out["gyroid_batch_white"] = measure(*batch, "--noise", "white", "--out",
                                            str(folder / "white"))
        for name in ("default", "white"):
            summary = json.loads((folder / name / "batch.json").read_text())
            key = "gyroid_batch" if name == "default" else "gyroid_batch_white"
            out[key]["failed"] = len(summary["failed"])
            out[key]["fitted"] = len(summary["logs"]) - out[key]["failed"]
        out["bare_loop"] = measure(sys.executable, "-c", _LOOP.format(here=here), *paths)
    for key in ("gyroid_batch", "gyroid_batch_white"):
        out[f"{key}_over_bare"] = out[key]["seconds"] / out["bare_loop"]["seconds"]
    report(out, args.json)


if __name__ == "__main__":
    main()
