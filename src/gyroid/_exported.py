"""Compiled programs loaded, not traced: the largest of a fit's programs kept as exported
StableHLO (``jax.export``) beside the persistent compilation cache, so that a new process
(every command, every batch worker) deserialises them instead of tracing and lowering them.

A fresh process's first fit of paper A's bench traced and lowered 74 programs, some 2.4 s
beside a 2.3 s fit; two of them (the vmapped BFGS on the noise levels' marginal and the
marginal's batched gradients) carried 1.7 s of it. An exported program deserialises in a few
milliseconds; its first call then costs only the load of its compiled form from the
persistent cache (``benchmarks/results_process_start.json``).

:func:`exported` wraps a function as :func:`equinox.filter_jit` does (arrays are arguments,
everything else static). Each program is stored under a key that names everything it was
built from: the function, the static part of its arguments (an equinox module's static
fields, Python numbers, functions by their qualified names), the arrays' shapes and dtypes,
the source of gyroid and the versions of JAX, jaxlib, equinox, optimistix and lineax
(:func:`environment`). Arguments that cannot be named so (a lambda, an object whose text
holds its address) run through :func:`equinox.filter_jit` as before. Within a process a
program is always run from its exported form, whether it was exported or loaded there, so
a fit gives the same numbers in a process that loaded its programs as in the one that
exported them. Entries are written by rename and carry a CRC-32, as the compilation cache's
(:mod:`gyroid._compile_cache`); a damaged one is exported again.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import os
import pickle
import shutil
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.core import Tracer

from gyroid._compile_cache import opened, write_sealed

#: Where programs are stored (:func:`use_store`): a folder, None (not stored: every call
#: runs through filter_jit) or "cache" (``exported`` in the compilation cache's folder).
_CHOSEN: list[Path | str | None] = ["cache"]
#: Programs this process holds, by key: a jitted call of the exported program and the
#: skeleton of its output.
_PROGRAMS: dict[str, tuple[Callable, Any]] = {}
_LOCK = threading.Lock()
#: A program JAX could not export (an operation without a stable form, an output that is
#: not an array): run through filter_jit.
_NOT_EXPORTED: Any = (None, None)
#: Libraries whose code is traced into the programs.
_LIBRARIES = ("jax", "jaxlib", "equinox", "optimistix", "lineax")
#: Programs a process keeps at most (a long process fitting logs of many shapes); past it
#: they are dropped and read back from the store as needed.
_KEPT = 512
#: The store keeps the programs of this many environments (:func:`environment`: gyroid's
#: source and the libraries' versions), the most recently written; older ones are removed
#: when a process first writes to a new one.
_ENVIRONMENTS = 4
_PRUNED: list[bool] = [False]


def use_store(folder: str | os.PathLike | None = "cache") -> None:
    """Keep exported programs in ``folder``: None keeps none, ``"cache"`` (the default)
    ``exported`` in JAX's persistent compilation cache (:func:`store_folder`)."""
    _CHOSEN[0] = None if folder is None else "cache" if folder == "cache" else Path(folder)
    _PROGRAMS.clear()


def store_folder() -> Path | None:
    """Where programs are stored: the folder :func:`use_store` chose, else ``exported`` in
    JAX's persistent compilation cache (:func:`gyroid._config.configure`); None without
    one."""
    chosen = _CHOSEN[0]
    if chosen != "cache":
        return chosen if isinstance(chosen, Path) else None
    cache = jax.config.values.get("jax_compilation_cache_dir")
    return Path(cache) / "exported" if cache else None


def _environment_folder(folder: Path) -> Path:
    """The part of the store for this process's :func:`environment`."""
    return folder / environment()[:16]


def _prune(folder: Path) -> None:
    """Remove the programs of all but the :data:`_ENVIRONMENTS` most recently written
    environments (once per process)."""
    if _PRUNED[0]:
        return
    _PRUNED[0] = True
    try:
        others = sorted((p for p in folder.iterdir() if p.is_dir()),
                        key=lambda p: p.stat().st_mtime, reverse=True)
    except OSError:
        return
    for old in others[_ENVIRONMENTS:]:
        shutil.rmtree(old, ignore_errors=True)


@functools.cache
def environment() -> str:
    """What every stored program was built from besides its own arguments: a digest of
    gyroid's source and the versions of the libraries traced into it, float64 and the
    platform."""
    digest = hashlib.sha256()
    package = Path(__file__).resolve().parent
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package).as_posix().encode())
        digest.update(path.read_bytes())
    for library in _LIBRARIES:
        try:
            digest.update(f"{library}={importlib.metadata.version(library)}".encode())
        except importlib.metadata.PackageNotFoundError:
            digest.update(f"{library}=?".encode())
    digest.update(f"x64={jax.config.read('jax_enable_x64')};{jax.default_backend()}".encode())
    return digest.hexdigest()


def _named(leaf: Any) -> str:
    """A static argument's text for a key: a function by its qualified name, anything else
    by its ``repr``."""
    if callable(leaf) and hasattr(leaf, "__qualname__") and hasattr(leaf, "__module__"):
        return f"{leaf.__module__}.{leaf.__qualname__}"
    return repr(leaf)


def program_key(name: str, args: tuple) -> tuple[str, list, Any, Any] | None:
    """The key of ``name`` called with ``args``, the arrays among them, their tree and the
    static rest; None where the static part cannot be named (a lambda, a local function, an
    object whose text is its address) or an argument is being traced."""
    dynamic, static = eqx.partition(args, eqx.is_array)
    leaves, treedef = jax.tree.flatten(dynamic)
    if any(isinstance(leaf, Tracer) for leaf in leaves):
        return None
    static_leaves, static_def = jax.tree.flatten(static)
    text = "\n".join([name, str(treedef), str(static_def), *map(_named, static_leaves),
                      *(f"{np.shape(x)}{x.dtype}{getattr(x, 'weak_type', False)}"
                        for x in leaves)])
    if " at 0x" in text or "<lambda>" in text or "<locals>" in text:
        return None
    key = hashlib.sha256((environment() + text).encode()).hexdigest()
    return key, leaves, treedef, static


class Exported:
    """``fun`` compiled as :func:`equinox.filter_jit` compiles it, its program exported to
    and loaded from the store (module docstring) where one is set; :func:`exported`."""

    def __init__(self, fun: Callable, name: str | None = None):
        functools.update_wrapper(self, fun)
        self.fun = fun
        self.jitted = eqx.filter_jit(fun)
        self.short = name or fun.__name__  # JAX's logs name the program so ("jit(short)")
        self.label = f"{fun.__module__}.{name or fun.__qualname__}"

    def __call__(self, *args):
        folder = store_folder()
        keyed = None if folder is None else program_key(self.label, args)
        if folder is None or keyed is None:
            return self.jitted(*args)
        program = self._program(folder, *keyed)
        if program is _NOT_EXPORTED:
            return self.jitted(*args)
        return _run(program, keyed[1])

    def bound(self, *fixed, fallback: Callable | None = None) -> Callable:
        """Calls of this program whose first arguments are ``fixed`` (a density called for
        batch after batch of draws): the key is built once per shape of the other
        arguments, not at every call. ``fallback(*rest)`` runs where nothing is stored
        (default: this program's own filter_jit)."""
        fixed_leaves = jax.tree.leaves(eqx.filter(fixed, eqx.is_array))
        programs: dict = {}

        def call(*rest):
            folder = store_folder()
            if folder is not None:
                leaves, tree = jax.tree.flatten(rest)
                signature = (folder, str(tree), *(
                    (np.shape(x), x.dtype) if eqx.is_array(x) else _named(x) for x in leaves))
                program = programs.get(signature)
                if program is None:
                    keyed = program_key(self.label, (*fixed, *rest))
                    program = (_NOT_EXPORTED if keyed is None
                               else self._program(folder, *keyed))
                    programs[signature] = program
                if program is not _NOT_EXPORTED:
                    arrays = [x for x in leaves if eqx.is_array(x)]
                    return _run(program, [*fixed_leaves, *arrays])
            return fallback(*rest) if fallback is not None else self.jitted(*fixed, *rest)

        return call

    def _program(self, folder: Path, key: str, leaves: list, treedef, static
                 ) -> tuple[Callable, Any]:
        """The program of ``key``: held, read from the store, or exported there."""
        program = _PROGRAMS.get(key)
        if program is None:
            if len(_PROGRAMS) > _KEPT:
                _PROGRAMS.clear()
            with _LOCK:
                program = _PROGRAMS.get(key) or _load(folder, key, self.short) or _export(
                    self.fun, treedef, static, leaves, folder, key, self.short)
                _PROGRAMS[key] = program
        return program


def exported(fun: Callable, *, name: str | None = None) -> Exported:
    """``fun`` compiled as :func:`equinox.filter_jit` compiles it, its program exported to
    and loaded from the store (module docstring) where one is set. ``name``: the program's
    name in its key (default: the function's qualified name)."""
    return Exported(fun, name)


def _run(program: tuple[Callable, Any], leaves: list):
    run, skeleton = program
    return jax.tree.unflatten(jax.tree.structure(skeleton), run(*leaves))


def _runner(program: jax.export.Exported, name: str) -> Callable:
    """The exported ``program`` compiled (once per process: from the persistent cache where
    it is there), under ``name``."""

    def run(*arrays):
        return program.call(*arrays)

    run.__name__ = run.__qualname__ = name
    return jax.jit(run)


def _load(folder: Path, key: str, name: str) -> tuple[Callable, Any] | None:
    """The program stored under ``key``, or None (absent, or damaged: it is then replaced)."""
    try:
        entry = opened((_environment_folder(folder) / f"{key}.program").read_bytes())
    except OSError:
        return None
    if entry is None:
        return None
    try:
        blob, skeleton = pickle.loads(entry)
        program = jax.export.deserialize(bytearray(blob))
    except Exception:  # written by another version, or damaged: export it again
        return None
    return _runner(program, name), skeleton


def _export(fun: Callable, treedef, static, leaves: list, folder: Path, key: str, name: str
            ) -> tuple[Callable, Any]:
    """``fun`` at these arguments exported, stored under ``key`` (where the folder can be
    written) and loaded; :data:`_NOT_EXPORTED` where JAX cannot export it."""
    shape: list = []

    def flat(*arrays):
        out = fun(*eqx.combine(jax.tree.unflatten(treedef, list(arrays)), static))
        out_leaves, out_def = jax.tree.flatten(out)
        if not all(isinstance(leaf, jax.Array | np.ndarray | np.generic | int | float)
                   for leaf in out_leaves):
            raise TypeError("an output that is not an array")
        shape.append(jax.tree.unflatten(out_def, [np.zeros(())] * len(out_leaves)))
        return tuple(jnp.asarray(leaf) for leaf in out_leaves)

    flat.__name__ = flat.__qualname__ = name
    specs = [jax.ShapeDtypeStruct(np.shape(x), x.dtype,
                                  weak_type=getattr(x, "weak_type", False)) for x in leaves]
    try:
        program = jax.export.export(jax.jit(flat))(*specs)
        blob = bytes(program.serialize())
    except Exception:  # whatever JAX cannot export runs as before
        return _NOT_EXPORTED
    try:
        write_sealed(_environment_folder(folder) / f"{key}.program",
                     pickle.dumps((blob, shape[0])))
        _prune(folder)
    except OSError:  # a folder this process may not write: the program is used unstored
        pass
    return _runner(program, name), shape[0]

