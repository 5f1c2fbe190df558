"""What ``gyroid noise`` does: with one log, read it once, fit each gyro axis's noise, write
the results (:mod:`gyroid.pipeline._axes`); with several runs of one unit, each run's and
the unit's (:mod:`gyroid.allan._unit`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from gyroid.allan._fit import NoiseFit, fit_noise
from gyroid.allan._unit import UnitNoise, fit_unit_noise
from gyroid.errors import GyroidInputError
from gyroid.io._bench_reader import bench_log_from_table
from gyroid.io._datasheet import read_datasheet
from gyroid.io._logs import contiguous_segments, run_labels
from gyroid.io._outputs import output_dir
from gyroid.io._tables import read_log_table, table_source
from gyroid.io._units import ColumnMap
from gyroid.pipeline._axes import PerAxis, chosen_axes, write_axes, write_per_axis
from gyroid.workflows._datasheet import spec_verdicts

#: A clock whose steps vary by more than this (relative) is not a sampled rate.
MAX_STEP_SPREAD = 0.01
#: ``--static``: the moving average the rate is judged on, and the shortest still stretch
#: kept, s.
STILL_WINDOW_S = 1.0
MIN_STILL_S = 10.0


@dataclass(frozen=True)
class NoiseOptions:
    """How ``gyroid noise`` reads and fits a static log: ``maps`` (vendors' columns),
    ``axes`` (None: every axis the log has), ``instance`` (a native log's IMU; None: its
    first), ``static_deg_s`` (keep only still stretches, :func:`still_rows`; None: every
    row), ``datasheet`` (a TOML file each term is judged against) and the ``seed``."""

    seed: int = 0
    maps: tuple[ColumnMap, ...] = ()
    axes: tuple[str, ...] | None = None
    instance: int | None = None
    static_deg_s: float | None = None
    datasheet: str | Path | None = None


def still_rows(time_s: np.ndarray, rates_deg_h: list[np.ndarray], threshold_deg_s: float
               ) -> np.ndarray:
    """The rows of still stretches: every axis's rate, averaged over ``STILL_WINDOW_S``,
    within ``threshold_deg_s`` of its median (the gyro's bias), less ``STILL_WINDOW_S``
    either side of any motion (its slow start and end), in stretches of at least
    ``MIN_STILL_S``."""
    from scipy.ndimage import binary_erosion, uniform_filter1d

    time_s = np.asarray(time_s, dtype=float)
    step = float(np.median(np.diff(time_s))) if time_s.size > 1 else 1.0
    width = max(1, int(round(STILL_WINDOW_S / step)))
    still = np.ones(time_s.size, dtype=bool)
    for rate in rates_deg_h:
        deviation = uniform_filter1d(np.asarray(rate, float) - np.median(rate), width,
                                     mode="nearest")
        still &= np.abs(deviation) <= 3600.0 * threshold_deg_s
    still = binary_erosion(still, np.ones(2 * width + 1, dtype=bool), border_value=1)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], still.astype(int), [0]])))
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        if time_s[stop - 1] - time_s[start] < MIN_STILL_S:
            still[start:stop] = False
    return still


def noise_file(path: str | Path, out: str | Path, options: NoiseOptions = NoiseOptions()
               ) -> PerAxis[NoiseFit]:
    """Fit the noise of a static log's axes and write ``noise.json`` and ``allan.png`` per
    axis to ``out`` (``options``: :class:`NoiseOptions`; a datasheet's verdicts are
    ``noise.json``'s ``spec``)."""
    per_axis = noise_fits(path, options)
    write_per_axis(out, per_axis)
    return per_axis


@dataclass(frozen=True)
class UnitRuns:
    """Several static runs of one unit (or lot): each run's fits (by its label) and the
    unit's terms per axis (:func:`~gyroid.allan.fit_unit_noise`)."""

    runs: dict[str, PerAxis[NoiseFit]]
    unit: PerAxis[UnitNoise]

    @property
    def trustworthy(self) -> bool:
        return self.unit.trustworthy


def noise_unit_files(paths: Sequence[str | Path], out: str | Path,
                     options: NoiseOptions = NoiseOptions(), *,
                     say: Callable[[str], None] = lambda _m: None) -> UnitRuns:
    """Fit each static run in ``paths`` (as :func:`noise_file`) and the unit behind them,
    per axis the runs share; write each run's files to ``out/LABEL/`` (labels as
    :func:`~gyroid.io.run_labels` names runs) and the unit's (``unit.json``, ``unit.png``)
    to ``out/unit/``, all or nothing."""
    labels = run_labels([str(p) for p in paths])
    runs = {}
    for path, label in zip(paths, labels, strict=True):
        say(f"fitting the noise of {path} ...")
        runs[label] = noise_fits(path, options)
    shared = [a for a in next(iter(runs.values())).results
              if all(a in r.results for r in runs.values())]
    if not shared:
        raise GyroidInputError("the runs share no gyro axis: give --axes, or logs of one "
                               "gyro type")
    unit = PerAxis({axis: fit_unit_noise([r.results[axis] for r in runs.values()], labels,
                                         seed=options.seed) for axis in shared},
                   {"runs": {label: r.source for label, r in runs.items()}})
    with output_dir(out) as stage:
        for label, per_axis in runs.items():
            (stage / label).mkdir()
            write_axes(stage / label, per_axis)
        (stage / "unit").mkdir()
        write_axes(stage / "unit", unit)
    return UnitRuns(runs, unit)


def noise_fits(path: str | Path, options: NoiseOptions = NoiseOptions()) -> PerAxis[NoiseFit]:
    """The noise fits of a static log's axes (:func:`noise_file`, nothing written); with a
    datasheet, each fit's verdict per term against it."""
    o = options
    sheet = read_datasheet(o.datasheet) if o.datasheet is not None else None
    table = read_log_table(path, o.maps, o.instance)
    chosen = chosen_axes(table, o.axes)
    logs = {axis: bench_log_from_table(table, None, axis=axis) for axis in chosen}
    source = table_source(table)
    time_s = np.asarray(logs[chosen[0]].time_s)  # every axis's: the table's one clock
    keep = np.ones(time_s.size, dtype=bool)
    if o.static_deg_s is not None:
        keep = still_rows(time_s, [np.asarray(log.drift_deg_h) for log in logs.values()],
                          o.static_deg_s)
        stretches = len(contiguous_segments(time_s[keep])) if keep.any() else 0
        source["static"] = {"threshold_deg_s": o.static_deg_s, "window_s": STILL_WINDOW_S,
                            "min_stretch_s": MIN_STILL_S, "rows_kept": int(keep.sum()),
                            "rows": int(keep.size), "stretches": stretches}
        if not keep.any():
            raise GyroidInputError(
                f"{table.label}: no still stretch of {MIN_STILL_S:g} s or more, the rate "
                f"within {o.static_deg_s:g} deg/s of its median on every axis; raise --static, "
                "or give a log recorded with the gyro still")
    segments, step = _regular_clock(time_s[keep], table.label)
    rows = np.flatnonzero(keep)
    results = {axis: fit_noise(np.asarray(log.drift_deg_h)[keep], step, segments=segments,
                               seed=o.seed, label=table.label,
                               where=lambda i, log=log: log.where(int(rows[i])))
               for axis, log in logs.items()}
    if sheet is not None:
        results = {axis: replace(fit, spec=spec_verdicts(fit.term_summaries(), sheet))
                   for axis, fit in results.items()}
    return PerAxis(results, source)


def _regular_clock(time_s: np.ndarray, label: str) -> tuple[list[tuple[int, int]], float]:
    """The clock's contiguous segments and its median step (s), or one message when the
    steps within the segments are not a sampled rate's."""
    segments = contiguous_segments(time_s)
    steps = np.concatenate([np.diff(time_s[a:b]) for a, b in segments])
    step = float(np.median(steps)) if steps.size else float("nan")
    if not step > 0:
        raise GyroidInputError(f"{label}: the clock does not advance; a noise fit needs a "
                               "sampled rate")
    spread = float(np.quantile(np.abs(steps / step - 1.0), 0.99))
    if spread > MAX_STEP_SPREAD:
        raise GyroidInputError(
            f"{label}: the sample steps vary by {100 * spread:.0f} % (99th percentile) about "
            f"their median {step:.4g} s; a noise fit needs a regular clock (resample the "
            "log, or give the device's own sample counter as time_s)")
    return segments, step
