"""A linear model's white-noise likelihood on its rows' sufficient statistics
(:class:`SufficientStatistics`, a typed part of :class:`~gyroid.bench.BenchDensity`,
computed once on the host): its rows' Gram matrix and least-squares solution (and the same
per LOO block), so that an evaluation costs ``O(p^2)`` whatever the log's length (its
coefficients integrate out on them: :class:`~gyroid.inference._collapsed.
SufficientCoefficients`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.models._design import least_squares_from_r, with_rows

_LOG_2PI = math.log(2.0 * math.pi)

#: Rows of the weighted design and drift, block by block: (rows, X, y).
WeightedBlocks = Callable[[], Iterable[tuple[slice, np.ndarray, np.ndarray]]]


class SufficientStatistics(eqx.Module):
    """A linear model's white-noise likelihood on sufficient statistics: the R factor of the
    weighted ``[X, y]`` (X'WX its design part's ``R'R``), the weighted least-squares
    solution and the residual sum there, for the whole log and for each LOO
    block about that solution (which keeps the block sums well conditioned), with the
    rows' count and sum of log sigma per block."""

    factor: Float[Array, "1+p 1+p"]  # the R factor of the weighted [X, y]
    solution: Float[Array, " p"]
    rss_min: Float[Array, ""]
    log_sigma_sum: Float[Array, ""]
    block_gram: Float[Array, "b p p"]
    block_xr: Float[Array, "b p"]
    block_rr: Float[Array, " b"]
    block_count: Float[Array, " b"]
    block_log_sigma: Float[Array, " b"]

    @classmethod
    def of(cls, blocks: WeightedBlocks, p: int, block: np.ndarray, n_blocks: int,
           log_sigma: np.ndarray) -> SufficientStatistics:
        """Two passes over the weighted design ``blocks()`` (its R factor, then the block
        sums): memory of one block, whatever the log's length. ``block``: each row's LOO
        block; ``log_sigma``: each row's log of its known sd (zeros when not known)."""
        r = None
        for _, xw, yw in blocks():
            r = with_rows(r, np.column_stack([xw, yw]))
        if r is None:
            raise ValueError("a density of no rows has no sufficient statistics")
        solution, rss = least_squares_from_r(r)
        factor = np.zeros((p + 1, p + 1))
        factor[: r.shape[0]] = r
        gram_b = np.zeros((n_blocks, p, p))
        xr_b = np.zeros((n_blocks, p))
        rr_b = np.zeros(n_blocks)
        for rows, xw, yw in blocks():
            r0 = yw - xw @ solution
            index = block[rows]
            for i in range(p):
                xr_b[:, i] += np.bincount(index, xw[:, i] * r0, n_blocks)
                for j in range(i, p):
                    gram_b[:, i, j] += np.bincount(index, xw[:, i] * xw[:, j], n_blocks)
                    gram_b[:, j, i] = gram_b[:, i, j]
            rr_b += np.bincount(index, r0**2, n_blocks)
        return cls(jnp.asarray(factor), jnp.asarray(solution), jnp.asarray(rss),
                   jnp.asarray(float(np.sum(log_sigma))), jnp.asarray(gram_b),
                   jnp.asarray(xr_b), jnp.asarray(rr_b),
                   jnp.asarray(np.bincount(block, minlength=n_blocks).astype(float)),
                   jnp.asarray(np.bincount(block, log_sigma, n_blocks)))

    @property
    def gram(self) -> Float[Array, "p p"]:
        """X'WX, from the factor (``R'R`` of its design columns)."""
        design = self.factor[:, :-1]
        return design.T @ design

    def log_likelihood(self, theta: Float[Array, " p"], sd: Float[Array, ""] | None,
                       n: int) -> Float[Array, ""]:
        """The log-likelihood of the ``n`` rows at coefficients ``theta``: with their known
        sds (``sd`` None) or a row's sd ``sd`` (deg/h)."""
        delta = theta - self.solution
        rss = self.rss_min + delta @ self.gram @ delta
        if sd is None:
            return -0.5 * rss - self.log_sigma_sum - 0.5 * n * _LOG_2PI
        return -0.5 * rss / sd**2 - n * jnp.log(sd) - 0.5 * n * _LOG_2PI

    def log_likelihood_blocks(self, theta: Float[Array, " p"], sd: Float[Array, ""] | None
                              ) -> Float[Array, " b"]:
        """:meth:`log_likelihood` summed over each LOO block."""
        delta = theta - self.solution
        rss = (self.block_rr - 2.0 * self.block_xr @ delta
               + jnp.einsum("bij,i,j->b", self.block_gram, delta, delta))
        constant = 0.5 * self.block_count * _LOG_2PI
        if sd is None:
            return -0.5 * rss - self.block_log_sigma - constant
        return -0.5 * rss / sd**2 - self.block_count * jnp.log(sd) - constant
