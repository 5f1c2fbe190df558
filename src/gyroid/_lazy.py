"""Explicit public re-exports, imported on first use: a package lists its public names and
the private module each comes from, and gets ``__getattr__``, ``__dir__`` and ``__all__``.
Importing a package (or one of its modules) then costs nothing until a name is used, which
keeps the command line quick to start."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence


def attach(package: str, exports: Mapping[str, Sequence[str]]
           ) -> tuple[Callable[[str], object], Callable[[], list[str]], list[str]]:
    """``exports``: private module (relative, e.g. ``"_logs"``) -> the public names it
    holds; a name ``"PRIVATE as PUBLIC"`` re-exports under another name."""
    where: dict[str, tuple[str, str]] = {}
    for module, names in exports.items():
        for name in names:
            private, _, public = name.partition(" as ")
            where[public or private] = (f"{package}.{module}", private)

    def __getattr__(name: str):
        if name not in where:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module, private = where[name]
        value = getattr(importlib.import_module(module), private)
        setattr(importlib.import_module(package), name, value)  # an ordinary attribute now
        return value

    def __dir__() -> list[str]:
        return sorted({*vars(importlib.import_module(package)), *where})

    return __getattr__, __dir__, sorted(where)
