"""A compilation-cache store that several processes may share: each entry is written to a
temporary file and renamed into place, so that no process reads another's half-written
program.

JAX's own file store (``jax._src.lru_cache.LRUCache``, JAX 0.10) writes entries in place
and, without a size limit, takes no lock: two processes compiling the same program write one
file at once, and a third may load the mixture, which aborts the interpreter in XLA's
deserialiser (seen as "Fatal Python error: Aborted" under pytest-xdist). Its size-limited
mode locks, but scans the whole folder on every write. Each entry here also carries a
CRC-32 of its program, checked on every read: an entry that fails it (damaged on disk, or
written by JAX's own store, which may have left such mixtures behind) is not loaded but
compiled again and replaced.
"""

from __future__ import annotations

import os
import pathlib
import tempfile
import zlib

_SUFFIX = "-cache"
#: An entry's first bytes: this mark, then the program's CRC-32 (4 bytes, little-endian).
_MARK = b"gyroid-jax-1\n"


def sealed(value: bytes) -> bytes:
    return _MARK + zlib.crc32(value).to_bytes(4, "little") + value


def opened(data: bytes) -> bytes | None:
    """The program of an entry, or None when it is not one of ours or fails its CRC."""
    head = len(_MARK) + 4
    if not data.startswith(_MARK) or len(data) < head:
        return None
    value = data[head:]
    return value if zlib.crc32(value).to_bytes(4, "little") == data[len(_MARK):head] else None


def write_sealed(target: pathlib.Path, value: bytes) -> None:
    """``value`` :func:`sealed` into ``target``: written to a temporary file beside it and
    renamed into place, so no reader sees it half-written."""
    target.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.",
                                         suffix=".part")
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(sealed(value))
        os.replace(temporary, target)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def install(folder: str) -> bool:
    """Make JAX's persistent compilation cache this process's :class:`AtomicFileStore` in
    ``folder``; False (JAX's own store stays) where this JAX has no such hook."""
    try:
        from jax._src import compilation_cache
        from jax._src.compilation_cache_interface import CacheInterface
    except ImportError:
        return False
    if not hasattr(compilation_cache, "_cache_initialized_mutex"):
        return False
    with compilation_cache._cache_initialized_mutex:
        compilation_cache._cache = _store_class(CacheInterface)(folder)
        compilation_cache._cache_initialized = True
    return True


def _store_class(base: type) -> type:
    class AtomicFileStore(base):
        """Entries as ``KEY-cache`` files in one folder, each written by rename."""

        def __init__(self, folder: str):
            self._path = pathlib.Path(folder)
            self._path.mkdir(parents=True, exist_ok=True)

        def get(self, key: str) -> bytes | None:
            try:
                return opened((self._path / f"{key}{_SUFFIX}").read_bytes())
            except FileNotFoundError:
                return None

        def put(self, key: str, value: bytes) -> None:
            target = self._path / f"{key}{_SUFFIX}"
            if self.get(key) is not None:
                return  # a sound entry is kept (JAX's rule); a damaged one is replaced
            write_sealed(target, value)

    return AtomicFileStore
