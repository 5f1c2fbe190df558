"""Posterior draws of a collapsed problem by Pareto-smoothed importance sampling
(:class:`Importance`), with emcee where that is not reliable.

A linear drift model under correlated noise has its coefficients integrated out exactly
(:mod:`gyroid.inference._collapsed`): what is left to integrate numerically is the
marginal posterior of the noise levels, three dimensions for IEEE 952 noise (two for a
Gauss-Markov bias). There an ensemble sampler spends most of its time on its own
correlation: a FOG bench's thermal fit ran 1213 emcee steps x 16 walkers (19 400
evaluations of the marginal, eight at a time) for some 800 effective draws. Importance
sampling evaluates its draws hundreds at a time, and its weights say themselves whether it
worked: Pareto smoothing's shape ``k`` (Vehtari, Simpson, Gelman, Yao & Gabry 2024,
"Pareto smoothed importance sampling", JMLR 25(72)) below 0.7 means the weighted draws'
averages are reliable, and their effective number (``1 / sum w^2`` of the smoothed,
normalised weights) is the posterior's effective sample size.

The first stage's 4000 draws come from Student-t's about the mode (4 degrees of freedom;
an equal mixture of the mode's covariance doubled and times eight). A marginal that is not
the mode's Gaussian needs more: a level the log does not resolve keeps its prior's lower
tail beside the likelihood's bump (a FOG log's flicker: log B's mode at -4.8 with a
curvature sd of 0.36, its posterior sd 2.4), or meets a cliff above. While ``k > 0.7`` or
fewer than ``MIN_ESS`` draws are effective, a further stage (at most ``stages`` in all)
draws half its 4000 about the weighted mean and twice the weighted covariance of every
draw so far and half about the mode as before, and every draw is reweighed against the
stages' mixture (adaptive multiple importance sampling, Cornuet, Marin, Mira & Robert
2012, Scand. J. Stat. 39(4)). Where the last stage still fails (a bimodal posterior, say)
the problem goes to ``fallback`` (emcee, run as usual), and the result says which ran.

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
    stages: int = 4  # proposal stages at most (each n_draws), the later ones adapted
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
        when the mode gives no proposal or the weights stay unreliable (module docstring:
        each further stage proposes half of its draws about the weighted draws so far)."""
        covariance = np.asarray(walked.covariance, dtype=float)
        if not np.all(np.isfinite(covariance)) or not np.all(np.isfinite(walked.start)):
            return None
        about_mode = [(1.0 / len(self.inflation), walked.start, scale * covariance)
                      for scale in self.inflation]
        try:
            stages = [_Mixture.of(about_mode, self.df)]
        except (ValueError, np.linalg.LinAlgError):
            return None
        draws, log_target = np.zeros((0, walked.start.size)), np.zeros(0)
        for _ in range(self.stages):
            new = stages[-1].draw(self.n_draws, rng)
            draws = np.concatenate([draws, new])
            log_target = np.concatenate([log_target, in_chunks(walked.batch, new, _BATCH)])
            # every draw weighed against the stages' mixture (deterministic mixture weights)
            log_proposal = np.logaddexp.reduce([m.log_pdf(draws) for m in stages], axis=0)
            weighted = _smoothed(draws, log_target, log_target - log_proposal
                                 - np.log(len(stages)))
            if weighted is None:
                return None
            if weighted.pareto_k <= MAX_PARETO_K and weighted.effective >= MIN_ESS:
                return weighted
            spread = np.cov(draws.T, aweights=weighted.weights, bias=True).reshape(
                covariance.shape)
            try:
                stages.append(_Mixture.of([(0.5, weighted.weights @ draws, 2.0 * spread)]
                                          + [(0.5 * p, m, c) for p, m, c in about_mode],
                                          self.df))
            except (ValueError, np.linalg.LinAlgError):
                return None
        return None

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
        n = weighted.draws.shape[0]
        return Posterior(
            names=problem.names,
            draws=natural,
            log_posterior=lp,
            tau_steps=np.ones(len(problem.names)),
            n_steps=n,
            burn=0,
            thin=1,
            acceptance=weighted.effective / n,
            method=(f"importance sampling of the noise levels (PSIS, Pareto k "
                    f"{weighted.pareto_k:.2f}, {n} draws in {n // self.n_draws} stage(s) of "
                    f"Student-t's, {weighted.effective:.0f} effective); coefficients exact "
                    "given each"),
            summary=summary,
            move="psis",
        )


@dataclass(frozen=True)
class _Mixture:
    """A mixture of multivariate Student-t's (weight, location, scale matrix)."""

    weights: np.ndarray
    parts: list

    @classmethod
    def of(cls, components: list[tuple[float, np.ndarray, np.ndarray]], df: float
           ) -> _Mixture:
        return cls(np.array([w for w, _, _ in components]),
                   [stats.multivariate_t(loc=m, shape=c, df=df) for _, m, c in components])

    def draw(self, n: int, rng: np.random.Generator) -> np.ndarray:
        counts = rng.multinomial(n, self.weights / self.weights.sum())
        k = self.parts[0].loc.size
        return np.concatenate([part.rvs(size=m, random_state=rng).reshape(m, k)
                               for part, m in zip(self.parts, counts, strict=True) if m])

    def log_pdf(self, x: np.ndarray) -> np.ndarray:
        return np.logaddexp.reduce([np.log(w) + part.logpdf(x)
                                    for w, part in zip(self.weights, self.parts, strict=True)],
                                   axis=0)


def _smoothed(draws: np.ndarray, log_target: np.ndarray, log_weight: np.ndarray
              ) -> _Weighted | None:
    """Pareto-smoothed, normalised weights (ArviZ's psislw) with their shape k and
    effective number; None when fewer than half the draws have a finite weight."""
    finite = np.isfinite(log_weight)
    if finite.sum() < log_weight.size // 2:
        return None
    floor = np.min(log_weight[finite]) - 1e3  # a zero weight, in what PSIS accepts
    smoothed, pareto_k = arviz().psislw(np.where(finite, log_weight, floor))
    w = np.where(finite, np.exp(smoothed - np.max(smoothed)), 0.0)
    w /= w.sum()
    return _Weighted(draws, log_target, w, float(pareto_k), float(1.0 / np.sum(w**2)))


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
