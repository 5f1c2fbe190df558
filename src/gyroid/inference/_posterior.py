"""What a sampler gives (:class:`Posterior`), the interface every sampler has
(:class:`AbstractSampler`: emcee's and NUTS's), and the summaries and ArviZ storage shared
by every kind of fit."""

from __future__ import annotations

import abc
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyroid.inference._batching import in_chunks, problem_batcher
from gyroid.inference._checks import MAX_R_HAT, MIN_ESS
from gyroid.io._arviz import arviz

if TYPE_CHECKING:
    from gyroid.inference._problem import AbstractProblem, PointEstimate


@dataclass(frozen=True, eq=False)
class Posterior:
    """Posterior draws in natural units with their diagnostics."""

    names: tuple[str, ...]
    draws: np.ndarray = field(repr=False)  # (chains or walkers, draws, d) natural units
    log_posterior: np.ndarray = field(repr=False)  # (chains or walkers, draws)
    tau_steps: np.ndarray = field(repr=False)  # integrated autocorrelation time, steps
    n_steps: int
    burn: int
    thin: int
    acceptance: float
    method: str  # what sampled it: emcee's move and walkers, or NUTS's chains
    summary: dict[str, dict] = field(repr=False)  # per name: mean, sd, ci95, r_hat, ess_bulk
    divergent: int = 0  # NUTS's divergent transitions after warm-up
    move: str | None = None  # emcee's move ("de" or "stretch")

    def flat(self, name: str) -> np.ndarray:
        return self.draws[..., self.names.index(name)].reshape(-1)

    @property
    def converged(self) -> bool:
        return all(s["r_hat"] <= MAX_R_HAT and s["ess_bulk"] >= MIN_ESS
                   for s in self.summary.values())


class AbstractSampler(abc.ABC):
    """A way to sample a problem's posterior, started from its mode: :class:`~gyroid.
    inference.Emcee` or :class:`~gyroid.inference.Nuts`."""

    @abc.abstractmethod
    def sample(self, problem: AbstractProblem, point: PointEstimate, *, seed: int = 0,
               progress: Callable[[str], None] | None = None) -> Posterior:
        """Posterior draws of ``problem`` (natural units), from ``point``."""


def covariance_factor(covariance: np.ndarray) -> np.ndarray:
    """A lower-triangular factor of a mode's covariance, for drawing starting points: the
    Cholesky factor of its symmetric part, or its diagonal's square roots when it is not
    positive definite (a tiny isotropic one when it is not finite)."""
    covariance = np.asarray(covariance, dtype=float)
    d = covariance.shape[0]
    if not np.all(np.isfinite(covariance)):
        covariance = np.eye(d) * 1e-4
    covariance = 0.5 * (covariance + covariance.T) + 1e-12 * np.eye(d)
    try:
        return np.linalg.cholesky(covariance)
    except np.linalg.LinAlgError:
        return np.diag(np.sqrt(np.clip(np.diag(covariance), 1e-12, None)))


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


def interval_summary(values: np.ndarray) -> dict:
    """Mean, sd and central 95 % interval of draws of one derived quantity (no chains, so
    no r_hat or ESS: see :func:`summarise_draws` for sampled parameters)."""
    values = np.asarray(values, dtype=float).reshape(-1)
    lo, hi = np.percentile(values, [2.5, 97.5])
    return {"mean": float(np.mean(values)), "sd": float(np.std(values, ddof=1)),
            "ci95": [float(lo), float(hi)]}


def summarise_draws(draws: np.ndarray, names: tuple[str, ...]) -> dict[str, dict]:
    """Mean, sd, 95 % interval, r_hat and bulk ESS of each parameter of (chains, draws, d)
    natural-unit draws."""
    az = arviz()
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="More chains .* than draws")
        idata = az.from_dict(posterior={n: draws[..., i] for i, n in enumerate(names)})
        r_hat = az.rhat(idata)
        ess = az.ess(idata, method="bulk")
    out = {}
    for i, name in enumerate(names):
        values = draws[..., i].reshape(-1)
        lo, hi = np.percentile(values, [2.5, 97.5])
        out[name] = {
            "mean": float(values.mean()),
            "sd": float(values.std(ddof=1)),
            "ci95": [float(lo), float(hi)],
            "r_hat": float(r_hat[name]),
            "ess_bulk": float(ess[name]),
        }
    return out
