"""What ``gyroid reproduce`` and ``gyroid datasets NAME --out`` write: both papers' tables
recomputed and audited; a public dataset's logs in gyroid's columns."""

from __future__ import annotations

from pathlib import Path

from gyroid.io._datasets import dataset_logs
from gyroid.io._log_writer import write_bench_log
from gyroid.io._outputs import output_dir
from gyroid.reports._reproduction import write_reproduction


def reproduce_dir(out: Path) -> dict:
    """Recompute paper A's and paper B's tables and figures into ``out``; returns
    ``reproduce.json``'s record (its ``audit`` lists the disagreements)."""
    with output_dir(out) as stage:
        return write_reproduction(stage)


def dataset_to_dir(name: str, out: Path) -> tuple[str, ...]:
    """Fetch dataset ``name`` (checked by its SHA-256) and write each of its logs to
    ``out/LOG.csv`` in gyroid's columns, provenance as comment lines; returns the files'
    names."""
    logs = dataset_logs(name)
    with output_dir(out) as stage:
        for log_name, (columns, comments) in logs.items():
            write_bench_log(stage / f"{log_name}.csv", columns, comments)
    return tuple(f"{k}.csv" for k in logs)
