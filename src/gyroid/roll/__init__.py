"""Paper B's loop on a roll log fitted: the problem (:class:`RollProblem`), its density, its
held-out check, its result (:class:`RollFit`) and the one-call :func:`fit_roll_log`, on the
generic fitting of :mod:`gyroid.inference`.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
