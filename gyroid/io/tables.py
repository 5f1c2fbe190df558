"""Reading logs: CSV (comma, semicolon or tab), .csv.gz and .parquet, with every bad cell
named by row, line and column, and vendors' columns and units mapped onto the contract's.

CSV files are parsed by pyarrow (vectorised, from the file's bytes without copying them);
blank and comment lines among the data rows are taken out first, their line numbers kept
for the messages. The strict checks run on the parsed columns and name the first bad row.
A row with the wrong number of fields is found by streaming the rows through Python's csv
module, which names its line.
"""

from __future__ import annotations

import codecs
import csv
import gzip
import io
import math
import re
import zlib
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
    lines: np.ndarray | None = None  # else: the file line of every data row
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


def _open_failure(path: Path, error: OSError) -> GyroidInputError:
    if isinstance(error, FileNotFoundError):
        return GyroidInputError(f"{path}: no such file; check the path")
    if isinstance(error, IsADirectoryError):
        return GyroidInputError(f"{path} is a folder; give the log file")
    if isinstance(error, PermissionError):
        return GyroidInputError(f"{path}: not readable (permission denied)")
    return GyroidInputError(f"{path}: cannot be read ({error})")


def _is_gzip(path: Path) -> bool:
    try:
        with path.open("rb") as handle:
            return handle.read(2) == b"\x1f\x8b"
    except OSError as error:
        raise _open_failure(path, error) from None


def _read_bytes(path: Path, limit: int = -1) -> bytes:
    """The file's bytes (the first ``limit`` only, if given), gzip decompressed."""
    try:
        with (gzip.open(path) if _is_gzip(path) else path.open("rb")) as handle:
            return handle.read(limit)
    except (EOFError, gzip.BadGzipFile, zlib.error):
        raise GyroidInputError(f"{path}: a damaged gzip file; compress it again") from None
    except OSError as error:
        raise _open_failure(path, error) from None


#: Bytes read at a time when a log is scanned.
SCAN_CHUNK = 1 << 24
#: A blank or comment line, with the newline before it and the one that ends it.
_INNER_LINE_ENDED = re.compile(rb"\n[ \t\r]*(?:#[^\n]*)?\n")


def _scan_body(path: Path, offset: int) -> bool:
    """Whether blank or comment lines sit among the rows after the header (which starts at
    byte ``offset``), reading the file in chunks (a 10^7-row log is never held whole); a file
    that is not UTF-8 is refused."""
    decoder = codecs.getincrementaldecoder("utf-8")()
    tail, inner = b"", False
    try:
        with (gzip.open(path) if _is_gzip(path) else path.open("rb")) as handle:
            decoder.decode(handle.read(offset))
            while chunk := handle.read(SCAN_CHUNK):
                if not chunk.isascii() or decoder.getstate()[0]:
                    decoder.decode(chunk)
                block = tail + chunk
                inner = inner or _INNER_LINE_ENDED.search(block) is not None
                cut = block.rfind(b"\n")
                tail = block[cut:] if cut >= 0 else block
            decoder.decode(b"", final=True)
    except UnicodeDecodeError:
        raise GyroidInputError(f"{path.name}: not a UTF-8 text file; give a CSV log") from None
    except (EOFError, gzip.BadGzipFile, zlib.error):
        raise GyroidInputError(f"{path}: a damaged gzip file; compress it again") from None
    # the last line, when the file does not end with a newline
    return inner or re.fullmatch(rb"\n[ \t\r]*(?:#.*)?", tail, re.S) is not None and tail != b"\n"


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


def _delimiter(header: str) -> str:
    """The most frequent of comma, semicolon and tab in the header line (comma if none)."""
    delimiter = max(_DELIMITERS, key=header.count)
    return delimiter if header.count(delimiter) else ","


def _header_names(header: str) -> tuple[str, ...]:
    """Column names of a header line, quotes removed (R's and pyarrow's writers quote)."""
    return tuple(c.strip() for c in next(csv.reader([header], delimiter=_delimiter(header))))


def read_log_table(path: str | Path, maps: tuple[ColumnMap, ...] = ()) -> LogTable:
    """Read a log (.csv, .csv.gz, .parquet) with ``#`` comment lines and a header row."""
    path = Path(path)
    if path.suffix.lower() in (".parquet", ".pq"):
        return _read_parquet(path, maps)
    head_bytes = _read_bytes(path, 1 << 16)
    if b"\x00" in head_bytes[:4096]:
        raise GyroidInputError(f"{path.name}: not a text file; give a CSV, .csv.gz or .parquet "
                               "log")
    head = head_bytes.decode("utf-8-sig", errors="replace")
    comments, header_line, header = _split_head(head)
    if header is None:
        raise GyroidInputError(f"{path.name}: no header row found; the file is empty")
    delimiter = _delimiter(header)
    names = list(_header_names(header))
    duplicates = sorted({c for c in names if names.count(c) > 1})
    if duplicates:
        raise GyroidInputError(f"{path.name}: the header names column {duplicates[0]!r} twice "
                               f"(line {header_line}); rename one of them")
    decimal_comma = delimiter == ";" and bool(re.search(r"\d,\d", head.split("\n", header_line)
                                                          [-1][:4000]))
    offset = 0
    for _ in range(header_line - 1):
        offset = head_bytes.index(b"\n", offset) + 1
    import pyarrow as pa

    lines, inner = None, []
    if _scan_body(path, offset):  # rare: take the lines out in memory, keep line numbers
        body, lines, inner = _without_inner_lines(_read_bytes(path), offset, header_line)
        source = lambda: pa.BufferReader(pa.py_buffer(body))  # noqa: E731
    else:  # usual: pyarrow reads the file in blocks
        source = lambda: _arrow_stream(path, offset)  # noqa: E731
    table = _read_arrow_csv(source, delimiter, names, decimal_comma)
    if table is None:
        if lines is None:
            with (gzip.open(path) if _is_gzip(path) else path.open("rb")) as handle:
                handle.read(offset)
                _raise_bad_row(path, handle, delimiter, len(names), header_line, None)
        else:
            _raise_bad_row(path, io.BytesIO(body), delimiter, len(names), header_line, lines)
        return _read_python_csv(path, _read_bytes(path), delimiter, maps, decimal_comma)
    raw, empty, n_rows = table
    if n_rows == 0:
        raise GyroidInputError(f"{path.name}: the header is there but there are no data rows")
    first_line = header_line + 1 if lines is None else None
    if lines is not None and lines.size != n_rows:
        lines = None  # a quoted field spans lines: rows are named by their number only
    return LogTable(path, tuple(names), raw, n_rows, first_line, lines,
                    tuple(comments + inner), maps, decimal_comma, empty)


def _arrow_stream(path: Path, offset: int):
    """The file from byte ``offset`` (the header line) as a pyarrow stream, decompressed."""
    import pyarrow as pa

    stream = pa.OSFile(str(path))
    if _is_gzip(path):
        stream = pa.CompressedInputStream(stream, "gzip")
        stream.read(offset)
    else:
        stream.seek(offset)
    return stream


#: A blank or comment line after the header, with the newline that ends the line before it.
_INNER_LINE = re.compile(rb"\n[ \t\r]*(?:#[^\n]*)?(?=\n|\Z)")


def _without_inner_lines(data: bytes, offset: int, header_line: int
                         ) -> tuple[bytes, np.ndarray | None, list[str]]:
    """The header and data rows (``data`` from ``offset``, the header's start) with blank and
    comment lines among the rows taken out; the file line of every data row (None when none
    was taken out: row k is line ``header_line + 1 + k``); the comments."""
    spans = [m.span() for m in _INNER_LINE.finditer(data, offset)]
    if not spans or (len(spans) == 1 and spans[0][1] == len(data)
                     and not data[spans[0][0]:].strip()):
        return data[offset:], None, []
    removed, comments, pieces = [], [], []
    count, previous, kept_from = 0, offset, offset
    for start, end in spans:
        count += data.count(b"\n", previous, start)
        previous = start
        removed.append(count + 1)  # the line's index after the header (header: 0)
        text = data[start:end].strip()
        if text.startswith(b"#"):
            comments.append(text[1:].decode("utf-8", errors="replace").strip())
        pieces.append(data[kept_from:start])
        kept_from = end
    pieces.append(data[kept_from:])
    total = count + data.count(b"\n", previous) + (0 if data.endswith(b"\n") else 1)
    index = np.setdiff1d(np.arange(1, total), np.asarray(removed))
    return b"".join(pieces), header_line + index, comments


def _raise_bad_row(path: Path, handle, delimiter: str, width: int, header_line: int,
                   lines: np.ndarray | None) -> None:
    """Name the first data row whose number of fields is not the header's, reading the
    binary stream ``handle`` from the header on (no row is kept); return when every row has
    the header's width."""
    text = io.TextIOWrapper(handle, encoding="utf-8-sig", newline="")
    reader = csv.reader(text, delimiter=delimiter)
    next(reader, None)  # the header
    for row, cells in enumerate(reader):
        if len(cells) != width:
            if lines is None:  # the reader counts lines from the header's
                where = f"row {row + 1} (line {header_line + reader.line_num - 1})"
            elif row < lines.size:
                where = f"row {row + 1} (line {lines[row]})"
            else:
                where = f"row {row + 1}"
            raise GyroidInputError(
                f"{path.name}: {where} has {len(cells)} fields but the header has {width}; "
                "fix the row's separators")


def _read_arrow_csv(source, delimiter: str, names, decimal_comma: bool):
    """pyarrow's parse of the header and data rows (``source()`` gives them as a stream),
    or None when it cannot split them."""
    import pyarrow as pa
    from pyarrow import csv as pacsv

    def read(types):
        return pacsv.read_csv(
            source(),
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
    n_rows, holder = table.num_rows, [table.rename_columns(list(names))]
    del table
    raw, empty = _columns(holder)
    return raw, empty, n_rows


def _columns(holder: list) -> tuple[dict, dict]:
    """pyarrow columns to numpy: numbers as floats (empty cells NaN, remembered), text as
    objects. The table is taken out of ``holder`` (so that the caller keeps no reference)
    and its columns are converted one at a time and dropped, so that a long log is never
    held twice; arrow's unused memory is returned to the system after."""
    import pyarrow as pa

    table = holder.pop()
    raw, empty = {}, {}
    for name in list(table.column_names):
        column = table.column(name)
        if pa.types.is_integer(column.type) or pa.types.is_floating(column.type):
            # one float64 chunk is viewed, not copied; several are joined once
            raw[name] = np.asarray(column.to_numpy(), dtype=float)
            if column.null_count:
                empty[name] = np.asarray(column.is_null())
                raw[name] = raw[name].copy() if not raw[name].flags.writeable else raw[name]
                raw[name][empty[name]] = np.nan
        elif pa.types.is_null(column.type):
            raw[name] = np.full(len(column), np.nan)
            empty[name] = np.ones(len(column), dtype=bool)
        else:
            raw[name] = np.asarray(column.to_pylist(), dtype=object)
        del column
        table = table.drop_columns([name])
    pa.default_memory_pool().release_unused()
    return raw, empty


def _read_python_csv(path: Path, data: bytes, delimiter: str, maps, decimal_comma: bool
                     ) -> LogTable:
    """Every cell as text by Python's csv module: the last resort for what pyarrow cannot
    split although every row has the header's number of fields (slow, and memory of about
    60 bytes per cell)."""
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
    return LogTable(path, header, raw, len(rows), None, np.asarray(lines), tuple(comments), maps,
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
    names, n_rows = tuple(table.column_names), table.num_rows
    metadata, holder = table.schema.metadata or {}, [table]
    del table
    raw, empty = _columns(holder)
    if n_rows == 0:
        raise GyroidInputError(f"{path.name}: the file has no data rows")
    comments = tuple(v.decode(errors="replace") for k, v in metadata.items()
                     if k.startswith(b"comment"))
    return LogTable(path, names, raw, n_rows, None, None, comments,
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
    return _header_names(header)


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
