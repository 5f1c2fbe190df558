"""A fit's ArviZ storage: its InferenceData and the log-likelihood per leave-one-out unit,
for any problem."""

from __future__ import annotations

import warnings
from typing import Protocol, runtime_checkable

import equinox as eqx
import jax
import numpy as np
from jaxtyping import Array, Float

from gyroid.inference._batching import in_chunks, problem_batcher
from gyroid.inference._collapsed import CollapsedCoefficients
from gyroid.inference._posterior import Posterior
from gyroid.inference._problem import AbstractProblem
from gyroid.io._arviz import load_arviz


@runtime_checkable
class BlockedDensity(Protocol):
    """A density whose log-likelihood is a sum over blocks of rows, the units leave-one-out
    leaves out (a pool's runs are drawn with the population mean: it passes its own)."""

    def log_likelihood_blocks(self, u: Float[Array, " d"]) -> Float[Array, " b"]: ...


def inference_data(problem: AbstractProblem, posterior: Posterior, *,
                   log_likelihood: dict[str, np.ndarray] | None = None,
                   extra_posterior: dict[str, np.ndarray] | None = None,
                   coords: dict | None = None, dims: dict | None = None):
    """ArviZ InferenceData of a fit: the posterior, a log-likelihood per LOO unit (by
    default the problem's blocks of rows, computed here), observed and constant data,
    sample stats and the problem's attributes (its ``observed_data``, ``constant_data``
    and ``idata_attrs``)."""
    if log_likelihood is None:
        log_likelihood = {next(iter(problem.observed_data())): block_log_likelihood(
            problem, posterior)}
    observed, constant = problem.observed_data(), problem.constant_data()
    names = problem.names
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="More chains .* than draws")
        return load_arviz().from_dict(
            posterior={n: posterior.draws[..., i] for i, n in enumerate(names)}
            | (extra_posterior or {}),
            log_likelihood=log_likelihood,
            observed_data=observed,
            constant_data=constant,
            sample_stats={"lp": posterior.log_posterior},
            coords=coords,
            dims=(dims if dims is not None else
                  {**{k: ["row"] for k in log_likelihood}, **{k: ["row"] for k in constant}}),
            attrs={**problem.idata_attrs(), "sampler": posterior.method},
        )


def block_log_likelihood(problem: AbstractProblem, posterior: Posterior, chunk: int = 256
                         ) -> np.ndarray:
    """The problem's block log-likelihoods at every draw: (chains, draws, blocks)."""
    walkers, draws, d = posterior.draws.shape
    flat = np.asarray(problem.to_sampling_host(posterior.draws.reshape(-1, d)))
    collapsed = problem.collapsed()
    if isinstance(collapsed, CollapsedCoefficients):  # a linear model, correlated noise
        return _by_noise_level(problem.density, collapsed, flat, chunk).reshape(
            walkers, draws, -1)
    density = problem.density
    if not isinstance(density, BlockedDensity):
        raise TypeError(f"{type(density).__name__} has no blocks of rows: pass the fit's "
                        "log_likelihood to inference_data")
    blocks = problem_batcher(density.log_likelihood_blocks)
    return in_chunks(blocks, flat, chunk).reshape(walkers, draws, -1)


def _by_noise_level(density, collapsed, flat: np.ndarray, chunk: int) -> np.ndarray:
    """:meth:`log_likelihood_blocks` of a linear model under correlated noise at the draws
    ``flat`` (coefficients, then noise levels, sampling coordinates), one filter pass per
    distinct noise level (an importance posterior repeats them) instead of one per draw:
    the residual's innovations are the drift's less the design's times the coefficients.
    The same numbers to rounding (tests/test_importance.py)."""
    p = density.n_model
    levels, which = np.unique(flat[:, p:], axis=0, return_inverse=True)
    filtered = in_chunks(problem_batcher(collapsed.filtered), levels, chunk)  # (u, n, 2+p)
    weight = np.asarray(collapsed.row_filter.weight)
    member = np.zeros((weight.size, int(density.n_blocks)))
    member[np.arange(weight.size), np.asarray(density.block)] = 1.0
    out = np.empty((flat.shape[0], member.shape[1]))
    for start in range(0, flat.shape[0], chunk):
        rows = slice(start, start + chunk)
        own = filtered[which[rows]]
        innovation = own[..., 0] - np.einsum("mnp,mp->mn", own[..., 1:1 + p], flat[rows, :p])
        log_lik = np.asarray(_rows_of(collapsed.row_filter, innovation, own[..., -1]))
        out[rows] = (log_lik * weight) @ member
    return out


@eqx.filter_jit
def _rows_of(row_filter, innovation, variance):
    """Each draw's rows' log-likelihoods from their innovations (:meth:`~gyroid.noise.
    RowFilter.rows_of`: the rows' own, also where the innovations are not in time order)."""
    return jax.vmap(row_filter.rows_of)(innovation, variance)
