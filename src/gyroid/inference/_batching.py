"""A problem's density method evaluated for many parameter vectors at once (emcee's walkers,
the posterior draws), compiled once per density structure and shape.

A problem's density is an equinox module; its arrays are passed to one jitted, vmapped
function as arguments (never closed over: a new log of the same shape reuses the
compilation) and its static part is hashed once.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import equinox as eqx
import jax
import numpy as np
from jax.typing import ArrayLike

from gyroid._config import compute_threads
from gyroid._exported import exported


class _HashedOnce:
    """A static jit argument whose (costly, equinox-module) hash is computed once: jit
    hashes and compares its static arguments on every call, which would otherwise dominate
    a call that costs microseconds. Equal values are interned to one object, so the
    comparison on a cache hit is an identity check."""

    __slots__ = ("value", "_hash")

    def __init__(self, value) -> None:
        self.value = value
        self._hash = hash(value)

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other) -> bool:
        return isinstance(other, _HashedOnce) and (
            self.value is other.value or (self._hash == other._hash and self.value == other.value)
        )


_INTERNED: dict[_HashedOnce, _HashedOnce] = {}


def _interned(value) -> _HashedOnce:
    key = _HashedOnce(value)
    if len(_INTERNED) > 256:  # a long session with many model structures: start afresh
        _INTERNED.clear()
    return _INTERNED.setdefault(key, key)


@functools.partial(jax.jit, static_argnums=(0, 1, 2))
def _batched_method(static, treedef, function, leaves, u):
    return _batched(eqx.combine(jax.tree_util.tree_unflatten(treedef, leaves), static.value),
                    function, u)


def _batched(density, function, u):
    return jax.vmap(lambda row: function(density, row))(u)


#: The batched evaluation as a stored program (:mod:`gyroid._exported`); where nothing is
#: stored, :func:`_batched_method` runs it.
_BATCHED = exported(_batched, name="batched_method")


def problem_batcher(method: Callable[[jax.Array], jax.Array]):
    """``u (w, d) -> vmap(method)(u)`` for a bound method of a problem's JAX part, e.g.
    ``problem_batcher(problem.density.log_posterior)``: jit-compiled once per density
    structure and shape (the arrays are arguments, so a new log of the same shape reuses the
    compilation), its program loaded from gyroid's store where there is one. The density is
    split and flattened here, once, not on every call."""
    density, function = method.__self__, method.__func__
    dynamic, static = eqx.partition(density, eqx.is_array)
    leaves, treedef = jax.tree_util.tree_flatten(dynamic)
    static = _interned(static)
    return _BATCHED.bound(density, function, fallback=lambda u: _batched_method(
        static, treedef, function, leaves, u))


def in_chunks(batch: Callable[[np.ndarray], ArrayLike], rows: np.ndarray, chunk: int
              ) -> np.ndarray:
    """``batch`` (e.g. a :func:`problem_batcher`) over ``rows`` ``chunk`` at a time, the
    last chunk padded with copies of the last row (one compiled shape): the memory of one
    chunk's evaluations per thread, whatever the number of rows. The chunks run on
    :func:`~gyroid._config.compute_threads` threads, each its own compiled call (JAX
    releases Python's lock while one runs): XLA spreads a single call's filter over the
    cores at a loss (1000 draws of paper A's bench's marginal: 0.29-0.50 s wall for 0.51-0.83
    s of processor time), where two calls side by side took 0.20 s for the same draws."""
    padded = np.concatenate([rows, np.repeat(rows[-1:], -rows.shape[0] % chunk, axis=0)])
    starts = range(0, padded.shape[0], chunk)

    def one(start: int) -> np.ndarray:
        return np.asarray(batch(padded[start:start + chunk]))

    threads = min(compute_threads(), len(starts))
    if threads > 1:
        with ThreadPoolExecutor(threads) as pool:
            out = np.concatenate(list(pool.map(one, starts)))
    else:
        out = np.concatenate([one(start) for start in starts])
    return out[: rows.shape[0]]
