"""Likelihoods (one Kalman filter), point estimates, posteriors (emcee, NUTS) and the
self-checks every fit passes through."""

from gyroid.inference._bench_fit import fit_log
from gyroid.inference._pool_fit import fit_pool
from gyroid.inference._pool_result import PoolResult
from gyroid.inference._roll_fit import fit_roll_log

__all__ = ["PoolResult", "fit_log", "fit_pool", "fit_roll_log"]
