"""A bench log's drift model fitted: the problem (:class:`BenchProblem`, built from a log),
its density, the dT/dt window, the thermometer's noise carried, the checks only a bench fit
has, its result (:class:`BenchFit`) and the one-call :func:`fit_log`. It builds on the
generic fitting of :mod:`gyroid.inference` and imports nothing of the other kinds.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
