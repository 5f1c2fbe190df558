"""Writing results: :func:`write` (one entry point for every kind of result) and the
reproduction of both papers' files."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
