"""Strict reading of gyroid's CSV logs: every bad cell is named by row, line and column."""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError


@dataclass(frozen=True)
class CsvTable:
    """A CSV file's header, comment lines and raw cells (text), with source line numbers."""

    path: Path
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    lines: tuple[int, ...]  # 1-based line number in the file of each data row
    comments: tuple[str, ...] = field(default=())

    @property
    def n_rows(self) -> int:
        return len(self.rows)

    def where(self, row: int) -> str:
        """Human description of data row ``row`` (0-based): 'row 3 (line 7)'."""
        return f"row {row + 1} (line {self.lines[row]} of {self.path.name})"

    def number_column(self, name: str) -> np.ndarray:
        """Parse one column as finite floats, refusing the first bad cell."""
        if name not in self.header:
            raise GyroidInputError(
                f"{self.path.name}: column {name!r} is missing (the header has "
                f"{', '.join(self.header)}); add it or choose terms that do not need it"
            )
        j = self.header.index(name)
        values = np.empty(self.n_rows)
        for i, row in enumerate(self.rows):
            cell = row[j].strip()
            try:
                value = float(cell)
            except ValueError:
                what = "is empty" if not cell else f"is {cell!r}, not a number"
                raise GyroidInputError(
                    f"{self.path.name}: {self.where(i)}, column {name}: the value {what}; "
                    "fix or remove the row"
                ) from None
            if not math.isfinite(value):
                raise GyroidInputError(
                    f"{self.path.name}: {self.where(i)}, column {name}: the value is {cell}; "
                    "remove the row or fill in a measured value"
                )
            values[i] = value
        return values

    def try_number_column(self, name: str) -> np.ndarray | None:
        """Parse a column if present and clean, else ``None`` (for optional context columns)."""
        if name not in self.header:
            return None
        try:
            return self.number_column(name)
        except GyroidInputError:
            return None


def read_csv_table(path: str | Path) -> CsvTable:
    """Read a comma-separated log with ``#`` comment lines and a header row."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise GyroidInputError(f"{path}: no such file; check the path") from None
    except IsADirectoryError:
        raise GyroidInputError(f"{path} is a folder; give the CSV log file") from None
    except UnicodeDecodeError:
        raise GyroidInputError(f"{path}: not a UTF-8 text file; give a CSV log") from None
    comments: list[str] = []
    header: tuple[str, ...] | None = None
    rows: list[tuple[str, ...]] = []
    lines: list[int] = []
    reader = csv.reader(io.StringIO(text))
    for cells in reader:
        line = reader.line_num
        if not cells or all(not c.strip() for c in cells):
            continue
        if cells[0].lstrip().startswith("#"):
            comments.append(",".join(cells).lstrip()[1:].strip())
            continue
        if header is None:
            header = tuple(c.strip() for c in cells)
            duplicates = sorted({c for c in header if header.count(c) > 1})
            if duplicates:
                raise GyroidInputError(
                    f"{path.name}: the header names column {duplicates[0]!r} twice "
                    f"(line {line}); rename one of them"
                )
            continue
        if len(cells) != len(header):
            raise GyroidInputError(
                f"{path.name}: row {len(rows) + 1} (line {line}) has {len(cells)} fields but "
                f"the header has {len(header)}; fix the row's commas"
            )
        rows.append(tuple(cells))
        lines.append(line)
    if header is None:
        raise GyroidInputError(f"{path.name}: no header row found; the file is empty")
    if not rows:
        raise GyroidInputError(f"{path.name}: the header is there but there are no data rows")
    return CsvTable(path, header, tuple(rows), tuple(lines), tuple(comments))


def check_time_increasing(table: CsvTable, time_s: np.ndarray) -> None:
    """Refuse a time column that is not strictly increasing, naming the first bad row."""
    steps = np.diff(time_s)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise GyroidInputError(
            f"{table.path.name}: time_s does not increase at {table.where(i)}: "
            f"{time_s[i]:g} s follows {time_s[i - 1]:g} s; sort the log by time and remove "
            "repeated samples"
        )
