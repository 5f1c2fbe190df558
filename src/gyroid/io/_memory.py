"""Whether a log can be held whole. ``gyroid fit`` streams a log too long to hold; the
commands that hold every row (``compensate``, ``discrepancy``) refuse one whose rows would
not fit in the memory that is free, before reading it, rather than be killed by the system
halfway with no word (a 10^8-row log needs ~25 GB to compensate)."""

from __future__ import annotations

from pathlib import Path

from gyroid.errors import GyroidInputError

#: Peak memory per row of a bench log (bytes), measured at 10^7 rows of six columns
#: (benchmarks/scaling.py): ``gyroid compensate`` 2.5 GB, ``gyroid discrepancy`` 1.4 GB.
COMPENSATE_BYTES_PER_ROW = 250
DISCREPANCY_BYTES_PER_ROW = 140


def memory_free_bytes() -> int | None:
    """The memory the system can give without swapping (``MemAvailable`` of
    ``/proc/meminfo``), bytes; None where that is not known."""
    try:
        with open("/proc/meminfo") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def refuse_if_too_long(path: str | Path, *, bytes_per_row: int, command: str,
                       remedy: str) -> None:
    """Refuse a table log (Parquet or CSV) whose rows would need more memory than is free,
    estimated from its footer or its size without reading it; native logs and machines
    that do not say their free memory are let through."""
    from gyroid.io._stream import stream_rows

    counted = stream_rows(path)
    free = memory_free_bytes()
    if counted is None or free is None:
        return
    rows, exact = counted
    need = rows * bytes_per_row
    if need > free:
        size = f"{rows} rows" if exact else f"up to about {rows} rows"
        raise GyroidInputError(
            f"{Path(path).name}: {command} holds the whole log, and its {size} need about "
            f"{need / 1e9:.1f} GB where {free / 1e9:.1f} GB are free: {remedy}")
