"""A Parquet or CSV log too long to hold, read as a stream of row batches and reduced as it
goes to what a fit of block means reads (:class:`~gyroid.io._logs.MeansOfBlocks`): every
column's mean over blocks of consecutive samples (never across a pause of the clock), and
of the samples themselves only what the spike check needs. Peak memory is one batch and
the means, whatever the log's length.

Each batch is read and checked as a whole log would be (numeric, finite, plausible, time
increasing strictly, also across batches), and its errors name the file's row. The pause
threshold is the first batch's (:func:`~gyroid.io._logs.gap_threshold`). A sample is kept
as a spike candidate when it deviates from its block's mean by more than
:data:`CANDIDATE_SD` times the smaller of its block's robust sd and the pooled sd of the
blocks before it (at most :data:`CANDIDATES_PER_BLOCK` per block, the largest): the spike
check's threshold is above 4.4 pooled sd for any log this long, so every sample it would
flag is among them unless a block's noise is far below the pooled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._bench_reader import bench_log_from_table
from gyroid.io._csv_reader import csv_batches, csv_layout, csv_rows_bound
from gyroid.io._log_table import LogTable
from gyroid.io._logs import (
    BenchLog,
    MeansOfBlocks,
    SampleDeviations,
    about_local_lines,
    gap_threshold,
    line_dof,
    log_of_means,
    means_of_blocks,
)
from gyroid.io._tables import parquet_comments
from gyroid.io._units import ColumnMap

#: Logs longer than this (rows; for a CSV log, an upper estimate) are read as a stream.
STREAM_ROWS = 20_000_000
#: Rows per batch read.
BATCH_ROWS = 1 << 20
#: Most bytes of CSV text parsed per batch.
CSV_BLOCK_BYTES = 1 << 24
CANDIDATE_SD = 2.5
CANDIDATES_PER_BLOCK = 10_000


def _batches(path: Path, maps: tuple[ColumnMap, ...], batch_rows: int):
    """The log's empty table (its header, comments and how its rows are named) and its
    rows as pyarrow record batches of about ``batch_rows`` rows."""
    if path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        # pre-buffering reads the whole file ahead (arrow's peak grew with the log's length:
        # 0.95 GB for 4e7 rows, 0.1 GB without)
        file = pq.ParquetFile(path, pre_buffer=False)
        comments = parquet_comments(file.schema_arrow.metadata)
        base = LogTable(path, tuple(file.schema_arrow.names), {}, 0, None, None, comments,
                        maps)
        return base, file.iter_batches(batch_size=batch_rows)
    layout = csv_layout(path)
    base = LogTable(path, layout.header, {}, 0, layout.header_line + 1, None, layout.comments,
                    maps, layout.decimal_comma)
    lines = layout.data_lines
    per_row = max(1.0, float(np.mean([len(line) + 1 for line in lines])) if lines else 64.0)
    # arrow parses several blocks ahead: 113 MB blocks (2^20 rows) peaked at 2.4 GB, 16 MB
    # blocks at 0.7 GB, in the same time (3 x 10^7 rows)
    return base, csv_batches(path, layout, min(CSV_BLOCK_BYTES,
                                               max(1 << 16, int(batch_rows * per_row))))


def stream_rows(path: str | Path) -> tuple[int, bool] | None:
    """A log's row count if it is a Parquet file (from its footer), or an upper estimate
    of it for a CSV log (:func:`~gyroid.io._csv_reader.csv_rows_bound`), with whether it is
    exact; None for a native or netCDF log."""
    from gyroid.io._native import is_native
    from gyroid.io._netcdf import is_netcdf

    path = Path(path)
    exact = parquet_rows(path)
    if exact is not None:
        return exact, True
    if is_native(path) or is_netcdf(path) or not path.is_file():
        return None
    return csv_rows_bound(path, csv_layout(path)), False


def parquet_rows(path: str | Path) -> int | None:
    """A Parquet file's row count from its footer (None for any other file)."""
    path = Path(path)
    if path.suffix.lower() not in (".parquet", ".pq") or not path.exists():
        return None
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        return int(pq.ParquetFile(path).metadata.num_rows)
    except (pa.ArrowInvalid, OSError) as error:
        raise GyroidInputError(f"{path.name}: not a readable parquet file ({error})") from None


@dataclass
class _Blocks:
    """One axis's reduction so far: the means of the blocks completed, the samples carried
    into the next batch (fewer than a block, in the current stretch of the clock), and the
    spike candidates."""

    rows: int
    means: dict[str, list[np.ndarray]] = field(default_factory=dict)
    starts: list[np.ndarray] = field(default_factory=list)
    carried: dict[str, np.ndarray] | None = None
    carried_start: int = 0
    sum_sq: float = 0.0
    dof: int = 0
    candidate_rows: list[np.ndarray] = field(default_factory=list)
    candidate_dev: list[np.ndarray] = field(default_factory=list)

    def add(self, columns: dict[str, np.ndarray], first_row: int, breaks: np.ndarray) -> None:
        """Take a batch's columns (rows ``first_row`` on; ``breaks``: indices where a new
        stretch of the clock starts, relative to the batch with the carried rows before
        it)."""
        if self.carried is not None:
            columns = {k: np.concatenate([self.carried[k], v]) for k, v in columns.items()}
            first_row = self.carried_start
        n = next(iter(columns.values())).size
        edges = np.concatenate([[0], breaks, [n]]).astype(int)
        self.carried = None
        for a, b, last in zip(edges[:-1], edges[1:], [False] * (edges.size - 2) + [True],
                              strict=True):
            k = (b - a) // self.rows
            if k:
                self._blocks({c: v[a: a + k * self.rows] for c, v in columns.items()},
                             first_row + a)
            if last and b - (a + k * self.rows) > 0:  # the stretch may go on in the next batch
                rest = a + k * self.rows
                self.carried = {c: v[rest:b].copy() for c, v in columns.items()}
                self.carried_start = first_row + rest

    def _blocks(self, columns: dict[str, np.ndarray], first_row: int) -> None:
        m = self.rows
        shaped = {c: v.reshape(-1, m) for c, v in columns.items()}
        for c, v in means_of_blocks(shaped).items():
            self.means.setdefault(c, []).append(v)
        k = shaped["drift_deg_h"].shape[0]
        self.starts.append(first_row + m * np.arange(k))
        deviation = about_local_lines(shaped["drift_deg_h"], shaped["time_s"])
        pooled = math.sqrt(self.sum_sq / self.dof) if self.dof else math.inf
        self.sum_sq += float(np.sum(deviation**2))
        self.dof += line_dof([m] * k)
        robust = 1.4826 * np.median(np.abs(deviation - np.median(deviation, axis=1,
                                                                  keepdims=True)), axis=1)
        limit = CANDIDATE_SD * np.minimum(robust, pooled)
        for j in np.flatnonzero(np.any(np.abs(deviation) > limit[:, None], axis=1)):
            row = deviation[j]
            beyond = np.flatnonzero(np.abs(row) > limit[j])
            if beyond.size > CANDIDATES_PER_BLOCK:
                beyond = beyond[np.argsort(-np.abs(row[beyond]))[:CANDIDATES_PER_BLOCK]]
            self.candidate_rows.append(first_row + m * j + beyond)
            self.candidate_dev.append(row[beyond])

    def result(self, head: BenchLog, n: int, where) -> MeansOfBlocks:
        """The means of the blocks, of the ``n`` samples whose first batch is ``head``
        (``where``: the file's row names)."""
        source = head.source
        if not self.starts:
            raise GyroidInputError(
                f"{source}: no stretch of the clock without a pause holds {self.rows} "
                "samples, so it has no blocks to average; fit a shorter excerpt")
        columns = {c: np.concatenate(v) for c, v in self.means.items()}
        starts = np.concatenate(self.starts)
        within = math.sqrt(self.sum_sq / self.dof) if self.dof else 0.0
        rows = (np.concatenate(self.candidate_rows) if self.candidate_rows
                else np.zeros(0, dtype=int))
        dev = np.concatenate(self.candidate_dev) if self.candidate_dev else np.zeros(0)
        scale = within if within > 0 else 1.0
        samples = SampleDeviations(n=n, rows=rows, z=dev / scale,
                                   z_sum_sq=self.sum_sq / scale**2, within_sd=within,
                                   head=head, where=where)
        means = log_of_means(columns, self.rows, starts, head, where,
                             f"means of {self.rows} consecutive samples of {source}, read "
                             "as a stream")
        return MeansOfBlocks(means, self.rows, samples)


def stream_block_means(path: str | Path, terms, axes: tuple[str | None, ...],
                       maps: tuple[ColumnMap, ...], rows_per_mean: int,
                       batch_rows: int | None = None) -> dict[str | None, MeansOfBlocks]:
    """Each of ``axes``' block means (``rows_per_mean`` samples each) of a Parquet or CSV
    log, read batch by batch (``terms``: the model whose columns each batch must hold,
    checked as :func:`~gyroid.io._bench_reader.bench_log_from_table` checks a whole log)."""
    import pyarrow as pa

    from gyroid.io._csv_reader import arrow_columns

    path = Path(path)
    base, batches = _batches(path, maps, batch_rows or BATCH_ROWS)
    blocks = {axis: _Blocks(rows_per_mean) for axis in axes}
    heads: dict[str | None, BenchLog] = {}
    offset, threshold, last_time = 0, math.inf, -math.inf
    for batch in batches:
        raw, empty = arrow_columns([pa.Table.from_batches([batch])])
        table = replace(base, raw=raw, n_rows=batch.num_rows, empty=empty, row_offset=offset)
        for axis in axes:
            log = bench_log_from_table(table, terms, axis=axis, check_rows=False)
            time_s = np.asarray(log.time_s, dtype=float)
            if time_s[0] <= last_time:
                raise GyroidInputError(
                    f"{table.where(0)}: time_s {time_s[0]:g} does not increase from the row "
                    f"before ({last_time:g}); sort the log by time")
            if axis not in heads:
                heads[axis] = log
                threshold = gap_threshold(time_s)
            carried = blocks[axis].carried
            before = carried["time_s"] if carried is not None else np.zeros(0)
            joined = np.concatenate([before[-1:], time_s]) if before.size else time_s
            # where a new stretch starts, counted in the carried rows and the batch
            breaks = np.flatnonzero(np.diff(joined) > threshold) + (
                before.size if before.size else 1)
            blocks[axis].add({k: np.asarray(v, dtype=float) for k, v in log.columns.items()},
                             offset, breaks)
        last_time = float(time_s[-1])
        offset += batch.num_rows
    return {axis: blocks[axis].result(heads[axis], offset, base.where)
            for axis in axes}
