"""Fitting: one abstract problem (:class:`AbstractProblem`) with three final kinds (a bench
log's drift model, paper B's loop on a roll log, a pooled lot of runs), one :func:`fit`,
interchangeable samplers (:class:`Importance`, :class:`Emcee`, :class:`Nuts`), frozen
results, and the self-checks every fit passes through.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
