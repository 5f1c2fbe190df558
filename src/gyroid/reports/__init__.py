"""Writing results: :func:`write` (one entry point for every kind of result) and the
reproduction of both papers' files."""

from gyroid._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "_write": ["write_compensated_csv", "write"],
    "_reproduction": ["write_reproduction"],
})
