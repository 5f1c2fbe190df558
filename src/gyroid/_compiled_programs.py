"""The compiled programs a long-running process keeps, dropped before they exhaust its memory
mappings.

JAX keeps every program it compiles, per function and per shape, for the life of the process.
On Linux each of XLA's CPU programs holds memory mappings (about 120 for one of gyroid's
programs read back from the persistent compilation cache, one per section of its kernels),
and a process may hold at most ``vm.max_map_count`` of them (65 530 by default). A process
that fits logs of many shapes (measured: each new length of a thermal bench log kept some
2 300 more mappings; a pytest worker running hundreds of tests) reaches the limit, and XLA
then aborts the interpreter ("LLVM ERROR: Unable to allocate section memory", "Fatal Python
error: Aborted"): no exception, nothing written. Before each fit gyroid counts its mappings
(:func:`release_if_crowded`) and, past half the limit, drops JAX's in-memory caches: the
programs it needs again are then read back from the persistent compilation cache (a few
milliseconds each) or compiled again. Where there is no such limit to read (not Linux), it
does nothing.
"""

from __future__ import annotations

#: The share of the process's mapping limit past which the compiled programs are dropped:
#: half leaves room for the largest single job measured (a fit of a new shape, ~2 300
#: mappings; a discrepancy search's candidates) many times over.
CROWDED_SHARE = 0.5


def mapping_count() -> int | None:
    """The memory mappings this process holds (Linux: lines of ``/proc/self/maps``); None
    where that cannot be read. Costs ~1 ms per 1 000 mappings."""
    try:
        with open("/proc/self/maps", "rb") as maps:
            return maps.read().count(b"\n")
    except OSError:
        return None


def mapping_limit() -> int | None:
    """The most memory mappings a process may hold (Linux's ``vm.max_map_count``); None
    where there is none to read."""
    try:
        with open("/proc/sys/vm/max_map_count") as limit:
            return int(limit.read())
    except (OSError, ValueError):
        return None


def release_if_crowded(share: float = CROWDED_SHARE) -> bool:
    """Drop JAX's compiled programs (``jax.clear_caches``) if this process holds more than
    ``share`` of its memory-mapping limit; True when it did. Call it between jobs, never
    while a compiled program's results are still being computed."""
    limit = mapping_limit()
    count = mapping_count() if limit is not None else None
    if limit is None or count is None or count <= share * limit:
        return False
    import gc

    import jax

    jax.clear_caches()
    gc.collect()  # programs no longer referenced are unmapped when their objects go
    return True
