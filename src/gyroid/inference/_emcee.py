"""Posterior sampling with emcee (:class:`Emcee`).

Walkers start from the mode's Gaussian approximation; the run is extended in chunks until it
is at least ``tau_factor`` integrated autocorrelation times long and every parameter has
``ess_bulk >= min_ess`` and ``r_hat <= max_r_hat`` (ArviZ, over walkers), or until
``max_steps``. After the first chunk each chunk is sized from the current autocorrelation
time to reach ``tau_factor`` times it, so few checks are needed. The log-posterior is the
problem's density, jit-compiled and vmapped over walkers (``vectorize=True``), or its NumPy
form where that is cheaper (a static log's noise terms).

A linear drift model is sampled collapsed (:mod:`gyroid.inference._collapsed`: filtered
under correlated noise, on sufficient statistics under white noise): emcee walks the noise
levels' marginal posterior (white noise's unknown level alone), and each kept draw gets its
coefficients from their exact Gaussian conditional; the same posterior, with a fraction of
the steps. IEEE 952's three dimensions are walked by 16 walkers, not 32: the autocorrelation
time in steps is the same (the demo's thermal fit under white+flicker+rw: 12 steps either
way, 986 and 1058 steps run) at half the cost per step (12 s against 22 s).

The default move is emcee's differential-evolution move (``DEMove``): on the nearly
Gaussian, correlated posteriors of drift models its autocorrelation time is about a third
of the stretch move's (8 parameters, 32 walkers: ~26 steps against ~90), for the same
cost per step. ``Emcee(move="stretch")`` gives emcee's default.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

import emcee
import numpy as np
from tqdm.auto import tqdm

from gyroid.inference._batching import in_chunks, problem_batcher
from gyroid.inference._checks import MAX_R_HAT, MIN_ESS
from gyroid.inference._posterior import Posterior, covariance_factor, summarise_draws
from gyroid.inference._problem import AbstractProblem, AbstractSampler, PointEstimate

#: Cap on the draws kept (walkers x draws) after thinning.
MAX_STORED_SAMPLES = 2000


@dataclass(frozen=True)
class Emcee(AbstractSampler):
    """emcee's ensemble sampler, run until it has converged (see the module docstring)."""

    #: default: max(32, 4 * dimension), even; max(16, 4 * dimension) for a collapsed problem
    n_walkers: int | None = None
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


def _initial_walkers(batch, start: np.ndarray, covariance: np.ndarray, n_walkers: int,
                     rng: np.random.Generator) -> np.ndarray:
    d = start.size
    if not np.all(np.isfinite(covariance)):  # a singular curvature at the mode: small steps
        covariance = np.diag(np.where(np.isfinite(np.diag(covariance)),
                                      np.diag(covariance), 1e-4))
    factor = covariance_factor(covariance)
    walkers = start + rng.standard_normal((n_walkers, d)) @ factor.T
    half = n_walkers // 2  # emcee evaluates half the ensemble at a time: one compilation
    for attempt in range(21):
        lp = np.concatenate([np.asarray(batch(walkers[:half])), np.asarray(batch(walkers[half:]))])
        bad = ~np.isfinite(lp)
        if not bad.any():
            break
        # closer to the start each time; a walker left where the posterior is zero would
        # never move (emcee compares its -inf with its proposals')
        shrink = 0.1 * 0.5**attempt
        walkers[bad] = start + shrink * rng.standard_normal((bad.sum(), d)) @ factor.T
    return walkers


def _sample(problem: AbstractProblem, point: PointEstimate, settings: Emcee, seed: int
            ) -> Posterior:
    rng = np.random.default_rng(seed)
    walked = Walked.of(problem, point, rng)
    batch, d = walked.batch, walked.start.size
    n_walkers = settings.n_walkers or max(16 if walked.n_coefficients else 32, 4 * d)
    n_walkers += n_walkers % 2

    def log_prob(u: np.ndarray) -> np.ndarray:
        return np.asarray(batch(u))

    sampler = emcee.EnsembleSampler(n_walkers, d, log_prob, vectorize=True,
                                    moves=settings.emcee_moves())
    # emcee draws its moves from its own RandomState: seed it from ours.
    sampler.random_state = np.random.RandomState(int(rng.integers(2**31))).get_state()
    state = _initial_walkers(batch, walked.start, walked.covariance, n_walkers, rng)
    # The run's length is found as it goes (50 autocorrelation times), so the bar counts
    # steps without a total (a percentage would jump back when the target grows) and shows
    # the current target beside the count.
    bar = _progress_bar(settings.progress)
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
            draws_u = walked.full(draws_u)
            summary = summarise_draws(problem.to_natural_host(draws_u), problem.names)
            good = all(v["r_hat"] <= settings.max_r_hat and v["ess_bulk"] >= settings.min_ess
                       for v in summary.values())
            if good or capped:
                break
        burn = next_burn(burn, tau_max, sampler.iteration)
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
        log_posterior=walked.log_posterior(draws_u, lp),
        tau_steps=walked.tau_steps(np.asarray(tau)),
        n_steps=int(sampler.iteration),
        burn=burn,
        thin=thin,
        acceptance=float(np.mean(sampler.acceptance_fraction)),
        method=settings.description(n_walkers),
        move=settings.move,
        summary=summary,  # of these very draws (the last check's)
    )


@dataclass(frozen=True)
class Walked:
    """What a sampler walks (emcee) or weighs (:class:`~gyroid.inference.Importance`): every
    parameter (``full`` the identity), or a collapsed problem's noise levels, the
    coefficients drawn given each kept draw (``full``)."""

    batch: Callable[[np.ndarray], np.ndarray]
    start: np.ndarray
    covariance: np.ndarray
    full: Callable[[np.ndarray], np.ndarray]
    joint: Callable[[np.ndarray], np.ndarray] | None = None  # the full log-posterior
    n_coefficients: int = 0  # drawn given the walked noise levels
    #: conditional draws and joint log-posteriors evaluated this many at a time (emcee: as
    #: many as half an ensemble of 32 walkers, the memory its own batches already use)
    chunk: int = 16

    @classmethod
    def of(cls, problem: AbstractProblem, point: PointEstimate, rng: np.random.Generator,
           chunk: int = 16) -> Walked:
        collapsed = problem.collapsed()
        if collapsed is None or not collapsed.noise_loc.size:
            # Every parameter walked (nothing integrates out, or nothing is left to walk),
            # on the host where the density has a NumPy form: cheaper per step than JAX.
            batch = problem.host_log_posterior() or problem_batcher(
                problem.density.log_posterior)
            return cls(batch, point.u, point.covariance_u, lambda draws: draws)
        k = int(collapsed.noise_loc.size)
        d = point.u.size
        noise = np.arange(d - k, d)  # a bench density's noise levels come last
        conditional = problem_batcher(collapsed.conditional)

        def full(draws: np.ndarray) -> np.ndarray:
            flat = draws.reshape(-1, k)
            z = rng.standard_normal((flat.shape[0], d - k))
            beta = in_chunks(conditional, np.column_stack([flat, z]), chunk)
            return np.concatenate([beta, flat], axis=1).reshape(*draws.shape[:-1], d)

        return cls(problem_batcher(collapsed.log_posterior), point.u[noise],
                   point.covariance_u[np.ix_(noise, noise)], full,
                   problem_batcher(problem.density.log_posterior), d - k, chunk)

    def log_posterior(self, draws_u: np.ndarray, walked_lp: np.ndarray) -> np.ndarray:
        """The joint log-posterior of the kept draws (emcee's own where it walked all)."""
        if self.joint is None:
            return walked_lp
        flat = draws_u.reshape(-1, draws_u.shape[-1])
        return in_chunks(self.joint, flat, self.chunk).reshape(draws_u.shape[:-1])

    def tau_steps(self, tau: np.ndarray) -> np.ndarray:
        """Autocorrelation times per parameter; a coefficient drawn given the noise levels
        is given theirs at most (its draws are independent given them)."""
        if self.joint is None:
            return tau
        return np.concatenate([np.full(self.n_coefficients, float(np.max(tau))), tau])


def _progress_bar(show: bool):
    """tqdm's bar on a terminal; elsewhere (a log file, a pipe) plain lines at most every
    ``PLAIN_EVERY_S``, never a carriage return."""
    if show and not _terminal(sys.stderr):
        return _PlainProgress(sys.stderr)
    return tqdm(desc="emcee", unit=" steps", disable=not show, leave=False)


def _terminal(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


#: Seconds between two plain progress lines.
PLAIN_EVERY_S = 10.0


class _PlainProgress:
    """The bar's interface (``update``, ``set_postfix_str``, ``close``) as plain lines:
    ``emcee: 1200 steps (target ~2930 (<= 30000))``, the first after ``PLAIN_EVERY_S``."""

    def __init__(self, stream) -> None:
        self.stream, self.steps, self.postfix = stream, 0, ""
        self.last = time.monotonic()

    def update(self, n: int = 1) -> None:
        self.steps += n
        now = time.monotonic()
        if now - self.last >= PLAIN_EVERY_S:
            self.last = now
            print(f"emcee: {self.steps} steps ({self.postfix})", file=self.stream, flush=True)

    def set_postfix_str(self, text: str) -> None:
        self.postfix = text

    def close(self) -> None:
        pass


def next_burn(burn: int, tau_max: float, steps: int) -> int:
    """The burn-in once the walkers have mixed: a few autocorrelation times, but at most
    half the steps run. Uncapped, a long or unestimated autocorrelation time (taken as the
    whole run) discarded every step, and emcee's next estimate failed on an empty chain
    (a FOG bench's fit whose rate random walk the log does not resolve)."""
    return max(burn, min(int(3 * tau_max), steps // 2))


def _advance(sampler: emcee.EnsembleSampler, state, steps: int, bar) -> emcee.State:
    """Run ``steps`` more steps, ticking the progress bar."""
    for _ in sampler.sample(state, iterations=steps):
        bar.update(1)
    return sampler.get_last_sample()


def _thinned(sampler: emcee.EnsembleSampler, burn: int, tau: np.ndarray):
    """Draws after burn-in, thinned by half the shortest autocorrelation time (or more, to
    keep at most ``MAX_STORED_SAMPLES``): (walkers, draws, d), (walkers, draws), thin."""
    # emcee's getters are typed by inference as possibly None (for blobs); these are arrays
    chain = np.asarray(sampler.get_chain(discard=burn))  # (steps, walkers, d)
    lp = np.asarray(sampler.get_log_prob(discard=burn))
    steps, walkers, _ = chain.shape
    thin = max(1, int(0.5 * np.min(tau)), math.ceil(steps * walkers / MAX_STORED_SAMPLES))
    return np.transpose(chain[::thin], (1, 0, 2)), lp[::thin].T, thin


