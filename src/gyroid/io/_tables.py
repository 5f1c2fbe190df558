"""Reading logs: a log's table (CSV, .csv.gz or parquet) with every bad cell named by row,
line and column, vendors' columns read as the contract's (:mod:`gyroid.io._units`), and the
checks every column gets (finite, plausible, time increasing). CSV parsing is
:mod:`gyroid.io._csv_reader`'s."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._csv_reader import arrow_columns, header_names, read_csv, split_head
from gyroid.io._file_bytes import read_bytes
from gyroid.io._log_table import LogTable
from gyroid.io._native import is_native, read_native
from gyroid.io._netcdf import is_netcdf, read_netcdf
from gyroid.io._units import ColumnMap


def read_log_table(path: str | Path, maps: tuple[ColumnMap, ...] = (),
                   instance: int | None = None) -> LogTable:
    """Read a log: .csv, .csv.gz, .parquet with ``#`` comment lines and a header row, a
    netCDF file (:mod:`gyroid.io._netcdf`), or a flight-controller, ROS or MATLAB log
    (:mod:`gyroid.io._native`; ``instance`` picks its IMU)."""

    path = Path(path)
    if is_netcdf(path):
        if instance is not None:
            raise GyroidInputError(f"--instance is for flight-controller and ROS logs; in "
                                   f"{path.name} choose the variables with --map")
        return read_netcdf(path, tuple(maps))
    if is_native(path):
        return replace(read_native(path, instance), maps=tuple(maps))
    if instance is not None:
        raise GyroidInputError(f"--instance is for flight-controller, ROS and MATLAB logs; "
                               f"{path.name} is a table: choose its columns with --map")
    if path.suffix.lower() in (".parquet", ".pq"):
        return _read_parquet(path, maps)
    parsed = read_csv(path)
    return LogTable(path, parsed.header, parsed.raw, parsed.n_rows, parsed.first_line,
                    parsed.lines, parsed.comments, maps, parsed.decimal_comma, parsed.empty)


def _read_parquet(path: Path, maps) -> LogTable:
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        # ParquetFile, not read_table: read_table imports pyarrow.dataset and pandas (0.2 s
        # of a small log's compensation) for the same table of a single file
        table = pq.ParquetFile(path).read()
    except FileNotFoundError:
        raise GyroidInputError(f"{path}: no such file; check the path") from None
    except (pa.ArrowInvalid, OSError) as error:
        raise GyroidInputError(f"{path.name}: not a readable parquet file ({error})") from None
    names, n_rows = tuple(table.column_names), table.num_rows
    metadata, holder = table.schema.metadata or {}, [table]
    del table
    raw, empty = arrow_columns(holder)
    if n_rows == 0:
        raise GyroidInputError(f"{path.name}: the file has no data rows")
    comments = parquet_comments(metadata)
    return LogTable(path, names, raw, n_rows, None, None, comments,
                    maps, False, empty)


def parquet_comments(metadata: dict | None) -> tuple[str, ...]:
    """A parquet file's comment lines (its schema metadata's ``comment*`` keys)."""
    return tuple(v.decode(errors="replace") for k, v in (metadata or {}).items()
                 if k.startswith(b"comment"))


def table_source(table: LogTable) -> dict[str, object]:
    """Where a table's columns came from: the file, what a native log's reader picked and
    the ``--map`` items (``axes.json``'s ``source``)."""
    return {"path": str(table.path), **table.picked,
            "maps": [f"{m.target}={m.source}" + (f":{m.unit}" if m.unit else "")
                     for m in table.maps]}


def read_header(path: str | Path) -> tuple[str, ...]:
    """A log's column names, reading no more than the header (a parquet file's schema, or
    the first 64 kB of a CSV, gzip or not); errors as :func:`read_log_table`'s."""

    path = Path(path)
    if is_native(path) or is_netcdf(path):
        return read_log_table(path).header
    if path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        try:
            return tuple(pq.read_schema(path).names)
        except FileNotFoundError:
            raise GyroidInputError(f"{path}: no such file; check the path") from None
        except Exception:  # noqa: BLE001 - a damaged file: the full read names the problem
            return read_log_table(path).header
    head = read_bytes(path, 1 << 16)  # a missing file or a damaged gzip: its message
    _, _, header = split_head(head.decode("utf-8-sig", errors="replace"))
    if header is None:
        return read_log_table(path).header
    return header_names(header)


def log_kind(path: str | Path, maps: tuple[ColumnMap, ...] = ()) -> str:
    """``"roll"`` for a roll log (docs/formats.md section 4: roll_rate_deg_s and no drift_deg_h,
    after the column maps), else ``"bench"``; reads the header only."""
    names = {*read_header(path), *(m.target for m in maps)}
    return "roll" if "roll_rate_deg_s" in names and "drift_deg_h" not in names else "bench"


def check_time_increasing(table: LogTable, time_s: np.ndarray) -> None:
    """Refuse a time column that is not strictly increasing, naming the first bad row."""
    steps = np.diff(time_s)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise GyroidInputError(
            f"{table.label}: time_s does not increase at {table.where(i)}: "
            f"{time_s[i]:g} s follows {time_s[i - 1]:g} s; sort the log by time and remove "
            "repeated samples"
        )


#: Values beyond these magnitudes are refused as implausible (a unit or parse mistake).
PLAUSIBLE = {
    "time_s": 1e12, "drift_deg_h": 1e9, "sigma_deg_h": 1e9, "Hx_uT": 1e8, "Hy_uT": 1e8,
    "Hz_uT": 1e8, "ax_g": 1e5, "ay_g": 1e5, "az_g": 1e5, "roll_rate_deg_s": 1e7,
    "gs_rate_deg_s": 1e7, "gs_angle_deg": 1e12,
}


def check_plausible(table: LogTable, name: str, values: np.ndarray) -> None:
    """Refuse a value no gyro log holds (e.g. 1e300), naming its row."""
    if name == "temperature_C":
        bad = np.flatnonzero((values < -273.15) | (values > 1000.0))
        limit = "between -273.15 and 1000 degC"
    else:
        bound = PLAUSIBLE.get(name)
        if bound is None:
            return
        bad = np.flatnonzero(np.abs(values) > bound)
        limit = f"within +/-{bound:g}"
    if bad.size:
        i = int(bad[0])
        source, column_map = table._source(name)
        column = name if column_map is None else f"{source} (read as {name})"
        many = f", nor are {bad.size - 1} more rows" if bad.size > 1 else ""
        advice = ("fix the row, or give the column's unit with --map" if bad.size <= 1 else
                  "if it holds raw sensor counts, convert them to physical units first, or "
                  "give the column's unit with --map")
        raise GyroidInputError(f"{table.label}: {table.where(i)}, column {column}: "
                               f"{values[i]:g} is not a plausible value (expected {limit})"
                               f"{many}; {advice}")
