"""Bench logs (docs/formats.md section 1): loading with validation, and writing."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._outputs import atomic_path
from gyroid.io._tables import (
    PLAUSIBLE,
    LogTable,
    check_plausible,
    check_time_increasing,
    read_log_table,
)
from gyroid.io._units import ColumnMap
from gyroid.models._derived import HYSTERESIS_DEADBAND_UT, RATE_WINDOW_S
from gyroid.models._drift import DriftModel
from gyroid.models._effects import EXTRA_PREFIX
from gyroid.models._inputs import FIELD_COLUMNS, T0_C, DriftInputs, build_inputs

#: Columns of a bench log that gyroid reads, in the order it writes them.
BENCH_COLUMNS = ("time_s", "drift_deg_h", "temperature_C", *FIELD_COLUMNS, "sigma_deg_h")
_UNITS = {
    "time_s": "s",
    "drift_deg_h": "deg/h",
    "temperature_C": "degC",
    "Hx_uT": "uT",
    "Hy_uT": "uT",
    "Hz_uT": "uT",
    "sigma_deg_h": "deg/h",
}


@dataclass(frozen=True)
class BenchLog:
    """A validated bench log: numeric columns by name, all of one length."""

    columns: Mapping[str, np.ndarray]
    source: str = "<memory>"
    comments: tuple[str, ...] = ()
    #: Names data row i (0-based) as the file has it, e.g. 'row 3 (line 7 of log.csv)'.
    row_name: Callable[[int], str] | None = field(default=None, compare=False, repr=False)
    #: The user's own numeric columns offered as ``extra:COLUMN`` effects (--extra-columns).
    extra_columns: tuple[str, ...] = ()

    @property
    def n(self) -> int:
        return int(self.columns["time_s"].size)

    @property
    def time_s(self) -> np.ndarray:
        return self.columns["time_s"]

    @property
    def drift_deg_h(self) -> np.ndarray:
        return self.columns["drift_deg_h"]

    @property
    def sigma_deg_h(self) -> np.ndarray | None:
        return self.columns.get("sigma_deg_h")

    def has(self, name: str) -> bool:
        return name in self.columns

    def where(self, row: int) -> str:
        """Data row ``row`` (0-based) as a user finds it in the file."""
        return self.row_name(row) if self.row_name is not None else f"row {row + 1}"

    def inputs(self, *, t0_C: float = T0_C, rate_window_s: float = RATE_WINDOW_S,
               deadband_uT: float = HYSTERESIS_DEADBAND_UT) -> DriftInputs:
        """The drift model's inputs, derived quantities included (built anew each call: a
        10^7-row log's are 0.8 GB, so a caller keeps the set it needs)."""
        return build_inputs(self.columns, t0_C=t0_C, extra_columns=self.extra_columns,
                            rate_window_s=rate_window_s, deadband_uT=deadband_uT)


#: A step longer than this many median steps splits the log into segments.
GAP_FACTOR = 1.5


def contiguous_segments(time_s: np.ndarray, gap_factor: float = GAP_FACTOR
                        ) -> list[tuple[int, int]]:
    """Index ranges ``[start, stop)`` of the log's evenly sampled stretches."""
    time_s = np.asarray(time_s, dtype=float)
    steps = np.diff(time_s)
    if steps.size == 0:
        return [(0, time_s.size)]
    breaks = np.flatnonzero(steps > gap_factor * np.median(steps)) + 1
    edges = np.concatenate([[0], breaks, [time_s.size]])
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True)]


#: Fewest contiguous segments a log of bursts needs for a fit of their means.
MIN_SEGMENTS = 8


def segment_means(log: BenchLog, segments: list[tuple[int, int]]
                  ) -> tuple[BenchLog, np.ndarray, float]:
    """One row per contiguous segment (burst) of ``log``: every column's mean over it
    (``sigma_deg_h`` dropped: it describes a sample, not the wander between bursts); each
    sample's drift minus its segment's mean over the pooled within-segment sd (for the spike
    check the averaging would hide); and that sd, deg/h."""
    if len(segments) < MIN_SEGMENTS:
        raise GyroidInputError(
            f"a fit of segment means needs a log of bursts with at least {MIN_SEGMENTS} "
            f"contiguous segments; {log.source} has {len(segments)}: fit its samples instead")
    columns = {name: np.array([values[a:b].mean() for a, b in segments])
               for name, values in log.columns.items() if name != "sigma_deg_h"}
    drift = np.asarray(log.drift_deg_h, dtype=float)
    deviation = np.concatenate([drift[a:b] - drift[a:b].mean() for a, b in segments])
    dof = log.n - len(segments)
    scale = float(np.sqrt(np.sum(deviation**2) / dof)) if dof > 0 else 0.0
    within = deviation / scale if scale > 0 else np.zeros_like(deviation)
    comments = (*log.comments, f"means of the {len(segments)} contiguous segments of "
                f"{log.source} ({log.n} rows)")
    return BenchLog(columns=columns, source=f"{log.source} (segment means)",
                    comments=comments), within, scale


def block_means(log: BenchLog, rows: int) -> BenchLog:
    """``log`` with every column averaged over blocks of ``rows`` consecutive samples inside
    each contiguous segment (a segment's last incomplete block is dropped, so that every
    block is a mean of exactly ``rows`` samples and its white noise is ``1/sqrt(rows)`` of
    a sample's). ``sigma_deg_h`` becomes the mean's sd. Rows are named by their first
    sample."""
    starts = np.concatenate([np.arange(a, b - rows + 1, rows)
                             for a, b in contiguous_segments(np.asarray(log.time_s))])
    index = starts[:, None] + np.arange(rows)[None, :]
    columns = {name: np.asarray(values, dtype=float)[index].mean(axis=1)
               for name, values in log.columns.items()}
    if "sigma_deg_h" in columns:
        sigma = np.asarray(log.columns["sigma_deg_h"], dtype=float)[index]
        columns["sigma_deg_h"] = np.sqrt(np.sum(sigma**2, axis=1)) / rows
    comments = (*log.comments, f"means of {rows} consecutive samples of {log.source}")

    def row_name(k: int) -> str:
        return f"the mean of {rows} samples from {log.where(int(starts[k]))}"

    return BenchLog(columns=columns, source=f"{log.source} ({rows}-sample means)",
                    comments=comments, row_name=row_name, extra_columns=log.extra_columns)


def run_labels(paths) -> tuple[str, ...]:
    """Names of runs from their logs' paths: the file stem (``run3.csv.gz`` -> ``run3``), or
    the folder's name when stems repeat (``lot/run_01/bench.csv`` -> ``run_01``), or both
    joined; two logs that still share a name are refused."""
    paths = [Path(p) for p in paths]
    stems = [p.name.split(".")[0] for p in paths]
    if len(set(stems)) == len(stems):
        return tuple(stems)
    folders = [p.resolve().parent.name for p in paths]
    for labels in (folders, [f"{f}_{s}" for f, s in zip(folders, stems, strict=True)]):
        if len(set(labels)) == len(labels) and all(labels):
            return tuple(labels)
    repeated = sorted({s for s in stems if stems.count(s) > 1})
    raise GyroidInputError(f"two logs have the same name {repeated[0]!r} and folder; give "
                           "each run its own file or folder name")


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
) -> BenchLog:
    """Read and validate a bench log (.csv, .csv.gz, .parquet) for a model with the terms.
    ``extra_columns=True`` keeps every other numeric, finite, varying column as a
    candidate cause ``extra:COLUMN`` (and a term that names one needs it).

    ``time_s`` and ``drift_deg_h`` are always needed; the terms add their columns;
    ``column_map`` reads a vendor's columns and units as contract columns (``--map``). Every
    needed column must be numeric, finite and plausible in every row; time must increase
    strictly; temperatures must be in degC; ``sigma_deg_h``, where present, must be
    positive. The first problem found ends the load with a :class:`GyroidInputError` that
    names the row or column. (Whether the terms are identifiable on the log is the
    problem's to check: :meth:`gyroid.inference.BenchProblem.from_log`.)
    """
    table = read_log_table(path, tuple(column_map))
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
                   row_name=table.where, extra_columns=extras)
    if model is not None and log.n <= len(model.parameter_names):
        raise GyroidInputError(f"{table.path.name}: {log.n} rows cannot identify "
                               f"{len(model.parameter_names)} coefficients; use a longer log")
    return log


def _check_shape(table: LogTable) -> None:
    """Refuse a roll log, and a header of one column (a separator gyroid does not read)."""
    if not table.has("drift_deg_h") and all(table.has(c) for c in ROLL_SIGNATURE):
        raise GyroidInputError(f"{table.path.name} is a roll log (it has roll_rate_deg_s and "
                               "gs_angle_deg, no drift_deg_h): use 'gyroid roll fit' (or "
                               "'gyroid discrepancy' with roll terms)")
    if len(table.header) == 1:
        raise GyroidInputError(f"{table.path.name}: the header has a single column "
                               f"{table.header[0]!r}; gyroid reads comma-, semicolon- or "
                               "tab-separated logs")


#: What to do when a column every log needs is missing.
_ADVICE = {
    "time_s": "every log needs the sample time in s; map yours with --map "
              "time_s=COLUMN[:UNIT] (units s, ms, us, ns, min, h)",
    "drift_deg_h": "gyroid always needs the measured drift (gyro output minus the known "
                   "input rate); map your gyro's column with --map "
                   "drift_deg_h=COLUMN[:UNIT] (units deg/h, deg/s, mdps, rad/s)",
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
                f"{table.path.name}: {table.where(int(bad[0]))}, column sigma_deg_h: "
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


def _extra_columns(table: LogTable, columns: dict[str, np.ndarray], wanted: set[str]
                   ) -> tuple[str, ...]:
    """Every other numeric, varying column, added to ``columns`` as a candidate cause
    (``--extra-columns``); a term ``extra:COLUMN`` in ``wanted`` needs its column."""
    extras = []
    taken = {m.source for m in table.maps} | set(BENCH_COLUMNS)
    for name in table.header:
        if name in taken:
            continue
        values = columns[name] if name in columns else table.try_number_column(name)
        if values is not None and np.ptp(values) > 0:
            columns[name] = values
            extras.append(name)
    for name in sorted(wanted - set(extras)):
        raise GyroidInputError(f"{table.path.name}: term extra:{name} needs a numeric, "
                               f"varying column {name!r}; the header has "
                               f"{', '.join(table.header)}")
    return tuple(extras)


def _ordered(columns: Mapping[str, np.ndarray]) -> list[str]:
    names = [c for c in BENCH_COLUMNS if c in columns]
    return names + [c for c in columns if c not in names]


def _header_lines(names: list[str], comments: Iterable[str]) -> list[str]:
    lines = [f"# {c}" for c in comments]
    lines.append("# units: " + ", ".join(f"{c} [{_UNITS.get(c, '-')}]" for c in names))
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
    path: str | Path, columns: Mapping[str, np.ndarray], comments: Iterable[str] = ()
) -> Path:
    """Write a bench log atomically: ``.csv`` or ``.csv.gz`` (contract CSV with the comment
    and units lines; values by pyarrow's CSV writer, in batches) or ``.parquet`` (comments
    in the file's metadata). Memory stays bounded on 10^7-row logs."""
    import gzip

    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    path = Path(path)
    names = _ordered(columns)
    table = pa.table({c: np.asarray(columns[c], dtype=float) for c in names})
    comments = list(comments)
    with atomic_path(path) as tmp:
        if path.suffix == ".parquet":
            meta = {b"gyroid_comments": "\n".join(comments).encode()}
            pq.write_table(table.replace_schema_metadata(meta), tmp)
            return path
        opener = gzip.open if path.name.endswith(".gz") else open
        options = pacsv.WriteOptions(include_header=False)
        with opener(tmp, "wb") as handle:
            handle.write(("\n".join(_header_lines(names, comments)) + "\n").encode())
            for start in range(0, max(table.num_rows, 1), WRITE_BATCH_ROWS):
                pacsv.write_csv(table.slice(start, WRITE_BATCH_ROWS), handle, options)
    return path
