"""Figures (matplotlib, Agg): black-and-white readable, units on every axis. One module per
kind of figure; every figure function is importable from here.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
