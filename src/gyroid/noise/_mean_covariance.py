"""The covariance of means of a drift log's correlated noise over time intervals, written
out pair by pair (dense): what the block filter (:mod:`gyroid.noise._block_filter`) gives as
a likelihood, for the predictive check's parts and for testing the filter.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gyroid.noise._block_filter import Processes


def mean_covariance(start_s: np.ndarray, end_s: np.ndarray, white_var: np.ndarray,
                    processes: Sequence[Processes], diffusion: float,
                    origin_s: float, centre_span_s: float | None = None) -> np.ndarray:
    """The covariance ((deg/h)^2) of the means over time intervals ``[start_s, end_s]``
    (disjoint or touching, in time order) of the same noise, written out pair by pair
    (dense; for the predictive check's parts and for testing the filter): white variance
    ``white_var`` per interval, each Gauss-Markov process's (``processes``:
    :data:`Processes`) exponential kernel integrated over both intervals, and the
    random walk diffusing ``diffusion`` ((deg/h)^2 per s): from zero at ``origin_s``
    (covariance ``D min(s, t)``), or with ``centre_span_s`` centred, its mean over
    ``[origin_s, origin_s + centre_span_s]`` zero (as the likelihood's, on a log whose
    blocks tile that span)."""
    a = np.asarray(start_s, dtype=float) - origin_s
    b = np.asarray(end_s, dtype=float) - origin_s
    length = b - a
    cov = np.diag(np.asarray(white_var, dtype=float))
    # Interval j > i comes after interval i: its order, not a comparison of end points,
    # says so. Touching intervals (a uniform clock's parts) end where the next starts, and
    # rounding put some ends a hair past the next start: their covariance, the largest
    # of all under a long correlation time, was dropped, and the matrix was indefinite.
    after = np.triu(np.ones((a.size, a.size), dtype=bool), 1)
    for tau, var in ((float(t), level**2 * unit) for taus, level, unit in processes
                     for t in np.asarray(taus, dtype=float).ravel()):
        u = length / tau
        # the mean of a stationary process over L: 2 var tau^2 (u - 1 + exp(-u)) / L^2
        within = 2.0 * var * tau**2 * (u + np.expm1(-u)) / length**2
        # interval i before j, a gap g = a_j - b_i apart (all over tau):
        #   var tau^2 (e^{-g} - e^{-(g + u_i)} - e^{-(g + u_j)} + e^{-(g + u_i + u_j)})
        #   / (L_i L_j) = var tau^2 e^{-g} (1 - e^{-u_i}) (1 - e^{-u_j}) / (L_i L_j),
        # the product written with expm1 (the four terms cancel when tau >> L)
        gap = np.maximum(a[None, :] - b[:, None], 0.0) / tau  # touching: 0, not rounding's
        decay = np.where(after, np.exp(-gap), 0.0)
        edge = -np.expm1(-u) / length
        cross = var * tau**2 * decay * np.outer(edge, edge)
        cov += cross + cross.T + np.diag(within)
    mid = 0.5 * (a + b)
    walk_cov = diffusion * np.minimum.outer(mid, mid)
    walk_cov[np.diag_indices_from(walk_cov)] = diffusion * (a + length / 3.0)
    if centre_span_s is not None:
        # W(t) - mean W over [0, T]: each interval's covariance with the mean, D (mean of
        # t - t^2 / 2T over it), and the mean's variance D T / 3
        span = float(centre_span_s)
        with_mean = diffusion * (mid - (a**2 + a * b + b**2) / (6.0 * span))
        walk_cov = (walk_cov - with_mean[:, None] - with_mean[None, :]
                    + diffusion * span / 3.0)
    return cov + walk_cov


def log_span_s(time_s: np.ndarray, step_s: float) -> float:
    """A log's span (s): its rows' first to last time plus one step (each row a step's
    mean)."""
    time_s = np.asarray(time_s, dtype=float)
    return float(time_s[-1] - time_s[0]) + step_s


def part_covariance(time_s: np.ndarray, part: np.ndarray, n_parts: int, step_s: float,
                    white_var: np.ndarray, processes: Sequence[Processes],
                    diffusion: float, after_s: float | None = None) -> np.ndarray:
    """The covariance ((deg/h)^2) of parts' means of a log's rows (``part``: each row's
    part, -1 for none; parts contiguous and in time order), each row one sampling step
    ``step_s`` long: ``white_var`` each part's white variance, the Gauss-Markov processes
    (:func:`mean_covariance`) and the walk (``diffusion``, (deg/h)^2 per s) centred on
    this log (as the likelihood's), or, with ``after_s``, on a log of that span just before
    this one (a new log compensated with a fit's bias: the walk from the fitted log's mean,
    whose variance at its end is ``D after_s / 3``, then on from zero at this log's
    start)."""
    time_s = np.asarray(time_s, dtype=float)
    kept = part >= 0
    first = np.full(n_parts, np.inf)
    last = np.full(n_parts, -np.inf)
    np.minimum.at(first, part[kept], time_s[kept])
    np.maximum.at(last, part[kept], time_s[kept])
    span = log_span_s(time_s, step_s)
    cov = mean_covariance(first - 0.5 * step_s, last + 0.5 * step_s, white_var, processes,
                          diffusion, time_s[0] - 0.5 * step_s,
                          centre_span_s=span if after_s is None else None)
    if after_s is not None:
        cov = cov + diffusion * float(after_s) / 3.0
    return cov
