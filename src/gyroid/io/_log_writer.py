"""Writing bench logs (docs/formats.md section 1): contract CSV (plain or gzip) or parquet,
atomically and in batches."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._logs import BENCH_COLUMNS, BenchLog
from gyroid.io._outputs import atomic_path
from gyroid.io._units import AXIS_COLUMN

_UNITS = {
    "time_s": "s",
    "drift_deg_h": "deg/h",
    "temperature_C": "degC",
    "Hx_uT": "uT",
    "Hy_uT": "uT",
    "Hz_uT": "uT",
    "ax_g": "g",
    "ay_g": "g",
    "az_g": "g",
    "sigma_deg_h": "deg/h",
}


def _unit(column: str) -> str:
    return "deg/h" if AXIS_COLUMN.match(column) else _UNITS.get(column, "-")


def _ordered(columns: Mapping[str, np.ndarray]) -> list[str]:
    """Contract columns first (time, a gyro axis's drift columns after the drift), then the
    log's others."""
    lead = [c for c in ("time_s", "drift_deg_h") if c in columns]
    names = lead + [c for c in columns if AXIS_COLUMN.match(c)]
    names += [c for c in BENCH_COLUMNS if c in columns and c not in names]
    return names + [c for c in columns if c not in names]


def _header_lines(names: list[str], comments: Iterable[str]) -> list[str]:
    lines = [f"# {c}" for c in comments]
    lines.append("# units: " + ", ".join(f"{c} [{_unit(c)}]" for c in names))
    lines.append(",".join(names))
    return lines


def bench_log_text(columns: Mapping[str, np.ndarray], comments: Iterable[str] = ()) -> str:
    """Render bench-log columns as contract CSV text (known columns first, in order)."""
    names = _ordered(columns)
    data = np.column_stack([np.asarray(columns[c], dtype=float) for c in names])
    body = "\n".join(",".join(f"{v:.10g}" for v in row) for row in data)
    return "\n".join(_header_lines(names, comments)) + "\n" + body + "\n"


#: Rows written per batch by :func:`write_bench_log` (bounds its memory on long logs).
WRITE_BATCH_ROWS = 1_000_000


def write_bench_log(
    path: str | Path, columns: Mapping[str, np.ndarray] | BenchLog, comments: Iterable[str] = ()
) -> Path:
    """Write a bench log (a :class:`~gyroid.io.BenchLog`, its comments kept, or its columns)
    atomically: ``.csv`` or ``.csv.gz`` (contract CSV with the comment and units lines; values
    by pyarrow's CSV writer, in batches) or ``.parquet`` (comments in the file's metadata).
    Memory stays bounded on 10^7-row logs."""
    if isinstance(path, BenchLog | Mapping):  # any os.PathLike stays a path
        raise GyroidInputError(f"write_bench_log(path, log): the path comes first, then the "
                               f"log; got a {type(path).__name__} for the path")
    if isinstance(columns, BenchLog):
        columns, comments = columns.columns, (*columns.comments, *comments)
    with bench_log_writer(path, _ordered(columns), comments) as append:
        append(columns)
    return Path(path)


@contextmanager
def bench_log_writer(path: str | Path, names: Sequence[str], comments: Iterable[str] = ()
                     ) -> Iterator[Callable[[Mapping[str, np.ndarray]], None]]:
    """A bench log written chunk by chunk (a log too long to hold): yields ``append``,
    which writes the next rows (a mapping of ``names`` to equally long arrays). The file
    (formats as :func:`write_bench_log`; columns in the order of ``names``) appears at
    ``path`` when the block ends without an error, and not at all otherwise."""
    import gzip

    import pyarrow as pa
    import pyarrow.parquet as pq

    path, names, comments = Path(path), list(names), list(comments)
    schema = pa.schema([(c, pa.float64()) for c in names])

    def table(columns: Mapping[str, np.ndarray]) -> pa.Table:
        return pa.table({c: np.asarray(columns[c], dtype=float) for c in names}, schema=schema)

    with atomic_path(path) as tmp:
        if path.suffix == ".parquet":
            meta = {b"gyroid_comments": "\n".join(comments).encode()}
            with pq.ParquetWriter(tmp, schema.with_metadata(meta)) as writer:
                yield lambda columns: writer.write_table(table(columns))
            return
        opener = gzip.open if path.name.endswith(".gz") else open
        with opener(tmp, "wb") as handle:
            handle.write(("\n".join(_header_lines(names, comments)) + "\n").encode())

            def append(columns: Mapping[str, np.ndarray]) -> None:
                write_csv_rows(handle, table(columns))

            yield append


def write_csv_rows(handle, rows) -> None:
    """A pyarrow table's rows appended to an open binary CSV file, without a header, by
    pyarrow's CSV writer :data:`WRITE_BATCH_ROWS` at a time (its memory stays bounded)."""
    import pyarrow.csv as pacsv

    options = pacsv.WriteOptions(include_header=False)
    for start in range(0, rows.num_rows, WRITE_BATCH_ROWS):
        pacsv.write_csv(rows.slice(start, WRITE_BATCH_ROWS), handle, options)
