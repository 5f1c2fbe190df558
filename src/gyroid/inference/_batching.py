"""A problem's density method evaluated for many parameter vectors at once (emcee's walkers,
the posterior draws), compiled once per density structure and shape.

A problem's density is an equinox module; its arrays are passed to one jitted, vmapped
function as arguments (never closed over: a new log of the same shape reuses the
compilation) and its static part is hashed once.
"""

from __future__ import annotations

import functools

import equinox as eqx
import jax


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
def _batched_method(static, treedef, method, leaves, u):
    problem = eqx.combine(jax.tree_util.tree_unflatten(treedef, leaves), static.value)
    return jax.vmap(getattr(problem, method))(u)


def problem_batcher(density: eqx.Module, method: str = "log_posterior"):
    """``u (w, d) -> vmap(density.<method>)(u)``, jit-compiled once per density structure
    and shape (the arrays are arguments, so a new log of the same shape reuses the
    compilation). ``density`` is a problem's JAX part (``problem.density``); it is split and
    flattened here, once, not on every call."""
    dynamic, static = eqx.partition(density, eqx.is_array)
    leaves, treedef = jax.tree_util.tree_flatten(dynamic)
    static = _interned(static)
    return lambda u: _batched_method(static, treedef, method, leaves, u)
