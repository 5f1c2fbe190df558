"""The discrepancy search on one long axis (issue 45: a 90 000-row axis in under 60 s):
paper A's thermal bench simulated for 25 h at 1 Hz (``gyroid simulate thermal``), as is and
with a hidden start-up transient, each searched by ``gyroid discrepancy LOG --terms
thermal`` in a fresh process (wall time, peak memory, what it added).

    python benchmarks/discrepancy_long.py --json benchmarks/results_discrepancy_long.json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from datetime import date
from pathlib import Path

from _report import report
from scaling import measure

#: The logs searched: a name and the ``gyroid simulate thermal`` effect switched on (or none).
CASES = {"plain": None, "hidden_warmup": "warmup:w_warmup=0.5,tau_warmup_min=30"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=25.0)
    parser.add_argument("--rate-hz", type=float, default=1.0)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    out: dict = {"date": date.today().isoformat(), "hours": args.hours,
                 "rate_hz": args.rate_hz, "cases": {}}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name, effect in CASES.items():
            simulate = [sys.executable, "-m", "gyroid", "simulate", "thermal", "--hours",
                        str(args.hours), "--rate-hz", str(args.rate_hz), "--out",
                        str(folder / name), "-q"]
            made = measure(*simulate, *(("--effect", effect) if effect else ()))
            log = folder / name / "bench.csv"
            rows = sum(1 for line in log.open() if line[:1].isdigit())
            search = measure(sys.executable, "-m", "gyroid", "discrepancy", str(log),
                             "--terms", "thermal", "--out", str(folder / f"{name}_out"), "-q")
            found = json.loads((folder / f"{name}_out" / "discrepancy.json").read_text())
            out["cases"][name] = {
                "effect": effect, "rows": rows, "simulate_code": made["code"],
                "seconds": search["seconds"], "peak_mb": search["peak_mb"],
                "code": search["code"], "added": found["added"],
                "trustworthy": found["trustworthy"]}
    report(out, args.json)


if __name__ == "__main__":
    main()
