"""JAX settings gyroid needs, made explicitly (never as a side effect of ``import gyroid``).

* float64: every gyroid model computes in double precision (a FOG's 0.01 deg/h against a
  MEMS gyro's 10^4 deg/h bias, and sums over 10^7 rows, do not survive float32).
  :func:`enable_float64` turns it on; the computing packages (``gyroid.models`` and every
  package built on it) call it when they are first imported, since a float32 answer would
  be a silent wrong one.
* the persistent compilation cache: :func:`configure` (called by the command line) keeps
  compiled programs in the user's cache folder, so that a command reuses what an earlier
  one compiled. A library user opts in with ``gyroid.configure()``.
"""

from __future__ import annotations

import os


def enable_float64() -> None:
    """Turn on JAX's 64-bit mode (idempotent)."""
    import jax

    if not jax.config.jax_enable_x64:
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
    :func:`cache_folder`."""
    import jax

    enable_float64()
    folder = cache_folder() if compilation_cache else None
    if folder is not None:
        jax.config.update("jax_compilation_cache_dir", folder)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
