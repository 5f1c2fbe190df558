"""A fit's ArviZ storage: its InferenceData and the log-likelihood per leave-one-out unit,
for any problem."""

from __future__ import annotations

import warnings

import numpy as np

from gyroid.inference._batching import in_chunks, problem_batcher
from gyroid.inference._posterior import Posterior
from gyroid.inference._problem import AbstractProblem
from gyroid.io._arviz import arviz


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
        return arviz().from_dict(
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
    blocks = problem_batcher(problem.density.log_likelihood_blocks)
    return in_chunks(blocks, flat, chunk).reshape(walkers, draws, -1)
