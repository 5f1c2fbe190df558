"""Posterior sampling with emcee (:class:`Emcee`).

Walkers start from the mode's Gaussian approximation; the run is extended in chunks until it
is at least ``tau_factor`` integrated autocorrelation times long and every parameter has
``ess_bulk >= min_ess`` and ``r_hat <= max_r_hat`` (ArviZ, over walkers), or until
``max_steps``. After the first chunk each chunk is sized from the current autocorrelation
time to reach ``tau_factor`` times it, so few checks are needed. The log-posterior is the
problem's density, jit-compiled and vmapped over walkers (``vectorize=True``), or its NumPy
form where that is cheaper (a linear model with white noise: sufficient statistics).

The default move is emcee's differential-evolution move (``DEMove``): on the nearly
Gaussian, correlated posteriors of drift models its autocorrelation time is about a third
of the stretch move's (8 parameters, 32 walkers: ~26 steps against ~90), for the same
cost per step. ``Emcee(move="stretch")`` gives emcee's default.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import emcee
import numpy as np
from tqdm.auto import tqdm

from gyroid.inference._batching import problem_batcher
from gyroid.inference._checks import MAX_R_HAT, MIN_ESS
from gyroid.inference._posterior import (
    AbstractSampler,
    Posterior,
    covariance_factor,
    summarise_draws,
)
from gyroid.inference._problem import AbstractProblem, PointEstimate

#: Cap on the draws kept (walkers x draws) after thinning.
MAX_STORED_SAMPLES = 2000


@dataclass(frozen=True)
class Emcee(AbstractSampler):
    """emcee's ensemble sampler, run until it has converged (see the module docstring)."""

    n_walkers: int | None = None  # default: max(32, 4 * dimension), even
    burn_steps: int = 300
    chunk_steps: int = 500
    tau_factor: float = 50.0
    min_ess: float = MIN_ESS
    max_r_hat: float = MAX_R_HAT
    max_steps: int = 30000
    move: str = "de"  # "de" (differential evolution) or "stretch" (emcee's default)
    progress: bool = True  # a progress bar on stderr

    def emcee_moves(self):
        """The emcee move object for ``move``."""
        if self.move == "de":
            return emcee.moves.DEMove()
        if self.move == "stretch":
            return emcee.moves.StretchMove()
        raise ValueError(f"unknown move {self.move!r}: use 'de' or 'stretch'")

    def description(self, n_walkers: int) -> str:
        return f"emcee {emcee.__version__}, {self.move} move, {n_walkers} walkers"

    def sample(self, problem: AbstractProblem, point: PointEstimate, *, seed: int = 0,
               progress: Callable[[str], None] | None = None) -> Posterior:
        """Sample ``problem``'s posterior from ``point`` (see the module docstring)."""
        return _sample(problem, point, self, seed)


def _initial_walkers(batch, point: PointEstimate, n_walkers: int,
                     rng: np.random.Generator) -> np.ndarray:
    d = point.u.size
    factor = covariance_factor(point.covariance_u)
    walkers = point.u + rng.standard_normal((n_walkers, d)) @ factor.T
    half = n_walkers // 2  # emcee evaluates half the ensemble at a time: one compilation
    for _ in range(20):
        lp = np.concatenate([np.asarray(batch(walkers[:half])), np.asarray(batch(walkers[half:]))])
        bad = ~np.isfinite(lp)
        if not bad.any():
            break
        walkers[bad] = point.u + 0.1 * rng.standard_normal((bad.sum(), d)) @ factor.T
    return walkers


def _sample(problem: AbstractProblem, point: PointEstimate, settings: Emcee, seed: int
            ) -> Posterior:
    rng = np.random.default_rng(seed)
    d = point.u.size
    n_walkers = settings.n_walkers or max(32, 4 * d)
    n_walkers += n_walkers % 2

    # A linear-Gaussian problem's log-posterior runs on the host (NumPy on its sufficient
    # statistics): cheaper per emcee step than a call into JAX.
    batch = problem.host_log_posterior() or problem_batcher(problem.density.log_posterior)

    def log_prob(u: np.ndarray) -> np.ndarray:
        return np.asarray(batch(u))

    sampler = emcee.EnsembleSampler(n_walkers, d, log_prob, vectorize=True,
                                    moves=settings.emcee_moves())
    # emcee draws its moves from its own RandomState: seed it from ours.
    sampler.random_state = np.random.RandomState(int(rng.integers(2**31))).get_state()
    state = _initial_walkers(batch, point, n_walkers, rng)
    # The run's length is found as it goes (50 autocorrelation times), so the bar counts
    # steps without a total (a percentage would jump back when the target grows) and shows
    # the current target beside the count.
    bar = tqdm(desc="emcee", unit=" steps", disable=not settings.progress, leave=False)
    bar.set_postfix_str(f"burn-in {settings.burn_steps}")
    state = _advance(sampler, state, settings.burn_steps, bar)
    burn = settings.burn_steps
    chunk = settings.chunk_steps
    while True:
        chunk = min(chunk, settings.max_steps - sampler.iteration)
        bar.set_postfix_str(f"target ~{sampler.iteration + chunk} (<= {settings.max_steps})")
        state = _advance(sampler, state, chunk, bar)
        kept = sampler.iteration - burn
        tau = sampler.get_autocorr_time(discard=burn, tol=0)
        if not np.all(np.isfinite(tau)):
            tau = np.full(d, float(kept))
        tau_max = float(np.max(tau))
        long_enough = kept >= settings.tau_factor * tau_max
        capped = sampler.iteration >= settings.max_steps
        if long_enough or capped:
            draws_u, lp, thin = _thinned(sampler, burn, tau)
            summary = summarise_draws(problem.to_natural_host(draws_u), problem.names)
            good = all(v["r_hat"] <= settings.max_r_hat and v["ess_bulk"] >= settings.min_ess
                       for v in summary.values())
            if good or capped:
                break
        # Once the walkers have mixed, a burn-in of a few autocorrelation times suffices.
        burn = max(burn, int(3 * tau_max))
        # Aim the next chunk at tau_factor * tau (10 % margin); once there, a check that
        # failed on r_hat or ESS grows the run by a quarter, so few checks are needed.
        kept = sampler.iteration - burn
        wanted = settings.tau_factor * tau_max * 1.1 - kept
        if long_enough:
            wanted = 0.25 * kept
        chunk = int(max(settings.chunk_steps / 5, min(wanted, 4 * settings.chunk_steps)))
    bar.close()
    return Posterior(
        names=problem.names,
        draws=problem.to_natural_host(draws_u),
        log_posterior=lp,
        tau_steps=np.asarray(tau),
        n_steps=int(sampler.iteration),
        burn=burn,
        thin=thin,
        acceptance=float(np.mean(sampler.acceptance_fraction)),
        method=settings.description(n_walkers),
        move=settings.move,
        summary=summary,  # of these very draws (the last check's)
    )


def _advance(sampler: emcee.EnsembleSampler, state, steps: int, bar) -> emcee.State:
    """Run ``steps`` more steps, ticking the progress bar."""
    for _ in sampler.sample(state, iterations=steps):
        bar.update(1)
    return sampler.get_last_sample()


def _thinned(sampler: emcee.EnsembleSampler, burn: int, tau: np.ndarray):
    """Draws after burn-in, thinned by half the shortest autocorrelation time (or more, to
    keep at most ``MAX_STORED_SAMPLES``): (walkers, draws, d), (walkers, draws), thin."""
    chain = sampler.get_chain(discard=burn)  # (steps, walkers, d)
    lp = sampler.get_log_prob(discard=burn)
    steps, walkers, _ = chain.shape
    thin = max(1, int(0.5 * np.min(tau)), math.ceil(steps * walkers / MAX_STORED_SAMPLES))
    return np.transpose(chain[::thin], (1, 0, 2)), lp[::thin].T, thin


