"""JAX settings gyroid needs, made explicitly (never as a side effect of ``import gyroid``).

* float64: every gyroid model computes in double precision (a FOG's 0.01 deg/h against a
  MEMS gyro's 10^4 deg/h bias, and sums over 10^7 rows, do not survive float32).
  :func:`enable_float64` turns it on; the computing packages (``gyroid.models`` and every
  package built on it) call it when they are first imported, since a float32 answer would
  be a silent wrong one.
* the persistent compilation cache: :func:`configure` (called by the command line) keeps
  compiled programs in the user's cache folder, so that a command reuses what an earlier
  one compiled, and gyroid's largest programs exported beside them (``exported`` in that
  folder, :mod:`gyroid._exported`), so that it loads them instead of tracing them. A
  library user opts in with ``gyroid.configure()``.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager


def enable_float64() -> None:
    """Turn on JAX's 64-bit mode (idempotent)."""
    import jax

    if not jax.config.read("jax_enable_x64"):
        jax.config.update("jax_enable_x64", True)


def cache_folder() -> str | None:
    """Where the compilation cache goes: ``GYROID_JAX_CACHE`` (a path, or ``off``), else the
    user's cache folder (``XDG_CACHE_HOME`` or ``~/.cache``)/gyroid/jax; None when switched
    off or when JAX's own ``JAX_COMPILATION_CACHE_DIR`` is set (JAX then uses that)."""
    setting = os.environ.get("GYROID_JAX_CACHE", "").strip()
    if setting.lower() in ("off", "0", "no", "false") or os.environ.get(
            "JAX_COMPILATION_CACHE_DIR"):
        return None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return setting or os.path.join(base, "gyroid", "jax")


def configure(*, compilation_cache: bool = True) -> None:
    """float64 and (unless ``compilation_cache=False``) JAX's persistent compilation cache in
    :func:`cache_folder`, gyroid's exported programs with it."""

    enable_float64()
    folder = cache_folder() if compilation_cache else None
    if folder is not None:
        use_compilation_cache(folder)


def use_compilation_cache(folder: str) -> None:
    """Keep every compiled program in ``folder`` (JAX's persistent compilation cache)."""
    import jax

    from gyroid._compile_cache import install

    jax.config.update("jax_compilation_cache_dir", folder)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    install(folder)  # entries written by rename: processes sharing the folder stay safe


#: Environment that keeps a process's computing on one core: XLA's and the BLAS's thread
#: pools off, and gyroid's own batches on one thread (:func:`compute_threads`). Two gyroid
#: processes side by side on a two-core machine otherwise run ~1.4x slower each, their
#: pools contending (the demo's two processes: 29 s -> 25 s warm).
ONE_CORE_ENVIRONMENT = {
    "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false",
    "GYROID_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}


def compute_threads() -> int:
    """How many threads a batch of evaluations may run on: ``GYROID_THREADS`` (a positive
    integer; the one-core environment sets 1), else the cores this process may use."""
    setting = os.environ.get("GYROID_THREADS", "").strip()
    if setting.isdigit() and int(setting) > 0:
        return int(setting)
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # no affinity on this platform
        return max(os.cpu_count() or 1, 1)


def use_one_core() -> None:
    """Set :data:`ONE_CORE_ENVIRONMENT` in ``os.environ`` (the user's own ``XLA_FLAGS`` kept
    after gyroid's, so that they win), for the processes started after; it also reaches
    this process's XLA if JAX has not computed anything yet."""
    for name, value in ONE_CORE_ENVIRONMENT.items():
        own = os.environ.get(name) if name == "XLA_FLAGS" else None
        os.environ[name] = f"{value} {own}" if own else value


@contextmanager
def one_core_environment() -> Iterator[None]:
    """:func:`use_one_core` for the processes started inside; ``os.environ`` restored
    after."""
    saved = {name: os.environ.get(name) for name in ONE_CORE_ENVIRONMENT}
    try:
        use_one_core()
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
