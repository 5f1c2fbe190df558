"""The compilation cache's store: entries appear whole or not at all (several processes share
the folder: pytest-xdist's workers, ``gyroid batch``'s, the demo's second process)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from gyroid import _compile_cache


def _store(folder):
    from jax._src.compilation_cache_interface import CacheInterface

    return _compile_cache._store_class(CacheInterface)(str(folder))


def test_store_round_trip_and_first_writer_kept(tmp_path):
    store = _store(tmp_path)
    assert store.get("k") is None
    store.put("k", b"first")
    store.put("k", b"second")  # JAX's rule: an existing entry is kept
    assert store.get("k") == b"first"
    assert sorted(os.listdir(tmp_path)) == ["k-cache"]


def test_a_damaged_or_foreign_entry_is_not_loaded_but_replaced(tmp_path):
    store = _store(tmp_path)
    store.put("k", b"program bytes")
    entry = tmp_path / "k-cache"
    data = bytearray(entry.read_bytes())
    data[-3] ^= 0xFF  # one flipped byte: the CRC fails
    entry.write_bytes(bytes(data))
    assert store.get("k") is None
    store.put("k", b"program bytes")
    assert store.get("k") == b"program bytes"
    (tmp_path / "j-cache").write_bytes(b"written by JAX's own store")
    assert store.get("j") is None


def test_failed_write_leaves_nothing(tmp_path, monkeypatch):
    store = _store(tmp_path)

    def broken_replace(source, target):
        raise OSError("disk full")

    monkeypatch.setattr(_compile_cache.os, "replace", broken_replace)
    with pytest.raises(OSError, match="disk full"):
        store.put("k", b"x" * 1000)
    assert os.listdir(tmp_path) == []
    assert store.get("k") is None


def test_configure_installs_the_store_and_a_second_process_reads_it(tmp_path):
    program = (
        "import gyroid, jax, jax.numpy as jnp\n"
        "gyroid.configure()\n"
        "from jax._src import compilation_cache as cc\n"
        "print(type(cc._cache).__name__)\n"
        "read = []\n"
        "get = cc._cache.get\n"
        "cc._cache.get = lambda key: read.append(get(key) is not None) or get(key)\n"
        "print(float(jax.jit(lambda x: jnp.cos(x) * 3.0)(jnp.float64(0.5))))\n"
        "print(any(read))\n")
    env = dict(os.environ, GYROID_JAX_CACHE=str(tmp_path / "jax"))
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    runs = [subprocess.run([sys.executable, "-c", program], env=env, capture_output=True,
                           text=True, check=True).stdout.split() for _ in range(2)]
    assert runs[0][0] == runs[1][0] == "AtomicFileStore"
    assert runs[0][1] == runs[1][1]
    assert runs[0][2] == "False" and runs[1][2] == "True"  # the second run reads the first's
    assert not [name for name in os.listdir(tmp_path / "jax") if name.endswith(".part")]
