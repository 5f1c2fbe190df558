"""A log's gyro axes as a dimension: which axes a command runs on, the results per axis, and
their files (docs/formats.md section 5): with one axis in ``OUT`` as before, with several
in ``OUT/AXIS/`` each and ``OUT/axes.json``."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Generic, Protocol, TypeVar

from gyroid.errors import GyroidInputError
from gyroid.io._log_table import LogTable
from gyroid.io._outputs import json_text, output_dir
from gyroid.reports._write import write


class Judged(Protocol):
    """A result a command writes: its self-checks' verdict."""

    @property
    def trustworthy(self) -> bool: ...


R = TypeVar("R", bound=Judged)


@dataclass(frozen=True)
class PerAxis(Generic[R]):
    """A command's results on one log, one per gyro axis (keyed None for a log of one drift
    column), and what the reader picked from the file. Each result has ``checks`` and
    ``trustworthy``."""

    results: dict[str | None, R]
    source: dict[str, object]
    #: Causes several axes show at once (the discrepancy search's), in ``axes.json``.
    shared: list[dict] = field(default_factory=list)

    @property
    def trustworthy(self) -> bool:
        return all(result.trustworthy for result in self.results.values())

    @property
    def several(self) -> bool:
        """True when the axes are written to a folder each, with ``axes.json``."""
        return len(self.results) > 1

    @property
    def only(self) -> R:
        """The result of a log read for one axis."""
        if self.several:
            raise ValueError(f"{len(self.results)} axes: pick one from results")
        return next(iter(self.results.values()))

    def to_json(self) -> dict:
        """``axes.json``."""
        return {"axes": {axis: {"trustworthy": result.trustworthy,
                                "exit": 0 if result.trustworthy else 3, "folder": axis}
                         for axis, result in self.results.items()},
                "source": self.source} | ({"shared": self.shared} if self.shared else {})


def chosen_axes(table: LogTable, wanted: tuple[str, ...] | None) -> tuple[str | None, ...]:
    """The axes to run on: ``wanted`` (each checked against the log's), or every axis the
    log has; ``(None,)`` for a log of one ``drift_deg_h`` column."""
    have = table.axes()
    if wanted is None:
        return (None,) if table.has("drift_deg_h") or not have else have
    unknown = [axis for axis in wanted if axis not in have]
    if unknown:
        listed = (f"its axes are {', '.join(have)}" if have else
                  "it has one drift column: leave --axes out")
        raise GyroidInputError(f"--axes {','.join(wanted)}: {table.label} has no gyro axis "
                               f"{unknown[0]!r} ({listed})")
    return wanted


def write_per_axis(out: str | Path, per_axis: PerAxis, **context) -> None:
    """Every axis's files, whole or not at all (``context`` as :func:`reports.write`'s)."""
    with output_dir(out) as stage:
        write_axes(stage, per_axis, **context)


def write_axes(folder: Path, per_axis: PerAxis, **context) -> None:
    """Every axis's files into ``folder`` (which exists): the one axis's there, or a folder
    per axis and ``axes.json``."""
    if not per_axis.several:
        write(folder, per_axis.only, **context)
        return
    for axis, result in per_axis.results.items():
        if axis is None:
            raise ValueError("a log's one drift column among several axes")
        (folder / axis).mkdir()
        write(folder / axis, result, **context)
    (folder / "axes.json").write_text(json_text(per_axis.to_json()))
