"""A lot of runs pooled: the hierarchical problem (:class:`PoolProblem`) built from each run's
own bench fit, its checks and result (:class:`PoolFit`), and :func:`fit_pool`. The one kind
that builds on another (:mod:`gyroid.bench`).
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
