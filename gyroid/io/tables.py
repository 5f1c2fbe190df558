"""Reading logs: CSV (comma, semicolon or tab), .csv.gz and .parquet, with every bad cell
named by row, line and column, and vendors' columns and units mapped onto the contract's.

CSV files are parsed by pyarrow (vectorised); the strict checks run on the parsed columns
and name the first bad row. A file pyarrow cannot split into rows (a row with the wrong
number of fields, comment lines between data rows) is read again by Python's csv module,
which names the offending line.
"""

from __future__ import annotations

import csv
import gzip
import io
import math
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError

# ----- vendors' columns and units (--map) ---------------------------------------------------

_DEG_H_PER = {"deg/h": 1.0, "dph": 1.0, "deg/s": 3600.0, "dps": 3600.0,
              "mdps": 3.6, "mdeg/s": 3.6, "rad/s": 3600.0 * 180.0 / math.pi,
              "mrad/s": 3.6 * 180.0 / math.pi, "deg/min": 60.0, "rad/h": 180.0 / math.pi}
_UT_PER = {"uT": 1.0, "T": 1e6, "mT": 1e3, "nT": 1e-3, "G": 100.0, "mG": 0.1, "gauss": 100.0}
_S_PER = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "min": 60.0, "h": 3600.0}
_DEG_PER = {"deg": 1.0, "rad": 180.0 / math.pi, "mrad": 0.18 / math.pi}


def _scale(table: dict[str, float], target: float):
    return {unit: (lambda v, f=factor / target: v * f) for unit, factor in table.items()}


_TEMPERATURE = {"degC": lambda v: v, "C": lambda v: v, "K": lambda v: v - 273.15,
                "degF": lambda v: (v - 32.0) * 5.0 / 9.0, "F": lambda v: (v - 32.0) * 5.0 / 9.0}
#: Per contract column: its unit conversions (unit -> function to the contract's unit).
CONVERSIONS = {
    "time_s": _scale(_S_PER, 1.0),
    "drift_deg_h": _scale(_DEG_H_PER, 1.0),
    "sigma_deg_h": _scale(_DEG_H_PER, 1.0),
    "temperature_C": _TEMPERATURE,
    **{name: _scale(_UT_PER, 1.0) for name in ("Hx_uT", "Hy_uT", "Hz_uT")},
    "roll_rate_deg_s": _scale(_DEG_H_PER, 3600.0),
    "gs_rate_deg_s": _scale(_DEG_H_PER, 3600.0),
    "gs_angle_deg": _scale(_DEG_PER, 1.0),
}


@dataclass(frozen=True)
class ColumnMap:
    """``--map CONTRACT_COLUMN=LOG_COLUMN[:UNIT]``."""

    target: str
    source: str
    unit: str | None = None

    def convert(self, values: np.ndarray) -> np.ndarray:
        if self.unit is None:
            return values
        return CONVERSIONS[self.target][self.unit](values)


def parse_column_maps(items: Iterable[str]) -> tuple[ColumnMap, ...]:
    """Parse ``CONTRACT=LOG[:UNIT]`` items, refusing unknown columns and units."""
    maps: list[ColumnMap] = []
    for item in items:
        target, sep, rest = item.partition("=")
        target, rest = target.strip(), rest.strip()
        if not sep or not target or not rest:
            raise GyroidInputError(f"--map {item!r}: write CONTRACT_COLUMN=LOG_COLUMN[:UNIT]")
        if target not in CONVERSIONS:
            raise GyroidInputError(f"--map {item!r}: {target!r} is not a contract column; use "
                                   f"one of {', '.join(CONVERSIONS)}")
        source, _, unit = rest.rpartition(":") if ":" in rest else (rest, "", "")
        unit = unit.strip() or None
        if unit is not None and unit not in CONVERSIONS[target]:
            raise GyroidInputError(f"--map {item!r}: unknown unit {unit!r} for {target}; use "
                                   f"one of {', '.join(CONVERSIONS[target])}")
        if any(m.target == target for m in maps):
            raise GyroidInputError(f"--map names {target} twice")
        maps.append(ColumnMap(target, source.strip(), unit))
    return tuple(maps)


# ----- the table ----------------------------------------------------------------------------


@dataclass(frozen=True)
class LogTable:
    """A log's header, comment lines and parsed columns, with data-row line numbers."""

    path: Path
    header: tuple[str, ...]
    raw: dict  # column name -> numpy array (float, or object/str for text)
    n_rows: int
    first_line: int | None  # file line of data row 0 when rows are consecutive lines
    lines: tuple[int, ...] | None = None  # else: the file line of every data row
    comments: tuple[str, ...] = ()
    maps: tuple[ColumnMap, ...] = field(default=())
    decimal_comma: bool = False
    empty: dict = field(default_factory=dict)  # column -> mask of empty cells (numeric cols)

    def where(self, row: int) -> str:
        """Human description of data row ``row`` (0-based): 'row 3 (line 7 of log.csv)'."""
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

    def missing(self, name: str, advice: str) -> GyroidInputError:
        source, mapped = self._source(name)
        what = f"column {source!r} (mapped to {name})" if mapped else f"column {name!r}"
        return GyroidInputError(f"{self.path.name}: {what} is missing (the header has "
                                f"{', '.join(self.header)}); {advice}")

    def number_column(self, name: str, advice: str | None = None) -> np.ndarray:
        """One column as finite floats in the contract's unit, refusing the first bad cell."""
        source, mapped = self._source(name)
        if source not in self.header:
            raise self.missing(name, advice or (
                f"add it, map a column of yours onto it with --map {name}=COLUMN[:UNIT], or "
                "choose terms that do not need it"))
        values = self._floats(source)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            i = int(bad[0])
            cell = self.raw[source][i]
            empty = source in self.empty and bool(self.empty[source][i])
            text = "" if cell is None or empty else str(cell).strip()
            what = "is empty" if not text or text.lower() in ("none", "null") else (
                f"is {text!r}, not a number" if not _is_float(text) else f"is {text}")
            advice_row = ("fix or remove the row" if "not a number" in what or "empty" in what
                          else "remove the row or fill in a measured value")
            raise GyroidInputError(f"{self.path.name}: {self.where(i)}, column {source}: the "
                                   f"value {what}; {advice_row}")
        return mapped.convert(values) if mapped is not None else values

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

    def numeric_columns(self) -> list[str]:
        """Columns whose every cell is a finite number."""
        out = []
        for name in self.header:
            try:
                if np.all(np.isfinite(self._floats(name))):
                    out.append(name)
            except (TypeError, ValueError):
                continue
        return out


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _read_bytes(path: Path) -> bytes:
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise GyroidInputError(f"{path}: no such file; check the path") from None
    except IsADirectoryError:
        raise GyroidInputError(f"{path} is a folder; give the log file") from None
    except PermissionError:
        raise GyroidInputError(f"{path}: not readable (permission denied)") from None
    if data[:2] == b"\x1f\x8b":
        try:
            data = gzip.decompress(data)
        except (OSError, EOFError):
            raise GyroidInputError(f"{path}: a damaged gzip file; compress it again") from None
    return data


_DELIMITERS = (",", ";", "\t")


def _split_head(text_head: str) -> tuple[list[str], int, str | None]:
    """Leading comment lines, the header's 1-based line number, and the header line."""
    comments, line_no = [], 0
    for line in text_head.splitlines():
        line_no += 1
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            comments.append(stripped[1:].strip())
            continue
        return comments, line_no, line
    return comments, line_no, None


def read_log_table(path: str | Path, maps: tuple[ColumnMap, ...] = ()) -> LogTable:
    """Read a log (.csv, .csv.gz, .parquet) with ``#`` comment lines and a header row."""
    path = Path(path)
    if path.suffix.lower() in (".parquet", ".pq"):
        return _read_parquet(path, maps)
    data = _read_bytes(path)
    if b"\x00" in data[:4096]:
        raise GyroidInputError(f"{path.name}: not a text file; give a CSV, .csv.gz or .parquet "
                               "log")
    head = data[: 1 << 16].decode("utf-8-sig", errors="replace")
    comments, header_line, header = _split_head(head)
    if header is None:
        raise GyroidInputError(f"{path.name}: no header row found; the file is empty")
    delimiter = max(_DELIMITERS, key=header.count)
    if header.count(delimiter) == 0:
        delimiter = ","
    names = [c.strip() for c in header.split(delimiter)]
    duplicates = sorted({c for c in names if names.count(c) > 1})
    if duplicates:
        raise GyroidInputError(f"{path.name}: the header names column {duplicates[0]!r} twice "
                               f"(line {header_line}); rename one of them")
    decimal_comma = delimiter == ";" and bool(re.search(r"\d,\d", head.split("\n", header_line)
                                                          [-1][:4000]))
    try:
        data.decode("utf-8")
    except UnicodeDecodeError:
        raise GyroidInputError(f"{path.name}: not a UTF-8 text file; give a CSV log") from None
    body = data.split(b"\n", header_line - 1)[-1] if header_line > 1 else data
    consecutive = re.search(rb"\n[ \t\r]*\n|\n[ \t]*#", body.split(b"\n", 1)[-1]) is None
    table = None
    if consecutive:
        table = _read_arrow_csv(path, body, delimiter, names, decimal_comma)
    if table is None:
        return _read_python_csv(path, data, delimiter, comments, maps, decimal_comma)
    raw, empty, n_rows = table
    if n_rows == 0:
        raise GyroidInputError(f"{path.name}: the header is there but there are no data rows")
    return LogTable(path, tuple(names), raw, n_rows, header_line + 1, None, tuple(comments),
                    maps, decimal_comma, empty)


def _read_arrow_csv(path, body: bytes, delimiter: str, names, decimal_comma: bool):
    """pyarrow's parse of the header and data rows, or None when it cannot split them."""
    import pyarrow as pa
    from pyarrow import csv as pacsv

    def read(types):
        return pacsv.read_csv(
            io.BytesIO(body),
            read_options=pacsv.ReadOptions(column_names=None, use_threads=True,
                                           encoding="utf8"),
            parse_options=pacsv.ParseOptions(delimiter=delimiter),
            convert_options=pacsv.ConvertOptions(column_types=types, strings_can_be_null=True,
                                                  null_values=[""]),
        )

    try:
        table = read(None if not decimal_comma else {n: pa.string() for n in names})
    except pa.ArrowInvalid as error:
        if "conversion error" not in str(error).lower():
            return None
        try:  # a bad cell deep in a numeric column: read as text, name it below
            table = read({n: pa.string() for n in names})
        except pa.ArrowInvalid:
            return None
    if [c.strip() for c in table.column_names] != list(names):
        return None
    raw, empty = _columns(names, table.columns)
    return raw, empty, table.num_rows


def _columns(names, columns) -> tuple[dict, dict]:
    """pyarrow columns to numpy: numbers as floats (empty cells NaN, remembered), text as
    objects."""
    import pyarrow as pa

    raw, empty = {}, {}
    for name, column in zip(names, columns, strict=True):
        if pa.types.is_integer(column.type) or pa.types.is_floating(column.type):
            raw[name] = column.to_numpy(zero_copy_only=False).astype(float)
            if column.null_count:
                empty[name] = np.asarray(column.is_null())
                raw[name][empty[name]] = np.nan
        elif pa.types.is_null(column.type):
            raw[name] = np.full(len(column), np.nan)
            empty[name] = np.ones(len(column), dtype=bool)
        else:
            raw[name] = np.asarray(column.to_pylist(), dtype=object)
    return raw, empty


def _read_python_csv(path: Path, data: bytes, delimiter: str, comments_head, maps,
                     decimal_comma: bool) -> LogTable:
    text = data.decode("utf-8-sig")
    comments: list[str] = []
    header: tuple[str, ...] | None = None
    rows: list[list[str]] = []
    lines: list[int] = []
    reader = csv.reader(io.StringIO(text), delimiter=delimiter)
    for cells in reader:
        line = reader.line_num
        if not cells or all(not c.strip() for c in cells):
            continue
        if cells[0].lstrip().startswith("#"):
            comments.append(delimiter.join(cells).lstrip()[1:].strip())
            continue
        if header is None:
            header = tuple(c.strip() for c in cells)
            continue
        if len(cells) != len(header):
            raise GyroidInputError(
                f"{path.name}: row {len(rows) + 1} (line {line}) has {len(cells)} fields but "
                f"the header has {len(header)}; fix the row's separators")
        rows.append(cells)
        lines.append(line)
    if header is None:
        raise GyroidInputError(f"{path.name}: no header row found; the file is empty")
    if not rows:
        raise GyroidInputError(f"{path.name}: the header is there but there are no data rows")
    columns = list(zip(*rows, strict=True))
    raw = {name: np.asarray(col, dtype=object) for name, col in zip(header, columns,
                                                                     strict=True)}
    return LogTable(path, header, raw, len(rows), None, tuple(lines), tuple(comments), maps,
                    decimal_comma)


def _read_parquet(path: Path, maps) -> LogTable:
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        table = pq.read_table(path)
    except FileNotFoundError:
        raise GyroidInputError(f"{path}: no such file; check the path") from None
    except (pa.ArrowInvalid, OSError) as error:
        raise GyroidInputError(f"{path.name}: not a readable parquet file ({error})") from None
    raw, empty = _columns(table.column_names, table.columns)
    if table.num_rows == 0:
        raise GyroidInputError(f"{path.name}: the file has no data rows")
    metadata = table.schema.metadata or {}
    comments = tuple(v.decode(errors="replace") for k, v in metadata.items()
                     if k.startswith(b"comment"))
    return LogTable(path, tuple(table.column_names), raw, table.num_rows, None, None, comments,
                    maps, False, empty)


def read_header(path: str | Path) -> tuple[str, ...]:
    """A log's column names, reading no more than the header (a parquet file's schema, or
    the first 64 kB of a CSV, gzip or not); errors as :func:`read_log_table`'s."""
    path = Path(path)
    if path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        try:
            return tuple(pq.read_schema(path).names)
        except FileNotFoundError:
            raise GyroidInputError(f"{path}: no such file; check the path") from None
        except Exception:  # noqa: BLE001 - a damaged file: the full read names the problem
            return read_log_table(path).header
    try:
        with path.open("rb") as raw:
            start = raw.read(2)
            raw.seek(0)
            handle = gzip.open(raw) if start == b"\x1f\x8b" else raw
            head = handle.read(1 << 16)
    except (FileNotFoundError, IsADirectoryError, PermissionError, OSError, EOFError):
        return read_log_table(path).header  # the full read raises the right message
    _, _, header = _split_head(head.decode("utf-8-sig", errors="replace"))
    if header is None:
        return read_log_table(path).header
    delimiter = max(_DELIMITERS, key=header.count)
    return tuple(c.strip() for c in header.split(delimiter if header.count(delimiter) else ","))


def log_kind(path: str | Path, maps: tuple[ColumnMap, ...] = ()) -> str:
    """``"roll"`` for a roll log (contract section 4: roll_rate_deg_s and no drift_deg_h,
    after the column maps), else ``"bench"``; reads the header only."""
    names = {*read_header(path), *(m.target for m in maps)}
    return "roll" if "roll_rate_deg_s" in names and "drift_deg_h" not in names else "bench"


def check_time_increasing(table: LogTable, time_s: np.ndarray) -> None:
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


#: Values beyond these magnitudes are refused as implausible (a unit or parse mistake).
PLAUSIBLE = {
    "time_s": 1e12, "drift_deg_h": 1e9, "sigma_deg_h": 1e9, "Hx_uT": 1e8, "Hy_uT": 1e8,
    "Hz_uT": 1e8, "roll_rate_deg_s": 1e7, "gs_rate_deg_s": 1e7, "gs_angle_deg": 1e12,
}


def check_plausible(table: LogTable, name: str, values: np.ndarray) -> None:
    """Refuse a value no gyro log holds (e.g. 1e300), naming its row."""
    if name == "temperature_C":
        bad = np.flatnonzero((values < -273.15) | (values > 1000.0))
        limit = "between -273.15 and 1000 degC"
    else:
        bound = PLAUSIBLE.get(name)
        if bound is None:
            return
        bad = np.flatnonzero(np.abs(values) > bound)
        limit = f"within +/-{bound:g}"
    if bad.size:
        i = int(bad[0])
        source, column_map = table._source(name)
        column = name if column_map is None else f"{source} (read as {name})"
        many = f", nor are {bad.size - 1} more rows" if bad.size > 1 else ""
        advice = ("fix the row, or give the column's unit with --map" if bad.size <= 1 else
                  "if it holds raw sensor counts, convert them to physical units first, or "
                  "give the column's unit with --map")
        raise GyroidInputError(f"{table.path.name}: {table.where(i)}, column {column}: "
                               f"{values[i]:g} is not a plausible value (expected {limit})"
                               f"{many}; {advice}")
