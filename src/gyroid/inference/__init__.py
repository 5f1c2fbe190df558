"""Likelihoods (one Kalman filter), point estimates, posteriors (emcee, NUTS) and the
self-checks every fit passes through.
"""

from gyroid._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "_bench_fit": ["fit_log"],
    "_pool_fit": ["fit_pool"],
    "_pool_result": ["PoolResult"],
    "_roll_fit": ["fit_roll_log"],
})
