"""What ``gyroid compensate`` does with one log: read it once, compensate each gyro axis with
its axis's fit (a fit folder of one axis, or the folder of a fit of several with
``axes.json``), write the results (:mod:`gyroid.pipeline._axes`)."""

from __future__ import annotations

from pathlib import Path

from gyroid.errors import GyroidInputError
from gyroid.io._bench_reader import bench_log_from_table
from gyroid.io._fitted import FittedDrift, axes_of
from gyroid.io._memory import COMPENSATE_BYTES_PER_ROW, refuse_if_too_long
from gyroid.io._tables import read_log_table, table_source
from gyroid.io._units import ColumnMap
from gyroid.pipeline._axes import PerAxis, chosen_axes, write_per_axis
from gyroid.workflows._compensate import WINDOW_S, Compensation, compensate
from gyroid.workflows._turn_on import SAME_RUN, TurnOn


def fitted_axes(fit_dir: str | Path) -> dict[str | None, FittedDrift]:
    """A fit folder's fitted drift per axis: ``{None: fit}`` for a fit of one axis, every
    ``AXIS/`` of a fit of several (listed in its ``axes.json``)."""
    return axes_of(fit_dir, FittedDrift.from_dir)


def compensate_file(path: str | Path, fit_dir: str | Path, out: str | Path, *, seed: int = 0,
                    maps: tuple[ColumnMap, ...] = (), axes: tuple[str, ...] | None = None,
                    instance: int | None = None, window_s: float = WINDOW_S,
                    turn_on: TurnOn = SAME_RUN) -> PerAxis[Compensation]:
    """Compensate one log's axes (``axes``; default every axis the fit has; ``instance``: a
    native log's IMU) with their fits and write the results to ``out`` (the means over
    windows of ``window_s`` seconds in ``compensated_means.csv``; ``turn_on``: whether the
    log is another power-on than the fitted one's)."""
    refuse_if_too_long(path, bytes_per_row=COMPENSATE_BYTES_PER_ROW, command="compensating",
                       remedy="compensate it in parts (its rows split by time), or on a "
                       "machine with more memory")
    table = read_log_table(path, maps, instance)
    fits = fitted_axes(fit_dir)
    if None in fits:  # a fit of one axis: the log's one drift column, or one chosen axis
        chosen = chosen_axes(table, axes)
        if len(chosen) != 1:
            raise GyroidInputError(
                f"{fit_dir} is a fit of one axis and {table.label} has {len(chosen)} "
                f"({', '.join(a for a in chosen if a)}): choose the one it was fitted to "
                "with --axes")
        pairs = {chosen[0]: fits[None]}
    else:
        named = {axis: fitted for axis, fitted in fits.items() if axis is not None}
        if table.has("drift_deg_h") and not table.axes():
            raise GyroidInputError(f"{fit_dir} is a fit of axes {', '.join(named)} and "
                                   f"{table.label} has one drift column: give the fit of "
                                   "one axis (its folder, e.g. FIT_DIR/x)")
        chosen = chosen_axes(table, axes or tuple(named))
        missing = [axis for axis in chosen if axis not in named]
        if missing:
            raise GyroidInputError(f"{fit_dir} has no fit of axis {missing[0]!r} (it has "
                                   f"{', '.join(named)}); fit that axis or leave it out of "
                                   "--axes")
        pairs = {axis: fits[axis] for axis in chosen}
    results = {axis: compensate(bench_log_from_table(table, fitted.model, axis=axis), fitted,
                                seed=seed, window_s=window_s, turn_on=turn_on)
               for axis, fitted in pairs.items()}
    per_axis = PerAxis(results, table_source(table))
    write_per_axis(out, per_axis)
    return per_axis
