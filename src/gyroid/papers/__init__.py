"""Paper A's classical estimators and the reproduction and audit of both papers' tables.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
