"""What ``gyroid discrepancy`` does with one log: read it (a bench log, each gyro axis of
it, or a roll log), search what the model misses, write the reports
(:mod:`gyroid.pipeline._axes`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from gyroid.io._bench_reader import bench_log_from_table
from gyroid.io._memory import DISCREPANCY_BYTES_PER_ROW, refuse_if_too_long
from gyroid.io._roll_log import load_roll_log
from gyroid.io._tables import log_kind, read_log_table, table_source
from gyroid.io._units import ColumnMap
from gyroid.models._inputs import T0_C
from gyroid.pipeline._axes import PerAxis, chosen_axes, write_per_axis
from gyroid.workflows._discrepancy import find_discrepancies
from gyroid.workflows._discrepancy_report import DiscrepancyReport
from gyroid.workflows._roll_discrepancy import find_roll_discrepancies
from gyroid.workflows._shared_causes import shared_causes


def discrepancy_file(path: Path, out: Path, terms: str, *, t0_C: float = T0_C,
                     max_added: int = 3, extra_columns: bool = False,
                     maps: tuple[ColumnMap, ...] = (), axes: tuple[str, ...] | None = None,
                     instance: int | None = None,
                     say: Callable[[str], None] = lambda _m: None
                     ) -> PerAxis[DiscrepancyReport]:
    """Search what ``terms`` misses in the log at ``path`` (every chosen gyro axis of a
    bench log, or a roll log) and write ``discrepancy.json`` and ``discrepancy.png`` (a
    folder per axis for several) to ``out``. ``say`` receives progress lines."""
    if log_kind(path, maps) == "roll":
        log = load_roll_log(path, column_map=maps)
        say(f"searching what {terms} misses in roll log {path} ({log.n} rows) ...")
        result = PerAxis({None: find_roll_discrepancies(log, terms, max_added=max_added,
                                                        progress=say)}, {"path": str(path)})
    else:
        refuse_if_too_long(path, bytes_per_row=DISCREPANCY_BYTES_PER_ROW,
                           command="the discrepancy search",
                           remedy="search a part of it (its rows split by time), or on a "
                           "machine with more memory")
        table = read_log_table(path, maps, instance)
        reports, logs = {}, {}
        for axis in chosen_axes(table, axes):
            log = bench_log_from_table(table, terms, extra_columns=extra_columns, axis=axis)
            extra = (f"; extra columns {', '.join(log.extra_columns)}" if log.extra_columns
                     else "")
            which = f" (axis {axis})" if axis is not None else ""
            say(f"searching what {terms} misses in {path}{which} ({log.n} rows{extra}) ...")
            reports[axis] = find_discrepancies(log, terms, max_added=max_added, t0_C=t0_C,
                                               progress=say)
            logs[axis] = log
        if len(reports) > 1:
            say("  comparing the axes ...")
        result = PerAxis(reports, table_source(table), shared_causes(reports, logs, t0_C=t0_C))
    write_per_axis(out, result)
    return result
