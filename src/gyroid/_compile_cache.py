"""A compilation-cache store that several processes may share: each entry is written to a
temporary file and renamed into place, so that no process reads another's half-written
program.

JAX's own file store (``jax._src.lru_cache.LRUCache``, JAX 0.10) writes entries in place
and, without a size limit, takes no lock: two processes compiling the same program write one
file at once, and a third may load the mixture, which aborts the interpreter in XLA's
deserialiser (seen as "Fatal Python error: Aborted" under pytest-xdist). Its size-limited
mode locks, but scans the whole folder on every write. Entries keep JAX's file names, so a
folder filled by either store serves the other.
"""

from __future__ import annotations

import os
import pathlib
import tempfile

_SUFFIX = "-cache"


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
                return (self._path / f"{key}{_SUFFIX}").read_bytes()
            except FileNotFoundError:
                return None

        def put(self, key: str, value: bytes) -> None:
            target = self._path / f"{key}{_SUFFIX}"
            if target.exists():
                return
            handle, temporary = tempfile.mkstemp(dir=self._path, prefix=f".{key}.",
                                                 suffix=".part")
            try:
                with os.fdopen(handle, "wb") as stream:
                    stream.write(value)
                os.replace(temporary, target)
            except BaseException:
                if os.path.exists(temporary):
                    os.unlink(temporary)
                raise

    return AtomicFileStore
