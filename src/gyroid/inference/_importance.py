"""Posterior draws of a collapsed problem by Pareto-smoothed importance sampling
(:class:`Importance`), with emcee where that is not reliable.

A linear drift model under correlated noise has its coefficients integrated out exactly
(:mod:`gyroid.inference._collapsed`): what is left to integrate numerically is the
marginal posterior of the noise levels, three dimensions for IEEE 952 noise (two for a
Gauss-Markov bias). There an ensemble sampler spends most of its time on its own
correlation: a FOG bench's thermal fit ran 1213 emcee steps x 16 walkers (19 400
evaluations of the marginal, eight at a time) for some 800 effective draws. Importance
sampling from Student-t's about the mode (4 degrees of freedom; an equal mixture of the
mode's covariance doubled and times eight, whose wider half keeps the weights bounded
where the posterior is not the mode's Gaussian: a level the log does not resolve keeps its
prior's lower tail and meets a cliff above, or two levels trade off along a bent ridge)
needs 4000 evaluations, hundreds at a time, and its weights say themselves whether it
worked: Pareto smoothing's shape ``k`` (Vehtari, Simpson, Gelman, Yao & Gabry 2024,
"Pareto smoothed importance sampling", JMLR 25(72)) below 0.7 means the weighted draws'
averages are reliable, and their effective number (``1 / sum w^2`` of the smoothed,
normalised weights) is the posterior's effective sample size. Where ``k > 0.7`` or fewer
than ``MIN_ESS`` draws are effective (a posterior far from the mode's Gaussian: a bimodal
or strongly bent one) the problem goes to ``fallback`` (emcee, run as usual), and the
result says which ran.

Kept draws: ``MAX_STORED_SAMPLES`` resampled by the smoothed weights (systematic
resampling, then shuffled into four chains), each with its coefficients drawn afresh
from their exact Gaussian given its noise levels. A noise level's draw may repeat;
its effective sample size is reported as at most the weights' effective number.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from gyroid.inference._batching import in_chunks
from gyroid.inference._checks import MIN_ESS
from gyroid.inference._emcee import MAX_STORED_SAMPLES, Emcee, Walked
from gyroid.inference._posterior import Posterior, summarise_draws
from gyroid.inference._problem import AbstractProblem, AbstractSampler, PointEstimate
from gyroid.io._arviz import arviz

#: Pareto shape above which importance sampling's averages are not trusted (PSIS paper).
MAX_PARETO_K = 0.7
#: Chains the kept draws are dealt into (for r_hat; they are independent draws).
_CHAINS = 4
#: Marginal log-posteriors evaluated this many at a time.
_BATCH = 250


@dataclass(frozen=True)
class Importance(AbstractSampler):
    """Pareto-smoothed importance sampling of a collapsed problem's noise levels from a
    Student-t about the mode (module docstring); ``fallback`` for any other problem and
    wherever the smoothed weights are not reliable."""

    n_draws: int = 4000
    df: float = 4.0  # the proposal's degrees of freedom
    #: the proposal: an equal mixture of Student-t's, scale matrices the mode's covariance
    #: times these
    inflation: tuple[float, ...] = (2.0, 8.0)
    fallback: AbstractSampler = field(default_factory=lambda: Emcee(progress=False))

    def sample(self, problem: AbstractProblem, point: PointEstimate, *, seed: int = 0,
               progress: Callable[[str], None] | None = None) -> Posterior:
        rng = np.random.default_rng(seed)
        if problem.collapsed() is None:
            return self.fallback.sample(problem, point, seed=seed, progress=progress)
        walked = Walked.of(problem, point, rng, chunk=_BATCH)
        weighted = self._weighted(walked, rng)
        if weighted is None:
            return self.fallback.sample(problem, point, seed=seed, progress=progress)
        return self._posterior(problem, walked, weighted, rng)

    def _weighted(self, walked: Walked, rng: np.random.Generator) -> _Weighted | None:
        """The proposals, their smoothed log-weights, Pareto k and effective number; None
        when the mode gives no proposal or the weights are not reliable."""
        covariance = np.asarray(walked.covariance, dtype=float)
        if not np.all(np.isfinite(covariance)) or not np.all(np.isfinite(walked.start)):
            return None
        try:
            parts = [stats.multivariate_t(loc=walked.start, shape=scale * covariance,
                                          df=self.df) for scale in self.inflation]
        except (ValueError, np.linalg.LinAlgError):
            return None
        counts = rng.multinomial(self.n_draws, np.full(len(parts), 1.0 / len(parts)))
        k = walked.start.size
        draws = np.concatenate([part.rvs(size=m, random_state=rng).reshape(m, k)
                                for part, m in zip(parts, counts, strict=True) if m])
        log_proposal = np.logaddexp.reduce([part.logpdf(draws) for part in parts], axis=0)
        log_target = in_chunks(walked.batch, draws, _BATCH)
        log_weight = log_target - log_proposal
        finite = np.isfinite(log_weight)
        if finite.sum() < self.n_draws // 2:
            return None
        floor = np.min(log_weight[finite]) - 1e3  # a zero weight, in what PSIS accepts
        smoothed, pareto_k = arviz().psislw(np.where(finite, log_weight, floor))
        w = np.where(finite, np.exp(smoothed - np.max(smoothed)), 0.0)
        w /= w.sum()
        effective = float(1.0 / np.sum(w**2))
        if not float(pareto_k) <= MAX_PARETO_K or effective < MIN_ESS:
            return None
        return _Weighted(draws, log_target, w, float(pareto_k), effective)

    def _posterior(self, problem: AbstractProblem, walked: Walked, weighted: _Weighted,
                   rng: np.random.Generator) -> Posterior:
        kept = MAX_STORED_SAMPLES - MAX_STORED_SAMPLES % _CHAINS
        index = rng.permutation(_systematic(weighted.weights, kept, rng))
        noise = weighted.draws[index].reshape(_CHAINS, kept // _CHAINS, -1)
        draws_u = walked.full(noise)
        natural = problem.to_natural_host(draws_u)
        summary = summarise_draws(natural, problem.names)
        for entry in summary.values():
            entry["ess_bulk"] = min(entry["ess_bulk"], weighted.effective)
        lp = walked.log_posterior(draws_u, weighted.log_target[index].reshape(_CHAINS, -1))
        return Posterior(
            names=problem.names,
            draws=natural,
            log_posterior=lp,
            tau_steps=np.ones(len(problem.names)),
            n_steps=self.n_draws,
            burn=0,
            thin=1,
            acceptance=weighted.effective / self.n_draws,
            method=(f"importance sampling of the noise levels (PSIS, Pareto k "
                    f"{weighted.pareto_k:.2f}, {self.n_draws} draws from Student-t's about the"
                    f" mode, {weighted.effective:.0f} effective); coefficients exact given each"),
            summary=summary,
            move="psis",
        )


@dataclass(frozen=True)
class _Weighted:
    draws: np.ndarray  # (n, k) sampling coordinates of the noise levels
    log_target: np.ndarray  # (n,) their marginal log-posterior
    weights: np.ndarray  # (n,) smoothed, normalised
    pareto_k: float
    effective: float


def _systematic(weights: np.ndarray, m: int, rng: np.random.Generator) -> np.ndarray:
    """``m`` indices drawn in proportion to ``weights`` by systematic resampling (one
    uniform offset: the least variance among unbiased schemes)."""
    positions = (rng.uniform() + np.arange(m)) / m
    return np.minimum(np.searchsorted(np.cumsum(weights), positions), weights.size - 1)
