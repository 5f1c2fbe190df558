"""A log file's bytes, plain or gzip: read whole or in part, scanned in chunks for blank and
comment lines among its rows, each failure to open or decode one message naming the file."""

from __future__ import annotations

import codecs
import gzip
import re
import zlib
from pathlib import Path

from gyroid.errors import GyroidInputError


def _open_failure(path: Path, error: OSError) -> GyroidInputError:
    if isinstance(error, FileNotFoundError):
        return GyroidInputError(f"{path}: no such file; check the path")
    if isinstance(error, IsADirectoryError):
        return GyroidInputError(f"{path} is a folder; give the log file")
    if isinstance(error, PermissionError):
        return GyroidInputError(f"{path}: not readable (permission denied)")
    return GyroidInputError(f"{path}: cannot be read ({error})")


def is_gzip(path: Path) -> bool:
    try:
        with path.open("rb") as handle:
            return handle.read(2) == b"\x1f\x8b"
    except OSError as error:
        raise _open_failure(path, error) from None


def read_bytes(path: Path, limit: int = -1) -> bytes:
    """The file's bytes (the first ``limit`` only, if given), gzip decompressed."""
    try:
        with (gzip.open(path) if is_gzip(path) else path.open("rb")) as handle:
            return handle.read(limit)
    except (EOFError, gzip.BadGzipFile, zlib.error):
        raise GyroidInputError(f"{path}: a damaged gzip file; compress it again") from None
    except OSError as error:
        raise _open_failure(path, error) from None


#: Bytes read at a time when a log is scanned.
SCAN_CHUNK = 1 << 24
#: A blank or comment line, with the newline before it and the one that ends it.
_INNER_LINE_ENDED = re.compile(rb"\n[ \t\r]*(?:[#%][^\n]*)?\n")


def has_inner_lines(path: Path, offset: int) -> bool:
    """Whether blank or comment lines sit among the rows after the header (which starts at
    byte ``offset``), reading the file in chunks (a 10^7-row log is never held whole); a file
    that is not UTF-8 is refused."""
    decoder = codecs.getincrementaldecoder("utf-8")()
    tail, inner = b"", False
    try:
        with (gzip.open(path) if is_gzip(path) else path.open("rb")) as handle:
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
    return inner or re.fullmatch(rb"\n[ \t\r]*(?:[#%].*)?", tail, re.S) is not None and (
        tail != b"\n")
