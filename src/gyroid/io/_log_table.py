"""A log read into named columns (:class:`LogTable`), whatever its format: what every
reader returns and every log type is built from."""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._units import AXIS_COLUMN, ColumnMap, axis_column, unit_list


@dataclass(frozen=True)
class LogTable:
    """A log's header, comment lines and parsed columns, with data-row line numbers."""

    path: Path
    header: tuple[str, ...]
    raw: dict  # column name -> numpy array (float, or object/str for text)
    n_rows: int
    first_line: int | None  # file line of data row 0 when rows are consecutive lines
    lines: np.ndarray | None = None  # else: the file line of every data row
    comments: tuple[str, ...] = ()
    maps: tuple[ColumnMap, ...] = field(default=())
    decimal_comma: bool = False
    empty: dict = field(default_factory=dict)  # column -> mask of empty cells (numeric cols)
    #: What a native log's reader chose from the file (stream, instance, units), reported.
    picked: dict = field(default_factory=dict)
    #: The file's row of data row 0 (a batch of a log read as a stream), 0-based.
    row_offset: int = 0

    def where(self, row: int) -> str:
        """Human description of data row ``row`` (0-based): 'row 3 (line 7 of log.csv)'."""
        row += self.row_offset
        if self.lines is not None:
            return f"row {row + 1} (line {self.lines[row]} of {self.path.name})"
        if self.first_line is not None:
            return f"row {row + 1} (line {self.first_line + row} of {self.path.name})"
        return f"row {row + 1} of {self.path.name}"

    def _source(self, name: str) -> tuple[str, ColumnMap | None]:
        for m in self.maps:
            if m.target == name:
                return m.source, m
        return name, None

    def has(self, name: str) -> bool:
        return self._source(name)[0] in self.header

    def axes(self) -> tuple[str, ...]:
        """The gyro axes the log has, by their drift columns ``drift_AXIS_deg_h`` (in the
        header, or mapped onto with --map)."""
        names = [*self.header, *(m.target for m in self.maps)]
        return tuple(dict.fromkeys(m.group(1) for name in names
                                   if (m := AXIS_COLUMN.match(name)) and self.has(name)))

    def with_axis(self, axis: str) -> LogTable:
        """The table read with ``axis``'s drift column as ``drift_deg_h`` (its unit map, if
        any, kept)."""
        source, mapped = self._source(axis_column(axis))
        drift = ColumnMap("drift_deg_h", source, mapped.unit if mapped else None)
        maps = tuple(m for m in self.maps if m.target != "drift_deg_h") + (drift,)
        return replace(self, maps=maps)

    def missing(self, name: str, advice: str) -> GyroidInputError:
        source, mapped = self._source(name)
        what = f"column {source!r} (mapped to {name})" if mapped else f"column {name!r}"
        return GyroidInputError(f"{self.label}: {what} is missing (the header has "
                                f"{', '.join(self.header)}); {advice}")

    def number_column(self, name: str, advice: str | None = None) -> np.ndarray:
        """One column as finite floats in the contract's unit, refusing the first bad cell."""
        source, mapped = self._source(name)
        if source not in self.header:
            raise self.missing(name, advice or (
                f"add it, map a column of yours onto it with --map {name}=COLUMN[:UNIT]"
                f"{unit_list(name)}, or choose terms that do not need it"))
        values = self._floats(source)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise self._bad_cell(source, values, bad)
        return mapped.convert(values) if mapped is not None else values

    def _bad_cell(self, source: str, values: np.ndarray, bad: np.ndarray) -> GyroidInputError:
        """The message for a column's first cell that is not a finite value."""
        column = self.raw[source]
        if bad.size == values.size and all(
                c is None or (source in self.empty and self.empty[source][k]) or
                str(c).strip().lower() in ("", "nan", "none", "null")
                for k, c in enumerate(column[: min(column.size, 1000)])):
            return GyroidInputError(
                f"{self.label}: column {source} is empty in every row: fill it in, or map "
                "another column onto it with --map")
        i = int(bad[0])
        cell = column[i]
        empty = source in self.empty and bool(self.empty[source][i])
        text = "" if cell is None or empty else str(cell).strip()
        kind = ("an ISO 8601 date-time" if values.dtype.kind == "f" and self._is_clock(source)
                else "a number")
        what = "is empty" if not text or text.lower() in ("none", "null") else (
            f"is {text!r}, not {kind}" if not _is_float(text) or kind != "a number"
            else f"is {text}")
        if re.fullmatch(r"[+-]?\d+,\d+", text):
            return GyroidInputError(
                f"{self.label}: {self.where(i)}, column {source}: the value {text!r} has a "
                "decimal comma, which gyroid reads only in ;-separated files: save the log "
                "with '.' decimals, or with ';' between the columns")
        advice = ("fix or remove the row" if ", not " in what or "empty" in what
                  else "remove the row or fill in a measured value")
        return GyroidInputError(f"{self.label}: {self.where(i)}, column {source}: the value "
                                f"{what}; {advice}")

    @property
    def label(self) -> str:
        """How messages name the file: its path as given when relative, else its folder
        and name (several logs named bench.csv are told apart)."""
        if not self.path.is_absolute():
            return str(self.path)
        return f"{self.path.parent.name}/{self.path.name}" if self.path.parent.name else \
            self.path.name

    def try_number_column(self, name: str) -> np.ndarray | None:
        """A column if present and clean, else ``None`` (for optional context columns)."""
        if not self.has(name):
            return None
        try:
            return self.number_column(name)
        except GyroidInputError:
            return None

    def _floats(self, source: str) -> np.ndarray:
        column = self.raw[source]
        if column.dtype.kind in "fiub":
            return np.asarray(column, dtype=float)  # no copy when already float64
        if column.dtype.kind == "M" or self._is_clock(source):
            return _seconds(column)
        text = np.asarray(column, dtype=object)
        out = np.full(text.size, np.nan)
        for i, cell in enumerate(text):
            if cell is None:
                continue
            cell = str(cell).strip()
            if self.decimal_comma:
                cell = cell.replace(",", ".")
            try:
                out[i] = float(cell)
            except ValueError:
                break  # the first bad cell ends the scan: it is what the error names
        return out


    def _is_clock(self, source: str) -> bool:
        """A text column read as a date-time clock: mapped with the unit ``datetime``, or
        the ``time_s`` column holding ISO 8601 date-times."""
        for m in self.maps:
            if m.source == source and m.target == "time_s":
                return m.unit == "datetime" or (m.unit is None and _looks_like_date(
                    self.raw[source]))
        return source == "time_s" and _looks_like_date(self.raw[source])


def _looks_like_date(column: np.ndarray) -> bool:
    first = next((c for c in column[:10] if c is not None), None)
    if first is None or _is_float(str(first).strip()):
        return False
    try:
        np.datetime64(str(first).strip().rstrip("Z"), "ns")
    except ValueError:
        return False
    return True


def _seconds(column: np.ndarray) -> np.ndarray:
    """A date-time column (datetime64, or ISO 8601 text; a zone-less time taken as UTC) as
    seconds since 1970; a cell that is no date-time is NaN (the caller names its row)."""
    if column.dtype.kind != "M":
        out = np.full(column.size, np.datetime64("NaT"), dtype="datetime64[ns]")
        for i, cell in enumerate(column):
            try:
                out[i] = np.datetime64(str(cell).strip().rstrip("Z"), "ns")
            except (ValueError, TypeError):
                break  # the first bad cell ends the scan: it is what the error names
        column = out
    nat = np.isnat(column)
    seconds = column.astype("datetime64[ns]").astype(np.int64) / 1e9
    return np.where(nat, np.nan, seconds)


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
