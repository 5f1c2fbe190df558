"""Posterior draws by Pareto-smoothed importance sampling (:class:`Importance`), with emcee
where that is not reliable: of a collapsed problem's noise levels (below), or of a whole
posterior where nothing integrates out (:func:`~gyroid.inference._marginal_target.
whole_posterior`: a white-noise bench fit, a roll log, a static log's noise terms), the same
proposals and stages with every coordinate a marginal one.

A drift model under correlated noise has its real coefficients integrated out exactly
(:mod:`gyroid.inference._collapsed`): what is left to integrate numerically is the
marginal posterior of the noise levels, three dimensions for IEEE 952 noise (two for a
Gauss-Markov bias), and of the model's positive parameters (a warm-up's time constant, a
step's time) where it has them (:mod:`gyroid.inference._marginal_target`; below, "noise
levels" stands for all of these). There an ensemble sampler spends most of its time on its own
correlation: a FOG bench's thermal fit ran 1213 emcee steps x 16 walkers (19 400
evaluations of the marginal, eight at a time) for some 800 effective draws. Importance
sampling evaluates its draws a thousand at a time, and its weights say themselves whether it
worked: Pareto smoothing's shape ``k`` (Vehtari, Simpson, Gelman, Yao & Gabry 2024,
"Pareto smoothed importance sampling", JMLR 25(72)) below 0.7 means the weighted draws'
averages are reliable, and their effective number (``1 / sum w^2`` of the smoothed,
normalised weights) is the posterior's effective sample size.

The first stage's 4000 draws come from an equal mixture of Student-t's (4 degrees of
freedom): two about the mode (its covariance doubled and times eight) and, for each noise
level with a prior, one with that level drawn from its prior and the others as about the
mode. The last are for a level the log does not resolve: where the likelihood stops
changing as the level falls (flicker, or a walk, too small to matter), the posterior keeps
the prior's lower tail beside the likelihood's bump, which the mode's curvature cannot
see. It can hold much of the mass: on a 20-minute log whose bias walks, 42 % of log K's
posterior lies in that tail (quadrature over the whole box of levels), where the flicker
explains the wander instead; emcee started at the mode missed it on two seeds of three.
While ``k > 0.7`` or fewer than ``MIN_ESS`` draws are effective, a further stage (at most
``stages`` in all) draws half its 4000 from Student-t kernels about 200 of the weighted
draws so far (resampled by weight; one scale matrix, their weighted covariance times
Silverman's factor squared), which follows a posterior of several parts, and half from the
first stage's mixture; every draw is reweighed against the stages' mixture (adaptive
multiple importance sampling: Cornuet, Marin, Mira & Robert 2012, Scand. J. Stat. 39(4)).
Where the last stage still fails the problem goes to ``fallback`` (emcee, run as usual),
and the result says which ran.

Why stages of 4000, when a first stage keeps only some 15-25 % of its draws effective:
smaller ones were measured on the quadrature test's log (``tests/test_importance.py``; a
posterior of two parts, 12 seeds, the worst of each coordinate's mean and sd errors in
their standard errors). Stages of 4000: worst 2.7, after 12 000-24 000 draws. A first stage
of 1000, then 1000 a stage: 3 seeds of 12 stopped after 2000 draws with weights that called
themselves reliable (k 0.37-0.66, 400 effective) and errors of 14-20 standard errors (the
walk's tail, where w1 is wide, unvisited). 2000, then 1000 a stage: errors of 5.2 and 6.0
on 2 seeds, the many small adapted stages' weights overstating their effective number. A
first stage of 2000, then stages of 4000: 2 seeds of 6 stopped after the first stage (k
0.49 and 0.57) with errors of 17 standard errors. On easy posteriors (paper A's bench, two
FOG benches) the smaller stages had saved 15-30 % of a fit. Where the first stage's draws
go on paper A's bench (seeds 0 and 1): the part about the mode with the doubled covariance
keeps 40-44 % of its draws effective, the one times eight 10-11 %, the flicker's and the
walk's prior-tail parts 34-39 % (those levels' posterior is near their prior), and the
white level's prior-tail part under 1 % (the log resolves it: 0.4 % of the posterior's
mass is that part's), a fifth of the stage; leaving a level's tail part out needs a test
that the log resolves that level which also sees what the mode's curvature cannot (the
walked log's K above).

Kept draws: ``MAX_STORED_SAMPLES`` resampled by the smoothed weights (systematic
resampling, then shuffled into four chains), each with its coefficients drawn afresh
from their exact Gaussian given its noise levels. A noise level's draw may repeat;
its effective sample size is reported as at most the weights' effective number.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from gyroid.inference._batching import in_chunks
from gyroid.inference._checks import MIN_ESS
from gyroid.inference._collapsed import conditional_draws
from gyroid.inference._emcee import MAX_STORED_SAMPLES, Emcee
from gyroid.inference._marginal_target import MarginalTarget
from gyroid.inference._posterior import Posterior, summarise_draws
from gyroid.inference._problem import AbstractProblem, AbstractSampler, PointEstimate
from gyroid.inference._proposals import Blend, Kernels, StudentMixture
from gyroid.io._arviz import load_arviz

#: Pareto shape above which importance sampling's averages are not trusted (PSIS paper).
MAX_PARETO_K = 0.7
#: Chains the kept draws are dealt into (for r_hat; they are independent draws).
_CHAINS = 4
#: Marginal log-posteriors evaluated this many at a time (one compiled program per log
#: shape: whoever else evaluates a target's draws uses the same, :mod:`._allowed_noise`),
#: the chunks side by side on the cores (:func:`~gyroid.inference._batching.in_chunks`):
#: half the noise priors' check's 1000 levels a chunk, so its two run at once.
BATCH = 500
#: Kernels of an adapted stage's proposal.
KERNELS = 200


@dataclass(frozen=True)
class Importance(AbstractSampler):
    """Pareto-smoothed importance sampling of a problem's marginal target (a collapsed
    problem's noise levels, or a whole posterior) from Student-t's about the mode and the
    levels' priors, adapted in stages (module docstring); ``fallback`` for a problem with
    no target and wherever the smoothed weights stay unreliable."""

    n_draws: int = 4000
    df: float = 4.0  # the proposal's degrees of freedom
    #: the first stage: an equal mixture of Student-t's, scale matrices the mode's
    #: covariance times these, and one per noise level with a prior, that level drawn from
    #: its prior (module docstring)
    inflation: tuple[float, ...] = (2.0, 8.0)
    stages: int = 8  # proposal stages at most (each n_draws), the later ones adapted
    fallback: AbstractSampler = field(default_factory=lambda: Emcee(progress=False))

    def sample(self, problem: AbstractProblem, point: PointEstimate, *, seed: int = 0,
               progress: Callable[[str], None] | None = None) -> Posterior:
        rng = np.random.default_rng(seed)
        target = problem.marginal_target()
        if target is None:
            return self.fallback.sample(problem, point, seed=seed, progress=progress)
        if not target.marginal.size:  # nothing to weigh: the coefficients' exact Gaussian
            return self._posterior(problem, target, _exact(target.solved), rng)
        # the mode's marginal coordinates and their covariance
        at = target.marginal
        mode = (np.asarray(point.u, dtype=float)[at],
                np.asarray(point.covariance_u, dtype=float)[np.ix_(at, at)])
        weighted = self._weighted(mode, target.solved, target.tails, rng)
        if weighted is None:
            return self.fallback.sample(problem, point, seed=seed, progress=progress)
        return self._posterior(problem, target, weighted, rng)

    def _weighted(self, mode: tuple[np.ndarray, np.ndarray],
                  solved: Callable[[np.ndarray], np.ndarray],
                  tails: list[tuple[int, float, float]], rng: np.random.Generator
                  ) -> _Weighted | None:
        """The proposals, their smoothed log-weights, Pareto k and effective number; None
        when the mode gives no proposal or the weights stay unreliable (module docstring)."""
        try:
            first = self._first_stage(*mode, tails)
        except (ValueError, np.linalg.LinAlgError):
            return None
        stages: list = [first]
        draws, rows = np.zeros((0, mode[0].size)), None
        densities: list[np.ndarray] = [np.zeros(0)]  # each stage's log-density at the draws
        for _ in range(self.stages):
            new = stages[-1].draw(self.n_draws, rng)
            draws = np.concatenate([draws, new])
            # the marginal and the coefficients' conditional at each draw, one filter pass
            new_rows = in_chunks(solved, new, BATCH)
            rows = new_rows if rows is None else np.concatenate([rows, new_rows])
            log_target = rows[:, 0]
            # every draw weighed against the stages' mixture (deterministic mixture weights);
            # each stage's density is computed once at each draw
            densities = [np.concatenate([d, m.log_pdf(new)]) if d.size else m.log_pdf(draws)
                         for d, m in zip(densities, stages, strict=True)]
            log_proposal = np.logaddexp.reduce(densities, axis=0)
            weighted = _smoothed(draws, rows, log_target - log_proposal - np.log(len(stages)))
            if weighted is None:
                return None
            if weighted.pareto_k <= MAX_PARETO_K and weighted.effective >= MIN_ESS:
                return weighted
            try:
                stages.append(Blend((0.5, 0.5), (_kernels(weighted, self.df, rng), first)))
                densities.append(np.zeros(0))
            except (ValueError, np.linalg.LinAlgError):
                return None
        return None

    def _first_stage(self, centre: np.ndarray, covariance: np.ndarray,
                     tails: list[tuple[int, float, float]]
                     ) -> StudentMixture:
        """Student-t's about the mode and, per noise level with a prior, that level from
        its prior and the others as about the mode."""
        if not np.all(np.isfinite(covariance)) or not np.all(np.isfinite(centre)):
            raise ValueError("no finite mode")
        components = [(1.0, centre, scale * covariance) for scale in self.inflation]
        for level, loc, scale in tails:
            shape = self.inflation[0] * covariance
            shape[level, :] = shape[:, level] = 0.0
            shape[level, level] = scale**2
            start = centre.copy()
            start[level] = loc
            components.append((1.0, start, shape))
        return StudentMixture.of(components, self.df)

    def _posterior(self, problem: AbstractProblem, target: MarginalTarget,
                   weighted: _Weighted, rng: np.random.Generator) -> Posterior:
        kept = MAX_STORED_SAMPLES - MAX_STORED_SAMPLES % _CHAINS
        index = rng.permutation(_systematic(weighted.weights, kept, rng))
        z = rng.standard_normal((kept, target.real.size))
        beta, lp = conditional_draws(weighted.solved[index], z)
        draws_u = target.assemble(beta, weighted.draws[index]).reshape(
            _CHAINS, kept // _CHAINS, -1)
        natural = problem.to_natural_host(draws_u)
        summary = summarise_draws(natural, problem.names)
        for entry in summary.values():
            entry["ess_bulk"] = min(entry["ess_bulk"], weighted.effective)
        lp = lp.reshape(_CHAINS, -1)
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
            method=(f"importance sampling of the {target.describe} (PSIS, Pareto k "
                    f"{weighted.pareto_k:.2f}, {n} draws in {n // self.n_draws} stage(s) of "
                    f"Student-t's, {weighted.effective:.0f} effective)"
                    + ("; coefficients exact given each" if target.real.size else "")
                    if target.marginal.size else
                    "exact draws of the coefficients' Gaussian posterior (every row's sd "
                    "given: nothing to weigh)"),
            summary=summary,
            move="psis",
            evaluated=(weighted.draws, weighted.solved),
        )


def _exact(solved: Callable[[np.ndarray], np.ndarray]) -> _Weighted:
    """The one "draw" of a target with no marginal coordinate (a linear model whose rows'
    sds are all given): its coefficients' Gaussian, weight 1; the kept draws are then
    independent draws of it."""
    at = np.zeros((1, 0))
    return _Weighted(at, np.asarray(solved(at)), np.ones(1), -np.inf,
                     float(MAX_STORED_SAMPLES))


def _kernels(weighted: _Weighted, df: float, rng: np.random.Generator) -> Kernels:
    """Student-t kernels about ``KERNELS`` draws resampled by their weights, sharing the
    weighted draws' covariance scaled by Silverman's factor squared."""
    d = weighted.draws.shape[1]
    centres = weighted.draws[_systematic(weighted.weights, KERNELS, rng)]
    spread = np.cov(weighted.draws.T, aweights=weighted.weights, bias=True).reshape(d, d)
    bandwidth = (4.0 / (d + 2.0)) ** (1.0 / (d + 4.0)) * KERNELS ** (-1.0 / (d + 4.0))
    return Kernels(centres, np.linalg.cholesky(bandwidth**2 * spread), df)


def _smoothed(draws: np.ndarray, solved: np.ndarray, log_weight: np.ndarray
              ) -> _Weighted | None:
    """Pareto-smoothed, normalised weights (ArviZ's psislw) with their shape k and
    effective number; None when fewer than half the draws have a finite weight."""
    finite = np.isfinite(log_weight)
    if finite.sum() < log_weight.size // 2:
        return None
    floor = np.min(log_weight[finite]) - 1e3  # a zero weight, in what PSIS accepts
    # ArviZ's tail fit weighs its grid of shapes by 1 / sum(exp(differences)); where
    # those overflow the weight's limit, 0, is what it gets: the warning says nothing
    with np.errstate(over="ignore"):
        smoothed, pareto_k = load_arviz().psislw(np.where(finite, log_weight, floor))
    w = np.where(finite, np.exp(smoothed - np.max(smoothed)), 0.0)
    w /= w.sum()
    return _Weighted(draws, solved, w, float(pareto_k), float(1.0 / np.sum(w**2)))


@dataclass(frozen=True)
class _Weighted:
    draws: np.ndarray  # (n, k) sampling coordinates of the noise levels
    #: (n, 1+p+p^2) their marginal log-posterior, then the coefficients' conditional
    #: (:meth:`~gyroid.inference._collapsed.CollapsedCoefficients.solved`)
    solved: np.ndarray
    weights: np.ndarray  # (n,) smoothed, normalised
    pareto_k: float
    effective: float


def _systematic(weights: np.ndarray, m: int, rng: np.random.Generator) -> np.ndarray:
    """``m`` indices drawn in proportion to ``weights`` by systematic resampling (one
    uniform offset: the least variance among unbiased schemes)."""
    positions = (rng.uniform() + np.arange(m)) / m
    return np.minimum(np.searchsorted(np.cumsum(weights), positions), weights.size - 1)
