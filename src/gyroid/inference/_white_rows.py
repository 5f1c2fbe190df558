"""Two forms of a bench density under white noise that are computed once, on the host, before
it is sampled (each a typed part of :class:`~gyroid.inference.BenchDensity`, absent when it
does not apply):

* :class:`SufficientStatistics`: a linear model's likelihood on its rows' Gram matrix and
  least-squares solution (and the same per LOO block), so that an evaluation costs
  ``O(p^2)`` whatever the log's length (its coefficients integrate out on them:
  :class:`~gyroid.inference._collapsed.SufficientCoefficients`).
* :class:`ThermometerEigenbasis`: the thermometer's noise carried through dT/dt (errors in
  variables) as a covariance over the rows, in the eigenbasis of that covariance over the
  white part (one eigendecomposition; each evaluation is then ``O(n)``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.models._design import least_squares_from_r, with_rows

_LOG_2PI = math.log(2.0 * math.pi)

#: Rows of the weighted design and drift, block by block: (rows, X, y).
WeightedBlocks = Callable[[], Iterable[tuple[slice, np.ndarray, np.ndarray]]]


@dataclass(frozen=True)
class HostPrior:
    """The priors as normal densities on the sampling coordinates, in NumPy (``on`` 0 for
    a flat prior): what a host log-posterior adds."""

    loc: np.ndarray
    scale: np.ndarray
    on: np.ndarray

    @property
    def constant(self) -> float:
        """The normal densities' normalising constant."""
        return -float(np.sum(self.on * (np.log(self.scale) + 0.5 * _LOG_2PI)))

    def log_density(self, u: np.ndarray) -> np.ndarray:
        """The log prior less :attr:`constant` at each row of ``u``."""
        z = self.on * (u - self.loc) / self.scale
        return -0.5 * np.sum(z**2, axis=1)


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


class ThermometerEigenbasis(eqx.Module):
    """The thermometer's noise through dT/dt as a covariance over the rows (white noise, a
    model reading dT/dt; :mod:`gyroid.models._rate_error`): ``s^2 D0 + wD^2 M``, with ``M``
    the rate error's covariance ((degC/h)^2) and ``D0`` the white part per unit ``s^2`` (a
    row's known variance, ``s = 1``; else ``row_scale^2``). With ``A = D0^-1/2 M D0^-1/2 =
    V diag(lam) V'``, ``basis`` is ``W = V' D0^-1/2`` (the rows of held-out coordinates
    zero, ``on`` 0), so that ``r' C^-1 r = sum (W r)^2 / (s^2 + wD^2 lam)`` and
    ``log det C = sum log D0 + sum log(s^2 + wD^2 lam)``."""

    covariance: Float[Array, "n n"]  # M
    basis: Float[Array, "n n"]
    lam: Float[Array, " n"]
    on: Float[Array, " n"]
    log_d0: Float[Array, ""]
    y: Float[Array, " n"]  # W drift
    x: Float[Array, "n p"] | None  # W design (a linear model; None otherwise)
    index: int = eqx.field(static=True)  # wD among the parameters

    @classmethod
    def of(cls, covariance: np.ndarray, d0: np.ndarray, keep: np.ndarray, drift: np.ndarray,
           design: np.ndarray | None, index: int) -> ThermometerEigenbasis:
        """The eigenbasis of ``covariance`` (M) over the white part ``d0`` on the rows
        ``keep`` (a boolean mask; the others held out), with the drift and (a linear
        model) the design projected onto it."""
        n = drift.size
        root = 1.0 / np.sqrt(d0[keep])
        lam, vectors = np.linalg.eigh(root[:, None] * covariance[np.ix_(keep, keep)]
                                      * root[None, :])
        k = int(keep.sum())
        basis = np.zeros((n, n))
        basis[:k][:, keep] = vectors.T * root[None, :]
        lam_full, on = np.zeros(n), np.zeros(n)
        lam_full[:k], on[:k] = np.maximum(lam, 0.0), 1.0
        return cls(jnp.asarray(covariance), jnp.asarray(basis), jnp.asarray(lam_full),
                   jnp.asarray(on), jnp.asarray(float(np.sum(np.log(d0[keep])))),
                   jnp.asarray(basis @ drift),
                   None if design is None else jnp.asarray(basis @ design), index)

    def projected(self, theta: Float[Array, " p"], residual: Callable[[], Float[Array, " n"]]
                  ) -> Float[Array, " n"]:
        """The residual in the eigenbasis: from the projected design where the model is
        linear, else from ``residual()``, the rows' drift less the model's (called only
        then)."""
        if self.x is not None:
            return self.y - self.x @ theta
        return self.basis @ residual()

    def log_likelihood(self, projected: Float[Array, " n"], variance: Float[Array, " n"]
                       ) -> Float[Array, ""]:
        """The rows' log-likelihood from the projected residual and each coordinate's
        variance (``s^2 + wD^2 lam``)."""
        terms = self.on * (projected**2 / variance + jnp.log(variance) + _LOG_2PI)
        return -0.5 * (jnp.sum(terms) + self.log_d0)

    def leave_one_out_rows(self, projected: Float[Array, " n"], variance: Float[Array, " n"]
                           ) -> Float[Array, " n"]:
        """Each row's density given every other row (Burkner, Gabry & Vehtari 2021, for
        non-factorised normal models): with ``g = C^-1 r`` and ``c = diag(C^-1)``, row i's
        log density is ``-0.5 log 2pi + 0.5 log c_i - 0.5 g_i^2 / c_i``; 0 for a row left
        out."""
        inverse = self.on / variance
        g = self.basis.T @ (projected * inverse)
        c = (self.basis**2).T @ inverse
        safe = jnp.where(c > 0, c, 1.0)
        rows = -0.5 * _LOG_2PI + 0.5 * jnp.log(safe) - 0.5 * g**2 / safe
        return jnp.where(c > 0, rows, 0.0)

    def host_log_posterior(self, prior: HostPrior, known: bool
                           ) -> Callable[[np.ndarray], np.ndarray]:
        """The log-posterior of many walkers, ``u (w, d) -> (w,)``, in NumPy, under errors in
        variables (a linear model): what emcee and importance sampling call, a step a
        (w, p) x (p, n) product and no JAX dispatch. ``known``: the rows' sds are given
        (else the sampled coordinate after the coefficients is the white level's log)."""
        if self.x is None:
            raise ValueError("the host log-posterior needs a linear model's projected design")
        y, x = np.asarray(self.y), np.asarray(self.x)
        lam, on = np.asarray(self.lam), np.asarray(self.on)
        p, index = x.shape[1], self.index
        constant = (prior.constant - 0.5 * float(self.log_d0)
                    - 0.5 * float(on.sum()) * _LOG_2PI)

        def log_posterior(u: np.ndarray) -> np.ndarray:
            u = np.atleast_2d(np.asarray(u, dtype=float))
            projected = y[None, :] - u[:, :p] @ x.T
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                s2 = np.ones(u.shape[0]) if known else np.exp(2.0 * u[:, p])
                variance = s2[:, None] + (u[:, index] ** 2)[:, None] * lam[None, :]
                log_lik = -0.5 * np.sum(on * (projected**2 / variance + np.log(variance)),
                                        axis=1)
                value = log_lik + prior.log_density(u) + constant
            return np.where(np.isfinite(value), value, -np.inf)

        return log_posterior
