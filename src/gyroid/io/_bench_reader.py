"""Reading a bench log (docs/formats.md section 1) with validation: the columns a model
needs, each numeric, finite and plausible in every row, the first problem named by row or
column."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._logs import BENCH_COLUMNS, BenchLog
from gyroid.io._tables import (
    PLAUSIBLE,
    LogTable,
    check_plausible,
    check_time_increasing,
    read_log_table,
)
from gyroid.io._units import AXIS_COLUMN, ColumnMap, unit_list
from gyroid.models._drift import DriftModel
from gyroid.models._effects import EXTRA_PREFIX
from gyroid.models._inputs import T0_C


def check_temperature_celsius(values: np.ndarray, where: str = "temperature_C") -> None:
    """Refuse temperatures that look like kelvin."""
    if values.size and float(np.median(values)) > 150.0 and float(np.min(values)) > 100.0:
        raise GyroidInputError(
            f"column {where} looks like kelvin (median {np.median(values):.2f}); gyroid "
            "expects degC: subtract 273.15"
        )


ROLL_SIGNATURE = ("roll_rate_deg_s", "gs_angle_deg")


def load_bench_log(
    path: str | Path,
    terms: str | Iterable[str] | DriftModel | None = None,
    *,
    t0_C: float = T0_C,
    column_map: Iterable[ColumnMap] = (),
    extra_columns: bool = False,
    axis: str | None = None,
) -> BenchLog:
    """Read and validate a bench log (.csv, .csv.gz, .parquet) for a model with the terms.
    ``extra_columns=True`` keeps every other numeric, finite, varying column as a
    candidate cause ``extra:COLUMN`` (and a term that names one needs it; the log's other
    rate channels are motion, not causes, and are left out). A log of several gyro axes
    (``drift_x_deg_h``, ...) is read for one ``axis``.

    ``time_s`` and ``drift_deg_h`` are always needed; the terms add their columns;
    ``column_map`` reads a vendor's columns and units as contract columns (``--map``). Every
    needed column must be numeric, finite and plausible in every row; time must increase
    strictly; temperatures must be in degC; ``sigma_deg_h``, where present, must be
    positive. The first problem found ends the load with a :class:`GyroidInputError` that
    names the row or column. (Whether the terms are identifiable on the log is the
    problem's to check: :meth:`gyroid.bench.BenchProblem.from_log`.)
    """
    del t0_C  # kept for callers; the reference temperature shapes the inputs, not the log
    return bench_log_from_table(read_log_table(path, tuple(column_map)), terms,
                     extra_columns=extra_columns, axis=axis)


def bench_log_from_table(
    table: LogTable,
    terms: str | Iterable[str] | DriftModel | None = None,
    *,
    extra_columns: bool = False,
    axis: str | None = None,
    check_rows: bool = True,
) -> BenchLog:
    """The bench log of a table already read (:func:`load_bench_log`'s checks): one call
    per gyro axis of a log of several reads the file once. ``check_rows=False``: the table
    is a batch of a longer log, so its length says nothing of the log's."""
    table, axis = _for_axis(table, axis)
    _check_shape(table)
    if terms is None or isinstance(terms, DriftModel):
        model = terms
    else:
        model = DriftModel.from_terms(terms if isinstance(terms, str) else tuple(terms))
    needed = ["time_s", "drift_deg_h"]
    if model is not None:
        needed += [c for c in model.columns if c not in needed]
    columns = _contract_columns(table, needed)
    wanted = {name[len(EXTRA_PREFIX):] for name in (model.terms if model else ())
              if name.startswith(EXTRA_PREFIX)}
    extras = _extra_columns(table, columns, wanted) if extra_columns or wanted else ()
    log = BenchLog(columns=columns, source=str(table.path), comments=table.comments,
                   row_name=table.where, extra_columns=extras, axis=axis)
    if check_rows and model is not None and log.n <= len(model.parameter_names):
        raise GyroidInputError(f"{table.label}: {log.n} rows cannot identify "
                               f"{len(model.parameter_names)} coefficients; use a longer log")
    return log


def _for_axis(table: LogTable, axis: str | None) -> tuple[LogTable, str | None]:
    """The table read for one gyro axis of a log of several (``drift_AXIS_deg_h`` as
    ``drift_deg_h``), and that axis; a log of one drift column as it is."""
    axes = table.axes()
    if axis is None:
        if table.has("drift_deg_h") or len(axes) == 0:
            return table, None
        if len(axes) > 1:
            raise GyroidInputError(
                f"{table.label} has {len(axes)} gyro axes ({', '.join(axes)}): choose "
                f"one with --axes, or fit them all with --axes {','.join(axes)}")
        axis = axes[0]
    if axis not in axes:
        have = f"its axes are {', '.join(axes)}" if axes else "it has no drift_AXIS_deg_h column"
        raise GyroidInputError(f"{table.label} has no gyro axis {axis!r} ({have})")
    return table.with_axis(axis), axis


def _check_shape(table: LogTable) -> None:
    """Refuse a roll log, and a header of one column (a separator gyroid does not read)."""
    if not table.has("drift_deg_h") and all(table.has(c) for c in ROLL_SIGNATURE):
        raise GyroidInputError(f"{table.label} is a roll log (it has roll_rate_deg_s and "
                               "gs_angle_deg, no drift_deg_h): use 'gyroid roll fit' (or "
                               "'gyroid discrepancy' with roll terms)")
    if len(table.header) == 1:
        raise GyroidInputError(f"{table.label}: the header has a single column "
                               f"{table.header[0]!r}; gyroid reads comma-, semicolon- or "
                               "tab-separated logs")


#: What to do when a column every log needs is missing.
_ADVICE = {
    "time_s": "every log needs the sample time in s; map yours with --map "
              f"time_s=COLUMN[:UNIT]{unit_list('time_s')}",
    "drift_deg_h": "gyroid always needs the measured drift (gyro output minus the known "
                   "input rate); map your gyro's column with --map "
                   f"drift_deg_h=COLUMN[:UNIT]{unit_list('drift_deg_h')}",
}


def _contract_columns(table: LogTable, needed: list[str]) -> dict[str, np.ndarray]:
    """The needed contract columns (each numeric, finite and plausible in every row), a
    positive ``sigma_deg_h`` when the log has one, and the other contract columns that are
    clean (kept for context); time increasing, temperatures in degC."""
    columns: dict[str, np.ndarray] = {}
    for name in needed:
        columns[name] = table.number_column(name, _ADVICE.get(name))
        check_plausible(table, name, columns[name])
    if table.has("sigma_deg_h"):
        sigma = table.number_column("sigma_deg_h")
        bad = np.flatnonzero(sigma <= 0)
        if bad.size:
            raise GyroidInputError(
                f"{table.label}: {table.where(int(bad[0]))}, column sigma_deg_h: "
                f"{sigma[bad[0]]:g} is not a positive noise level; fix it or drop the column "
                "to let gyroid estimate the noise")
        check_plausible(table, "sigma_deg_h", sigma)
        columns["sigma_deg_h"] = sigma
    for name in BENCH_COLUMNS:
        if name not in columns:
            values = table.try_number_column(name)
            if values is not None and np.all(np.abs(values) < PLAUSIBLE.get(name, 1e12)):
                columns[name] = values
    check_time_increasing(table, columns["time_s"])
    if "temperature_C" in needed:
        check_temperature_celsius(columns["temperature_C"])
    return columns


def _rate_channels(table: LogTable) -> set[str]:
    """The log's other gyro axes: its ``drift_AXIS_deg_h`` columns, and the columns named as
    the drift's own but for its axis (gyro_y, gyro_z beside gyro_x). They record motion, not
    a cause of drift, so they are never offered as one."""
    source = table._source("drift_deg_h")[0]
    channels = {name for name in table.header if AXIS_COLUMN.match(name)}
    for k, letter in enumerate(source):
        if letter.lower() in "xyz":
            for other in "xyz":
                sibling = source[:k] + (other.upper() if letter.isupper() else other) + \
                    source[k + 1:]
                if sibling != source and sibling in table.header:
                    channels.add(sibling)
    return channels


def _extra_columns(table: LogTable, columns: dict[str, np.ndarray], wanted: set[str]
                   ) -> tuple[str, ...]:
    """Every other numeric, varying column, added to ``columns`` as a candidate cause
    (``--extra-columns``); a term ``extra:COLUMN`` in ``wanted`` needs its column."""
    extras = []
    taken = {m.source for m in table.maps} | set(BENCH_COLUMNS)
    rate_channels = _rate_channels(table)
    for name in table.header:
        if name in taken or name in rate_channels:
            continue
        values = columns[name] if name in columns else table.try_number_column(name)
        if values is not None and np.ptp(values) > 0:
            columns[name] = values
            extras.append(name)
    for name in sorted(wanted - set(extras)):
        raise GyroidInputError(f"{table.label}: term extra:{name} needs a numeric, "
                               f"varying column {name!r}; the header has "
                               f"{', '.join(table.header)}")
    return tuple(extras)


