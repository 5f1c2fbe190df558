"""The one Kalman filter of gyroid: a scalar state seen through white noise.

Both noise models gyroid fits are this filter with a different state:

* bench logs: the residual is a stationary Gauss-Markov bias plus white noise
  (:func:`gauss_markov_innovations`);
* roll logs: the residual of the stabiliser angle is the SINS gyro's noise integrated into
  the angle (a random walk from zero) plus the encoder's white read-out noise
  (:func:`random_walk_innovations`).

The innovations and their variances give the exact Gaussian log-likelihood,
``-0.5 sum(innovation**2 / variance + log(2 pi variance))``, and standardised innovations
(``innovation / sqrt(variance)``) that are independent N(0, 1) when the model is right:
what the whiteness check reads.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float


def scalar_state_innovations(
    observed: Float[Array, "n ..."],
    phi: Float[Array, " n"],
    q: Float[Array, " n"],
    r: Float[Array, " n"],
    start_var: Float[Array, ""],
    update: Float[Array, " n"] | None = None,
) -> tuple[Float[Array, "n ..."], Float[Array, " n"]]:
    """Innovations and their variances of ``observed_k = x_k + e_k``.

    State ``x_k = phi_k x_(k-1) + eta_k`` with ``eta_k ~ N(0, q_k)``, white ``e_k ~ N(0,
    r_k)``, and ``x_0`` before the first step ``~ N(0, start_var)``. ``observed`` may have
    trailing columns, each filtered alike (the filter is linear in the data; the variances
    do not depend on it). Rows with ``update == 0`` are not learnt from (a held-out
    stretch): the state is only predicted through them, so their innovations are the
    errors of a prediction from the rows before, and ``innovation**2 / variance`` sums to
    the exact chi-square of those rows only row by row, not jointly.
    """

    def step(carry, row):
        mean, var = carry  # of x after the previous update
        e_k, phi_k, q_k, r_k, u_k = row
        prior_mean = phi_k * mean
        prior_var = phi_k**2 * var + q_k
        total = prior_var + r_k
        innovation = e_k - prior_mean
        gain = u_k * prior_var / total
        return (prior_mean + gain * innovation, (1.0 - gain) * prior_var), (innovation, total)

    update = jnp.ones_like(phi) if update is None else update
    start = (jnp.zeros(observed.shape[1:]), jnp.asarray(start_var, dtype=float))
    # Not unrolled: unroll=4 made emcee's batches of walkers 20 % faster (a white+gm fit of
    # 13 500 rows: 128 s against 160 s) but one filter pass 8x slower (37 200 rows: 12 ms
    # against 1.5 ms), which the discrepancy workflow's thousands of passes pay.
    _, (innovation, variance) = jax.lax.scan(step, start, (observed, phi, q, r, update))
    return innovation, variance


def gauss_markov_innovations(residual, steps_s, white, sd_gm, tau_s, update=None):
    """Innovations of white + Gauss-Markov noise and their variances.

    The residual is ``g + w``: ``g`` a stationary Gauss-Markov state of sd ``sd_gm`` and
    correlation time ``tau_s`` (s), ``w`` white of sd ``white`` (scalar or per row). Exact
    for any sampling (``phi_k = exp(-step_k / tau)``, ``steps_s`` the time since the
    previous row); the state starts stationary (mean 0, variance ``sd_gm**2``); ``update``:
    0 at rows not learnt from.
    """
    phi = jnp.exp(-steps_s / tau_s)
    q = sd_gm**2 * (1.0 - phi**2)
    r = jnp.broadcast_to(white**2, steps_s.shape)
    return scalar_state_innovations(residual, phi, q, r, sd_gm**2, update)


def random_walk_innovations(residual, steps, walk_sd, white, update=None):
    """Innovations of a random walk from zero plus white noise, and their variances.

    ``steps``: samples since the previous observed row; the walk adds ``walk_sd**2`` of
    variance per sample (an angle random walk sampled every ``steps`` samples); ``white``:
    the read-out noise's sd at each observed row; ``update``: 0 at rows not learnt from.
    """
    steps = jnp.asarray(steps, dtype=float)
    q = walk_sd**2 * steps
    r = jnp.broadcast_to(white**2, steps.shape)
    return scalar_state_innovations(residual, jnp.ones_like(steps), q, r, jnp.zeros(()),
                                    update)


def gauss_markov_mean_covariance(time_s: np.ndarray, part: np.ndarray, n_parts: int,
                                 sd: float, tau_s: float) -> np.ndarray:
    """Covariance of the parts' means of a stationary Gauss-Markov process (sd ``sd``,
    correlation time ``tau_s``) sampled at ``time_s`` (parts contiguous and in time order):
    the exponential kernel summed over every pair of samples, exactly, in O(n) (log-sum-exp
    of ``+-t / tau`` within and across parts)."""
    from scipy.special import logsumexp

    cov = np.zeros((n_parts, n_parts))
    a = np.asarray(time_s, dtype=float) / tau_s
    lse_plus, lse_minus, counts = np.zeros(n_parts), np.zeros(n_parts), np.zeros(n_parts)
    for s in range(n_parts):
        x = a[part == s]
        counts[s] = x.size
        # sum_{i, j in s} exp(-|a_i - a_j|) = m + 2 sum_i sum_{j < i} exp(a_j - a_i)
        running = np.logaddexp.accumulate(x)[:-1]  # log sum_{j <= i-1} exp(a_j)
        within = x.size + 2.0 * float(np.sum(np.exp(running - x[1:])))
        cov[s, s] = within
        lse_plus[s], lse_minus[s] = logsumexp(x), logsumexp(-x)
    for s in range(n_parts):
        for r in range(s + 1, n_parts):  # part s before part r: exp(a_i - a_j)
            cov[s, r] = cov[r, s] = float(np.exp(lse_plus[s] + lse_minus[r]))
    return sd**2 * cov / np.outer(counts, counts)
