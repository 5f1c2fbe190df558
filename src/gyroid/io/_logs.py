"""Bench logs (docs/formats.md section 1): the validated log, its contiguous stretches and
means; reading is :mod:`gyroid.io._bench_reader`, writing :mod:`gyroid.io._log_writer`."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.models._derived import HYSTERESIS_DEADBAND_UT, RATE_WINDOW_S
from gyroid.models._inputs import (
    ACCEL_COLUMNS,
    FIELD_COLUMNS,
    T0_C,
    DriftInputs,
    build_inputs,
)

#: Columns of a bench log that gyroid reads, in the order it writes them.
BENCH_COLUMNS = ("time_s", "drift_deg_h", "temperature_C", *FIELD_COLUMNS, *ACCEL_COLUMNS,
                 "sigma_deg_h")


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
    #: The gyro axis whose drift this is, for a log of several axes (None: the log has one).
    axis: str | None = None

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


#: A step longer than this many median steps splits the log into segments (a pause, not a
#: sample or two lost: a 10 s log with the odd 20 s step is one stretch).
GAP_FACTOR = 5.0
#: A clock whose steps exceed 3 median steps this often is jittered (host time stamps that
#: arrive in bursts: 1 ms to 0.5 s apart for a steady 99 Hz sensor)...
JITTERED_FRACTION = 0.05
#: ... and on it only a pause longer than this many mean steps (the sensor's rate) is a gap.
JITTER_GAP_FACTOR = 100.0


def gap_threshold(time_s: np.ndarray) -> float:
    """The step (s) beyond which a log's clock is taken to have paused: ``GAP_FACTOR``
    median steps, or on a jittered clock ``JITTER_GAP_FACTOR`` times the sensor's mean step
    (the median over windows of 100 steps of their mean, so that real pauses do not count)."""
    steps = np.diff(np.asarray(time_s, dtype=float))
    if steps.size == 0:
        return np.inf
    median = float(np.median(steps))
    threshold = GAP_FACTOR * median
    if np.mean(steps > 3.0 * median) > JITTERED_FRACTION:
        k = min(100, steps.size)
        windows = steps[: steps.size // k * k].reshape(-1, k).mean(axis=1)
        threshold = max(threshold, JITTER_GAP_FACTOR * float(np.median(windows)))
    return threshold


def contiguous_segments(time_s: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges ``[start, stop)`` of the log's stretches without a pause
    (:func:`gap_threshold`)."""
    time_s = np.asarray(time_s, dtype=float)
    steps = np.diff(time_s)
    if steps.size == 0:
        return [(0, time_s.size)]
    breaks = np.flatnonzero(steps > gap_threshold(time_s)) + 1
    edges = np.concatenate([[0], breaks, [time_s.size]])
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True)]


#: Fewest contiguous segments a log of bursts needs for a fit of their means.
MIN_SEGMENTS = 8


#: A sample's deviation from its mean, over the pooled sd, below which the spike check
#: never calls it a spike (its threshold is 3.4 sd for 16 samples, and grows with more).
SPIKE_CANDIDATE_Z = 3.0


@dataclass(frozen=True, eq=False)
class SampleDeviations:
    """The samples behind a fit of means (of blocks or of a burst log's segments), as the
    spike check reads them, since the means hide spikes: ``n`` samples, each one's drift
    about its mean over the pooled within-mean sd ``within_sd`` (deg/h), kept only beyond
    :data:`SPIKE_CANDIDATE_Z` (``rows``, 0-based, and their ``z``), the sum of every
    sample's ``z**2``, and the samples' row names. ``head``: the samples themselves, or for
    a log read as a stream its first stretch (what the units check reads)."""

    n: int
    rows: np.ndarray = field(repr=False)
    z: np.ndarray = field(repr=False)
    z_sum_sq: float
    within_sd: float
    head: BenchLog = field(repr=False)
    where: Callable[[int], str] = field(repr=False)

    @classmethod
    def of(cls, log: BenchLog, z: np.ndarray, within_sd: float) -> SampleDeviations:
        """From every sample's ``z`` (over ``within_sd``, deg/h)."""
        z = np.asarray(z, dtype=float)
        rows = np.flatnonzero(np.abs(z) > SPIKE_CANDIDATE_Z)
        return cls(log.n, rows, z[rows], float(z @ z), within_sd, log, log.where)


#: The fewest samples in a block that the spike check reads about the block's line.
LINE_FROM = 5


def about_local_lines(drift: np.ndarray, time_s: np.ndarray) -> np.ndarray:
    """Each row of ``drift`` (blocks x samples, deg/h) about its own least-squares line in
    ``time_s`` (s): what the spike check reads of the samples behind a mean. About the
    block's mean alone, the drift's own slope across a block (a temperature ramp's) made
    its end samples look like spikes: the tour's bench named two samples "beyond 5.1
    sd" whose noise was +3.4 and +3.2 sd. Two degrees of freedom per block; a block of
    fewer than :data:`LINE_FROM` samples cannot spare them (of two, nothing would be left to
    test) and is read about its mean, the slope across so few samples small beside their
    noise."""
    drift = np.atleast_2d(np.asarray(drift, dtype=float))
    about_mean = drift - drift.mean(axis=1, keepdims=True)
    if drift.shape[1] < LINE_FROM:
        return about_mean
    t = np.atleast_2d(np.asarray(time_s, dtype=float))
    t = t - t.mean(axis=1, keepdims=True)
    tt = np.sum(t * t, axis=1, keepdims=True)
    slope = np.sum(t * about_mean, axis=1, keepdims=True) / np.where(tt > 0, tt, 1.0)
    return about_mean - slope * t


def line_dof(counts) -> int:
    """The degrees of freedom left by :func:`about_local_lines` in blocks of ``counts``
    samples (a line takes two; a mean, in a block too short for a line, one)."""
    return int(sum(int(c) - (2 if c >= LINE_FROM else 1) for c in np.atleast_1d(counts)
                   if c > 0))


def segment_means(log: BenchLog, segments: list[tuple[int, int]]
                  ) -> tuple[BenchLog, SampleDeviations]:
    """One row per contiguous segment (burst) of ``log``: every column's mean over it
    (``sigma_deg_h`` dropped: it describes a sample, not the wander between bursts); and
    each sample's drift about its segment's mean (for the spike check the averaging would
    hide)."""
    if len(segments) < MIN_SEGMENTS:
        raise GyroidInputError(
            f"a fit of segment means needs a log of bursts with at least {MIN_SEGMENTS} "
            f"contiguous segments; {log.source} has {len(segments)}: fit its samples instead")
    columns = {name: np.array([values[a:b].mean() for a, b in segments])
               for name, values in log.columns.items() if name != "sigma_deg_h"}
    drift, time_s = np.asarray(log.drift_deg_h, dtype=float), np.asarray(log.time_s)
    deviation = np.concatenate([about_local_lines(drift[a:b], time_s[a:b]).ravel()
                                for a, b in segments])
    dof = line_dof([b - a for a, b in segments])
    scale = float(np.sqrt(np.sum(deviation**2) / dof)) if dof > 0 else 0.0
    within = deviation / scale if scale > 0 else np.zeros_like(deviation)
    comments = (*log.comments, f"means of the {len(segments)} contiguous segments of "
                f"{log.source} ({log.n} rows)")
    return (BenchLog(columns=columns, source=f"{log.source} (segment means)",
                     comments=comments), SampleDeviations.of(log, within, scale))


def _block_rows(log: BenchLog, rows: int) -> np.ndarray:
    """(blocks, rows) indices of the samples in each block of ``rows`` consecutive samples
    inside each contiguous segment (a segment's last incomplete block dropped)."""
    starts = np.concatenate([np.arange(a, b - rows + 1, rows, dtype=int)
                             for a, b in contiguous_segments(np.asarray(log.time_s))])
    return starts[:, None] + np.arange(rows)[None, :]


def block_means(log: BenchLog, rows: int, index: np.ndarray | None = None) -> BenchLog:
    """``log`` with every column averaged over blocks of ``rows`` consecutive samples inside
    each contiguous segment (a segment's last incomplete block is dropped, so that every
    block is a mean of exactly ``rows`` samples and its white noise is ``1/sqrt(rows)`` of
    a sample's). ``sigma_deg_h`` becomes the mean's sd. Rows are named by their first
    sample. ``index``: the blocks' rows (:func:`_block_rows`), if already found."""
    index = _block_rows(log, rows) if index is None else index
    columns = means_of_blocks({name: np.asarray(values, dtype=float)[index]
                               for name, values in log.columns.items()})
    return log_of_means(columns, rows, index[:, 0], log, log.where,
                        f"means of {rows} consecutive samples of {log.source}")


def means_of_blocks(blocks: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Every column's mean over each block (a row of its ``(blocks, samples)`` array);
    ``sigma_deg_h`` becomes the mean's sd."""
    return {name: (np.sqrt(np.sum(values**2, axis=1)) / values.shape[1]
                   if name == "sigma_deg_h" else values.mean(axis=1))
            for name, values in blocks.items()}


def log_of_means(columns: Mapping[str, np.ndarray], rows: int, starts: np.ndarray,
                 samples: BenchLog, where: Callable[[int], str], comment: str) -> BenchLog:
    """The log of block means ``columns`` (``rows`` samples each), its row ``k`` named by
    the sample ``starts[k]`` it begins at (``where``: the samples' row names), with the
    samples' comments, extra columns and axis, and ``comment`` saying what it is."""
    return BenchLog(columns=dict(columns), source=f"{samples.source} ({rows}-sample means)",
                    comments=(*samples.comments, comment),
                    row_name=_MeanRowName(rows, np.asarray(starts), where),
                    extra_columns=samples.extra_columns, axis=samples.axis)


@dataclass(frozen=True)
class _MeanRowName:
    """A block mean's row name: the sample it begins at (a class, not a closure, so that a
    log of means, and the fits that hold one, cross a process boundary: the demo's second
    process, a Dask worker)."""

    rows: int
    starts: np.ndarray
    where: Callable[[int], str]

    def __call__(self, k: int) -> str:
        return f"the mean of {self.rows} samples from {self.where(int(self.starts[k]))}"


def block_deviations(log: BenchLog, rows: int, index: np.ndarray | None = None
                     ) -> SampleDeviations:
    """Each sample's drift about its block's line (the blocks of :func:`block_means`;
    :func:`about_local_lines`), 0 for a sample in no block."""
    index = _block_rows(log, rows) if index is None else index
    drift = np.asarray(log.drift_deg_h, dtype=float)
    deviation = about_local_lines(drift[index], np.asarray(log.time_s)[index])
    dof = line_dof([index.shape[1]] * index.shape[0])
    scale = float(np.sqrt(np.sum(deviation**2) / dof)) if dof > 0 else 0.0
    out = np.zeros(log.n)
    if scale > 0:
        out[index.ravel()] = deviation.ravel() / scale
    return SampleDeviations.of(log, out, scale)


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


@dataclass(frozen=True, eq=False)
class MeansOfBlocks:
    """A log reduced to the means of blocks of ``rows_per_mean`` consecutive samples
    (:func:`block_means`, or read as a stream: :mod:`gyroid.io._stream`) and what the
    spike check needs of the samples behind them."""

    log: BenchLog
    rows_per_mean: int
    samples: SampleDeviations

    @classmethod
    def of(cls, log: BenchLog, rows: int) -> MeansOfBlocks:
        """``log`` held whole, its blocks found once for the means and the deviations."""
        index = _block_rows(log, rows)
        return cls(block_means(log, rows, index), rows, block_deviations(log, rows, index))
