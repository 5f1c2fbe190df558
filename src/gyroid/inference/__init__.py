"""Fitting any problem: one abstract problem (:class:`AbstractProblem`, whose final kinds
live in their own packages: :mod:`gyroid.bench`, :mod:`gyroid.roll`, :mod:`gyroid.pool`,
:mod:`gyroid.allan`), one :func:`fit`, interchangeable samplers (:class:`Importance`,
:class:`Emcee`, :class:`Nuts`), the one marginal of a model linear in its coefficients, the
result base, and the self-checks every fit passes through. Nothing here imports a kind.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
