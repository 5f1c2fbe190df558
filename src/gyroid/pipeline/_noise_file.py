"""What ``gyroid noise`` does with one log: read it once, fit each gyro axis's noise, write
the results (:mod:`gyroid.pipeline._axes`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.inference._noise_fit import NoiseFit, fit_noise
from gyroid.io._bench_reader import bench_log_from_table
from gyroid.io._logs import contiguous_segments
from gyroid.io._tables import read_log_table, table_source
from gyroid.io._units import ColumnMap
from gyroid.pipeline._axes import PerAxis, chosen_axes, write_per_axis

#: A clock whose steps vary by more than this (relative) is not a sampled rate.
MAX_STEP_SPREAD = 0.01


def noise_file(path: str | Path, out: str | Path, *, seed: int = 0,
               maps: tuple[ColumnMap, ...] = (), axes: tuple[str, ...] | None = None,
               instance: int | None = None) -> PerAxis[NoiseFit]:
    """Fit the noise of a static log's axes (``axes``; default every axis it has) and write
    ``noise.json`` and ``allan.png`` per axis to ``out``."""
    table = read_log_table(path, maps, instance)
    results = {}
    for axis in chosen_axes(table, axes):
        log = bench_log_from_table(table, None, axis=axis)
        time_s = np.asarray(log.time_s)
        segments = contiguous_segments(time_s)
        steps = np.concatenate([np.diff(time_s[a:b]) for a, b in segments])
        step = float(np.median(steps)) if steps.size else float("nan")
        if not step > 0:
            raise GyroidInputError(f"{table.label}: the clock does not advance; a noise fit "
                                   "needs a sampled rate")
        spread = float(np.quantile(np.abs(steps / step - 1.0), 0.99))
        if spread > MAX_STEP_SPREAD:
            raise GyroidInputError(
                f"{table.label}: the sample steps vary by {100 * spread:.0f} % (99th "
                f"percentile) about their median {step:.4g} s; a noise fit needs a regular "
                "clock (resample the log, or give the device's own sample counter as time_s)")
        results[axis] = fit_noise(np.asarray(log.drift_deg_h), step, segments=segments,
                                  seed=seed, label=table.label)
    per_axis = PerAxis(results, table_source(table))
    write_per_axis(out, per_axis)
    return per_axis
