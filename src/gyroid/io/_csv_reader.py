"""CSV logs (comma, semicolon or tab; plain or gzip) parsed into columns, every row named by
its line in the file.

pyarrow parses the file (vectorised, reading it in blocks from disk). Blank and comment
lines among the data rows are looked for first by scanning the file in 16 MB chunks; where
there are some (rare) they are taken out in memory and the file line of every data row is
kept for the messages. A row with the wrong number of fields is found by streaming the rows
through Python's csv module, which names its line (no row is kept). Only a file pyarrow
cannot split although every row has the header's width is read whole by Python's csv
module (slow: about 60 bytes of memory per cell).
"""

from __future__ import annotations

import csv
import gzip
import io
import re
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._file_bytes import has_inner_lines, is_gzip, read_bytes


@dataclass(frozen=True)
class ParsedCsv:
    """A CSV log's columns (numbers as floats, text as objects) and where its rows are."""

    header: tuple[str, ...]
    raw: dict
    empty: dict  # column -> mask of empty cells (numeric columns)
    n_rows: int
    first_line: int | None  # file line of data row 0 when rows are consecutive lines
    lines: np.ndarray | None  # else: the file line of every data row (None: unknown)
    comments: tuple[str, ...]
    decimal_comma: bool


@dataclass(frozen=True)
class CsvLayout:
    """How a CSV log's text is laid out, read from its first 64 kB: its comment lines, its
    header (1-based line, byte offset), delimiter and decimal mark."""

    header: tuple[str, ...]
    header_line: int
    offset: int  # byte of the header line (in the decompressed text)
    delimiter: str
    decimal_comma: bool
    comments: tuple[str, ...]
    head: bytes  # the first 64 kB (decompressed)

    @property
    def data_lines(self) -> list[bytes]:
        """The whole data lines within :attr:`head` (after the header, before a cut line)."""
        return self.head[self.offset:].split(b"\n")[1:-1]


def csv_layout(path: Path) -> CsvLayout:
    """A CSV log's layout (:class:`CsvLayout`); a file that is not UTF-8 text with a header
    row with distinct names is refused."""
    head_bytes = read_bytes(path, 1 << 16)
    if head_bytes[:2] in (b"\xff\xfe", b"\xfe\xff") or (
            b"\x00" in head_bytes[:4096] and head_bytes[1:2] == b"\x00"):
        raise GyroidInputError(f"{path.name} is UTF-16 text: save it as UTF-8 (in Excel: "
                               "'CSV UTF-8'), then read it again")
    if b"\x00" in head_bytes[:4096]:
        raise GyroidInputError(
            f"{path.name}: not a text file; give a CSV, .csv.gz, .parquet or netCDF (.nc) log, "
            "or a .ulg, .bin, .bag, .mcap, .db3 or .mat log (a binary file is read by its "
            "suffix)")
    head = head_bytes.decode("utf-8-sig", errors="replace")
    comments, header_line, header = split_head(head)
    if header is None:
        raise GyroidInputError(f"{path.name}: no header row found; the file is empty")
    delimiter = _delimiter(header)
    names = list(header_names(header))
    duplicates = sorted({c for c in names if names.count(c) > 1})
    if duplicates:
        raise GyroidInputError(f"{path.name}: the header names column {duplicates[0]!r} twice "
                               f"(line {header_line}); rename one of them")
    decimal_comma = delimiter == ";" and bool(re.search(r"\d,\d", head.split("\n", header_line)
                                                          [-1][:4000]))
    offset = 0
    for _ in range(header_line - 1):
        offset = head_bytes.index(b"\n", offset) + 1
    return CsvLayout(tuple(names), header_line, offset, delimiter, decimal_comma,
                     tuple(comments), head_bytes)


def read_csv(path: Path) -> ParsedCsv:
    """Parse a CSV log (.csv or .csv.gz; see the module docstring)."""
    layout = csv_layout(path)
    names, offset, header_line = list(layout.header), layout.offset, layout.header_line
    delimiter, decimal_comma, comments = layout.delimiter, layout.decimal_comma, \
        list(layout.comments)
    lines, inner, body = None, [], None
    if has_inner_lines(path, offset):  # rare: take the lines out in memory, keep line numbers
        body, lines, inner = _without_inner_lines(read_bytes(path), offset, header_line)
    # usual (body None): pyarrow reads the file in blocks from disk
    table = _read_arrow_csv(path, offset, body, delimiter, names, decimal_comma)
    if table is None:
        if body is None or lines is None:
            with (gzip.open(path) if is_gzip(path) else path.open("rb")) as handle:
                handle.read(offset)
                _raise_bad_row(path, handle, delimiter, len(names), header_line, None)
        else:
            _raise_bad_row(path, io.BytesIO(body), delimiter, len(names), header_line, lines)
        return _read_python_csv(path, read_bytes(path), delimiter, decimal_comma)
    raw, empty, n_rows = table
    if n_rows == 0:
        raise GyroidInputError(f"{path.name}: the header is there but there are no data rows")
    first_line = header_line + 1 if lines is None else None
    if lines is not None and lines.size != n_rows:
        lines = None  # a quoted field spans lines: rows are named by their number only
    return ParsedCsv(tuple(names), raw, empty, n_rows, first_line, lines,
                     tuple(comments + inner), decimal_comma)


def csv_rows_bound(path: Path, layout: CsvLayout) -> int:
    """An upper estimate of a CSV log's data rows, from its size and its shortest data line
    among the first 64 kB (a gzip file's size scaled by the compression of its first MB):
    what decides whether it is read as a stream, without reading it."""
    shortest = max(1, min((len(line) + 1 for line in layout.data_lines if line.strip()),
                          default=1))
    size = path.stat().st_size
    if is_gzip(path):
        with path.open("rb") as handle:
            compressed = handle.read(1 << 20)
        inflate = zlib.decompressobj(wbits=31)
        text = inflate.decompress(compressed, 1 << 26)
        used = len(compressed) - len(inflate.unconsumed_tail) - len(inflate.unused_data)
        size = int(size * len(text) / max(used, 1))
    return max(0, size - layout.offset) // shortest


def csv_batches(path: Path, layout: CsvLayout, batch_bytes: int):
    """A CSV log's data rows as pyarrow record batches of about ``batch_bytes`` of text,
    read from disk as they are used (the column types are those of the first batch). A log
    with blank or comment lines among its rows is refused: its rows are not its lines."""
    import pyarrow as pa
    from pyarrow import csv as pacsv

    if has_inner_lines(path, layout.offset):
        raise GyroidInputError(
            f"{path.name}: blank or comment lines sit among its rows; a log this long is read "
            "as a stream of lines, one row each: take them out (e.g. grep -v '^#'), or "
            "write the log as Parquet")
    def open_reader(types):
        return pacsv.open_csv(
            _arrow_stream(path, layout.offset),
            read_options=pacsv.ReadOptions(block_size=batch_bytes, encoding="utf8"),
            parse_options=pacsv.ParseOptions(delimiter=layout.delimiter),
            convert_options=pacsv.ConvertOptions(column_types=types, strings_can_be_null=True,
                                                  null_values=[""]))

    if layout.decimal_comma:
        reader = open_reader({n: pa.string() for n in layout.header})
    else:
        # The first block's types, widened: a column of whole numbers or of empty cells
        # there may hold decimals later (21 degC, then 21.5).
        first = open_reader(None).schema
        reader = open_reader({f.name: pa.float64() if pa.types.is_integer(f.type)
                              or pa.types.is_null(f.type) else f.type for f in first})
    if [c.strip() for c in reader.schema.names] != list(layout.header):
        raise GyroidInputError(f"{path.name}: its header cannot be split by "
                               f"{layout.delimiter!r}; fix the header line")
    rows = 0
    while True:
        try:
            batch = reader.read_next_batch()
        except StopIteration:
            return
        except pa.ArrowInvalid as error:
            raise GyroidInputError(
                f"{path.name}: after row {rows} (line {layout.header_line + rows}) a row "
                f"cannot be read ({str(error).splitlines()[0]}); fix it, or write the log "
                "as Parquet") from None
        rows += batch.num_rows
        yield batch.rename_columns(list(layout.header))


_DELIMITERS = (",", ";", "\t")
#: What starts a comment line: ``#``, or MATLAB's ``%``.
COMMENT_MARKS = ("#", "%")


def split_head(text_head: str) -> tuple[list[str], int, str | None]:
    """Leading comment lines, the header's 1-based line number, and the header line."""
    comments, line_no = [], 0
    for line in text_head.splitlines():
        line_no += 1
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith(COMMENT_MARKS):
            comments.append(stripped[1:].strip())
            continue
        return comments, line_no, line
    return comments, line_no, None


def _delimiter(header: str) -> str:
    """The most frequent of comma, semicolon and tab in the header line (comma if none)."""
    delimiter = max(_DELIMITERS, key=header.count)
    return delimiter if header.count(delimiter) else ","


def header_names(header: str) -> tuple[str, ...]:
    """Column names of a header line, quotes removed (R's and pyarrow's writers quote)."""
    return tuple(c.strip() for c in next(csv.reader([header], delimiter=_delimiter(header))))


def _arrow_stream(path: Path, offset: int):
    """The file from byte ``offset`` (the header line) as a pyarrow stream, decompressed."""
    import pyarrow as pa

    stream = pa.OSFile(str(path))
    if is_gzip(path):
        stream = pa.CompressedInputStream(stream, "gzip")
        stream.read(offset)
    else:
        stream.seek(offset)
    return stream


#: A blank or comment line after the header, with the newline that ends the line before it.
_INNER_LINE = re.compile(rb"\n[ \t\r]*(?:[#%][^\n]*)?(?=\n|\Z)")


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
        if text.startswith((b"#", b"%")):
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


def _read_arrow_csv(path: Path, offset: int, body: bytes | None, delimiter: str, names,
                    decimal_comma: bool):
    """pyarrow's parse of the header and data rows (the file from byte ``offset``, or
    ``body`` when given), or None when it cannot split them."""
    import pyarrow as pa
    from pyarrow import csv as pacsv

    def read(types):
        with (_arrow_stream(path, offset) if body is None
              else pa.BufferReader(pa.py_buffer(body))) as source:
            return pacsv.read_csv(
                source,
                read_options=pacsv.ReadOptions(column_names=None, use_threads=True,
                                               encoding="utf8"),
                parse_options=pacsv.ParseOptions(delimiter=delimiter),
                convert_options=pacsv.ConvertOptions(column_types=types,
                                                      strings_can_be_null=True,
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
    raw, empty = arrow_columns(holder)
    return raw, empty, n_rows


def arrow_columns(holder: list) -> tuple[dict, dict]:
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
        elif pa.types.is_timestamp(column.type):  # a date-time clock (UTC if it has a zone)
            raw[name] = np.asarray(column.cast(pa.timestamp("ns")).to_numpy(
                zero_copy_only=False), dtype="datetime64[ns]")
        else:
            raw[name] = np.asarray(column.to_pylist(), dtype=object)
        del column
        table = table.drop_columns([name])
    pa.default_memory_pool().release_unused()
    return raw, empty


def _read_python_csv(path: Path, data: bytes, delimiter: str, decimal_comma: bool
                     ) -> ParsedCsv:
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
        if cells[0].lstrip().startswith(COMMENT_MARKS):
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
    return ParsedCsv(header, raw, {}, len(rows), None, np.asarray(lines), tuple(comments),
                     decimal_comma)
