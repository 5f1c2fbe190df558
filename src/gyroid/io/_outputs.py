"""Atomic outputs: a command's files appear whole or not at all."""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename."""
    with atomic_path(Path(path)) as tmp:
        tmp.write_text(text, encoding="utf-8")


@contextlib.contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; renamed onto ``path`` when the block
    ends without an error, removed otherwise."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 would make outputs private to the user
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def to_jsonable(value: Any) -> Any:
    """Convert numpy/JAX scalars and arrays to plain JSON values (NaN/inf become null)."""
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [to_jsonable(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, str):
        return to_jsonable(np.asarray(value).tolist())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    return value


def json_text(data: Any) -> str:
    return json.dumps(to_jsonable(data), indent=2, allow_nan=False) + "\n"


def _lock_owner(lock: Path) -> int | None:
    """The process id written in a lock file (None when unreadable)."""
    try:
        return int(lock.read_text(encoding="ascii").split()[0])
    except (OSError, ValueError, IndexError):
        return None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


@contextlib.contextmanager
def output_lock(out: str | Path) -> Iterator[None]:
    """Hold ``out`` for one writer: a lock file beside it (``.NAME.lock``, holding the
    process id) made exclusively, removed when the block ends. A second command writing to
    the same folder at the same time is refused with a clear error instead of racing; a lock
    left by a process that no longer runs is taken over; the same process may nest it."""
    from gyroid.errors import GyroidInputError

    out = Path(out)
    lock = out.parent / f".{out.name}.lock"
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise GyroidInputError(f"--out {out}: cannot write there ({error.strerror or error}); "
                               "choose a folder you can write to") from None
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            break
        except FileExistsError:
            owner = _lock_owner(lock)
            if owner == os.getpid():
                yield
                return
            if owner is not None and _alive(owner):
                raise GyroidInputError(
                    f"--out {out} is being written by another gyroid command (process "
                    f"{owner}); wait for it to finish or choose another folder "
                    f"(if no gyroid command is running, delete {lock})") from None
            with contextlib.suppress(FileNotFoundError):
                os.unlink(lock)  # left by a process that is gone
        except OSError as error:
            raise GyroidInputError(f"--out {out}: cannot write there "
                                   f"({error.strerror or error}); choose a folder you can "
                                   "write to") from None
    else:
        raise GyroidInputError(f"--out {out}: another command took its lock {lock}; try again")
    try:
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
        os.close(fd)
        yield
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(lock)


@contextlib.contextmanager
def output_dir(out: str | Path) -> Iterator[Path]:
    """Stage a command's outputs in a hidden sibling folder; move them into ``out`` on success.

    If the block raises, nothing reaches ``out``. Files already in ``out`` that the command
    does not write are left as they are; each written file replaces its old version
    atomically. ``out`` is held by :func:`output_lock` meanwhile.
    """
    from gyroid.errors import GyroidInputError

    out = Path(out)
    if out.exists() and not out.is_dir():
        raise GyroidInputError(f"--out {out} is a file; give a folder")
    with output_lock(out), _staged(out) as staging:
        yield staging


@contextlib.contextmanager
def _staged(out: Path) -> Iterator[Path]:
    from gyroid.errors import GyroidInputError

    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.staging-"))
    except OSError as error:
        raise GyroidInputError(f"--out {out}: cannot write there ({error.strerror or error}); "
                               "choose a folder you can write to") from None
    try:
        yield staging
        try:
            out.mkdir(exist_ok=True)
        except OSError as error:
            raise GyroidInputError(f"--out {out}: cannot write there "
                                   f"({error.strerror or error}); choose a folder you can "
                                   "write to") from None
        for item in sorted(staging.rglob("*")):
            target = out / item.relative_to(staging)
            if item.is_dir():
                target.mkdir(exist_ok=True)
            else:
                os.replace(item, target)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
