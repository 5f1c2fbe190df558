"""What a bench density computes once, on the host, before it is sampled: the sufficient
statistics of the linear-Gaussian fast path, the eigenbasis of the errors-in-variables
covariance, and the NumPy log-posterior emcee calls every step on them. Each takes and
returns a :class:`~gyroid.inference._bench_density.BenchDensity` (typed loosely: that module
imports this one)."""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from gyroid.models._design import least_squares_from_r, with_rows

_LOG_2PI = math.log(2.0 * math.pi)


def with_errors_in_variables(density: eqx.Module) -> eqx.Module:
    """The eigenbasis of the rate error's covariance over the white part, on the rows
    the likelihood reads (one eigendecomposition; each evaluation is then O(n))."""
    keep = (np.ones(density.n, dtype=bool) if density.weight is None
            else np.asarray(density.weight) > 0)
    d0 = np.asarray(density.white_d0())
    root = 1.0 / np.sqrt(d0[keep])
    cov = np.asarray(density.rate_error_cov)[np.ix_(keep, keep)]
    lam, vectors = np.linalg.eigh(root[:, None] * cov * root[None, :])
    k = int(keep.sum())
    basis = np.zeros((density.n, density.n))
    basis[:k][:, keep] = vectors.T * root[None, :]
    lam_full, on = np.zeros(density.n), np.zeros(density.n)
    lam_full[:k], on[:k] = np.maximum(lam, 0.0), 1.0
    y = basis @ np.asarray(density.drift)
    x = (basis @ np.asarray(density.model.design(density.inputs))
         if density.model.is_linear else None)
    return eqx.tree_at(
        lambda q: (q.eiv_basis, q.eiv_lambda, q.eiv_on, q.eiv_log_d0, q.eiv_y, q.eiv_x),
        density,
        (jnp.asarray(basis), jnp.asarray(lam_full), jnp.asarray(on),
         jnp.asarray(float(np.sum(np.log(d0[keep])))), jnp.asarray(y),
         None if x is None else jnp.asarray(x)),
        is_leaf=lambda q: q is None)


def with_sufficient_statistics(density: eqx.Module) -> eqx.Module:
    """The linear-Gaussian fast path: the Gram matrix and least-squares solution of the
    whole log and of each LOO block (about that solution, which keeps the block sums
    well conditioned). Two passes over the design in blocks of rows (its R factor,
    then the block sums): memory of one block, whatever the log's length."""
    y = np.asarray(density.drift)
    w = None if density.sigma is None else 1.0 / np.asarray(density.sigma)
    p = density.n_model

    def weighted_blocks():
        for rows, x in density.model.design_blocks(density.inputs):
            yield rows, (x, y[rows]) if w is None else (x * w[rows, None], y[rows] * w[rows])

    r = None
    for _, (xw, yw) in weighted_blocks():
        r = with_rows(r, np.column_stack([xw, yw]))
    solution, rss = least_squares_from_r(r)
    gram = r[:, :p].T @ r[:, :p]
    block = np.asarray(density.block)
    n_blocks = int(density.n_blocks)
    gram_b = np.zeros((n_blocks, p, p))
    xr_b = np.zeros((n_blocks, p))
    rr_b = np.zeros(n_blocks)
    for rows, (xw, yw) in weighted_blocks():
        r0 = yw - xw @ solution
        index = block[rows]
        for i in range(p):
            xr_b[:, i] += np.bincount(index, xw[:, i] * r0, n_blocks)
            for j in range(i, p):
                gram_b[:, i, j] += np.bincount(index, xw[:, i] * xw[:, j], n_blocks)
                gram_b[:, j, i] = gram_b[:, i, j]
        rr_b += np.bincount(index, r0**2, n_blocks)
    log_sigma = np.zeros_like(y) if density.sigma is None else np.log(np.asarray(density.sigma))
    return eqx.tree_at(
        lambda q: (q.gram, q.solution, q.rss_min, q.log_sigma_sum, q.block_gram,
                   q.block_xr, q.block_rr, q.block_count, q.block_log_sigma),
        density,
        (jnp.asarray(gram), jnp.asarray(solution), jnp.asarray(rss),
         jnp.asarray(float(np.sum(log_sigma))), jnp.asarray(gram_b), jnp.asarray(xr_b),
         jnp.asarray(rr_b), jnp.asarray(np.bincount(block, minlength=n_blocks).astype(float)),
         jnp.asarray(np.bincount(block, log_sigma, n_blocks))),
        is_leaf=lambda x: x is None,
    )


def host_log_posterior(density: eqx.Module):
    """The log-posterior of many walkers, ``u (w, d) -> (w,)``, in NumPy on the
    sufficient statistics: what emcee calls every step. For a linear model with white
    noise a step then costs a (w, p) x (p, p) product and no JAX dispatch, whose
    overhead had made gyroid's steps 1.7x dearer than a NumPy script's
    (benchmarks/run.py); None for other models."""
    if density.eiv_x is not None:
        return _eiv_host_log_posterior(density)
    if density.gram is None:
        return None
    gram, solution = np.asarray(density.gram), np.asarray(density.solution)
    rss_min, n, p = float(density.rss_min), density.n, density.n_model
    loc, scale = np.asarray(density.prior_loc), np.asarray(density.prior_scale)
    on = np.asarray(density.prior_on)
    constant = -float(np.sum(on * (np.log(scale) + 0.5 * _LOG_2PI))) - 0.5 * n * _LOG_2PI
    known = None if density.sigma is None else float(density.log_sigma_sum)

    def log_posterior(u: np.ndarray) -> np.ndarray:
        u = np.atleast_2d(np.asarray(u, dtype=float))
        delta = u[:, :p] - solution
        rss = rss_min + np.einsum("ki,ij,kj->k", delta, gram, delta)
        if known is not None:
            log_lik = -0.5 * rss - known
        else:
            log_sd = u[:, p] + math.log(density.row_scale)
            log_lik = -0.5 * rss * np.exp(-2.0 * log_sd) - n * log_sd
        z = on * (u - loc) / scale
        with np.errstate(over="ignore", invalid="ignore"):
            value = log_lik - 0.5 * np.sum(z**2, axis=1) + constant
        return np.where(np.isfinite(value), value, -np.inf)

    return log_posterior

def _eiv_host_log_posterior(density):
    """:func:`host_log_posterior` under errors in variables (a linear model): a step
    costs a (w, p) x (p, n) product."""
    y, x = np.asarray(density.eiv_y), np.asarray(density.eiv_x)
    lam, on = np.asarray(density.eiv_lambda), np.asarray(density.eiv_on)
    p, index, known = density.n_model, density.eiv_index, density.sigma is not None
    loc, scale = np.asarray(density.prior_loc), np.asarray(density.prior_scale)
    prior_on = np.asarray(density.prior_on)
    constant = (-float(np.sum(prior_on * (np.log(scale) + 0.5 * _LOG_2PI)))
                - 0.5 * float(density.eiv_log_d0) - 0.5 * float(on.sum()) * _LOG_2PI)

    def log_posterior(u: np.ndarray) -> np.ndarray:
        u = np.atleast_2d(np.asarray(u, dtype=float))
        projected = y[None, :] - u[:, :p] @ x.T
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            s2 = np.ones(u.shape[0]) if known else np.exp(2.0 * u[:, p])
            variance = s2[:, None] + (u[:, index] ** 2)[:, None] * lam[None, :]
            log_lik = -0.5 * np.sum(on * (projected**2 / variance + np.log(variance)),
                                    axis=1)
            z = prior_on * (u - loc) / scale
            value = log_lik - 0.5 * np.sum(z**2, axis=1) + constant
        return np.where(np.isfinite(value), value, -np.inf)

    return log_posterior
