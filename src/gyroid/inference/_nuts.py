"""Posterior sampling with NUTS (blackjax) for posteriors emcee does not mix.

The pooled fit's default sampler (:class:`Nuts`): its sampled space is the between-run
sds and every run's noise level, ``p + R`` dimensions. emcee's ensemble moves (DE,
stretch) slow down with dimension faster than the posterior's difficulty grows: on a lot
of 30 magnetic runs (34 dimensions, 136 walkers) emcee stopped at its 30 000-step cap
with r_hat above 1.01 after 176 s, where NUTS, whose cost per independent draw depends
little on the dimension of a smooth posterior, converges in seconds (``experiments/pool_sbc.py``).

Four chains start from the mode's Gaussian approximation; blackjax's window adaptation
(step size and a diagonal mass matrix, ``warmup`` steps) precedes ``draws`` steps per chain.
When r_hat or the bulk ESS misses its target (as :mod:`gyroid.inference._emcee`), the
chains are run again twice as long, up to ``max_draws``. Each chain's loop is one compiled
function of the problem's arrays (passed as arguments, so a new lot of the same shape
reuses it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import version

import jax
import jax.numpy as jnp
import numpy as np

from gyroid._exported import exported
from gyroid.inference._checks import MAX_R_HAT, MIN_ESS
from gyroid.inference._posterior import Posterior, covariance_factor, summarise_draws
from gyroid.inference._problem import AbstractProblem, AbstractSampler, PointEstimate


@dataclass(frozen=True)
class Nuts(AbstractSampler):
    """blackjax's NUTS after its window adaptation, run until it has converged (see the
    module docstring)."""

    chains: int = 4
    warmup: int = 500
    draws: int = 1000
    max_draws: int = 8000
    target_acceptance: float = 0.85
    min_ess: float = MIN_ESS
    max_r_hat: float = MAX_R_HAT

    def sample(self, problem: AbstractProblem, point: PointEstimate, *, seed: int = 0,
               progress: Callable[[str], None] | None = None) -> Posterior:
        """Sample ``problem.density.log_posterior`` (sampling coordinates) with NUTS from
        ``point``; draws returned in natural units."""
        return _sample(problem, point, self, seed, progress)


@exported
def _run_chain(density, key, start, warmup: int, draws: int, target: float):
    import blackjax  # loaded when a chain is first traced, not with the Nuts class

    def logdensity(u):
        return density.log_posterior(u)

    # blackjax's adaptation mixes bool and int arrays: it is traced under JAX's standard
    # promotion even where gyroid's tests make promotion strict (gyroid's own code is).
    with jax.numpy_dtype_promotion("standard"):
        adapt = blackjax.window_adaptation(blackjax.nuts, logdensity,
                                           target_acceptance_rate=target)
        warm_key, run_key = jax.random.split(key)
        # blackjax's protocols omit the window adaptation's num_steps and type a step's
        # state and info as bare NamedTuples (they are HMCState and NUTSInfo)
        (state, parameters), _ = adapt.run(warm_key, start, num_steps=warmup)  # pyright: ignore[reportCallIssue]
        kernel = blackjax.nuts(logdensity, **parameters)

        def step(state, key):
            state, info = kernel.step(key, state)
            return state, (state.position, state.logdensity,  # pyright: ignore[reportAttributeAccessIssue]
                           info.acceptance_rate, info.is_divergent)  # pyright: ignore[reportAttributeAccessIssue]

        _, (positions, logdensities, acceptance, divergent) = jax.lax.scan(
            step, state, jax.random.split(run_key, draws))
    return positions, logdensities, acceptance, divergent


def _sample(problem: AbstractProblem, point: PointEstimate, settings: Nuts, seed: int,
            progress: Callable[[str], None] | None) -> Posterior:
    say = progress or (lambda _message: None)
    rng = np.random.default_rng(seed)
    d = point.u.size
    factor = covariance_factor(point.covariance_u)
    draws = settings.draws
    while True:
        runs = []
        say(f"NUTS: {settings.chains} chains of {settings.warmup} warm-up and {draws} draws ...")
        for _ in range(settings.chains):
            start = point.u + 0.5 * factor @ rng.standard_normal(d)
            key = jax.random.PRNGKey(int(rng.integers(2**31)))
            runs.append(_run_chain(problem.density, key, jnp.asarray(start), settings.warmup,
                                   draws, settings.target_acceptance))
        positions = np.stack([np.asarray(r[0]) for r in runs])
        natural = problem.to_natural_host(positions)
        summary = summarise_draws(natural, problem.names)
        good = all(s["r_hat"] <= settings.max_r_hat and s["ess_bulk"] >= settings.min_ess
                   for s in summary.values())
        if good or 2 * draws > settings.max_draws:
            break
        draws *= 2
    divergent = int(sum(np.asarray(r[3]).sum() for r in runs))
    return Posterior(
        names=problem.names,
        draws=natural,
        log_posterior=np.stack([np.asarray(r[1]) for r in runs]),
        tau_steps=np.array([draws * settings.chains / summary[n]["ess_bulk"]
                            for n in problem.names]),
        n_steps=settings.warmup + draws,
        burn=settings.warmup,
        thin=1,
        acceptance=float(np.mean([np.asarray(r[2]).mean() for r in runs])),
        method=f"nuts (blackjax {version('blackjax')}, {settings.chains} chains)",
        summary=summary,
        divergent=divergent,
    )
