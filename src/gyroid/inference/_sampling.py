"""Posterior sampling with emcee, stored as ArviZ InferenceData.

The log-posterior is jit-compiled and vmapped over walkers (``vectorize=True``). Walkers
start from the point estimate's Gaussian approximation; the run is extended in chunks
until it is at least ``tau_factor`` integrated autocorrelation times long and every
parameter has ``ess_bulk >= min_ess`` and ``r_hat <= max_r_hat`` (ArviZ, over walkers),
or until ``max_steps``. After the first chunk each chunk is sized from the current
autocorrelation time to reach ``tau_factor`` times it, so few checks are needed.

The default move is emcee's differential-evolution move (``DEMove``): on the nearly
Gaussian, correlated posteriors of drift models its autocorrelation time is about a third
of the stretch move's (8 parameters, 32 walkers: ~26 steps against ~90), for the same
cost per step. ``SamplerSettings(move="stretch")`` gives emcee's default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import emcee
import numpy as np
from tqdm.auto import tqdm

from gyroid.inference._batching import log_posterior_batcher, problem_batcher
from gyroid.inference._checks import MAX_R_HAT, MIN_ESS
from gyroid.inference._point import PointEstimate
from gyroid.io._arviz import arviz as az
from gyroid.models._priors import natural_from_sampling

#: Cap on the draws kept for storage (walkers x draws) after thinning.
MAX_STORED_SAMPLES = 2000


@dataclass(frozen=True)
class SamplerSettings:
    """How long to run emcee."""

    n_walkers: int | None = None  # default: max(32, 4 * dimension), even
    burn_steps: int = 300
    chunk_steps: int = 500
    tau_factor: float = 50.0
    min_ess: float = MIN_ESS
    max_r_hat: float = MAX_R_HAT
    max_steps: int = 30000
    move: str = "de"  # "de" (differential evolution) or "stretch" (emcee's default)
    progress: bool = True

    def emcee_moves(self):
        """The emcee move object for ``move``."""
        if self.move == "de":
            return emcee.moves.DEMove()
        if self.move == "stretch":
            return emcee.moves.StretchMove()
        raise ValueError(f"unknown move {self.move!r}: use 'de' or 'stretch'")


@dataclass
class Posterior:
    """Posterior draws in natural units with their diagnostics."""

    names: tuple[str, ...]
    draws: np.ndarray  # (walkers, draws, d) natural units, thinned, burn-in removed
    log_posterior: np.ndarray  # (walkers, draws)
    tau_steps: np.ndarray  # integrated autocorrelation time per parameter, steps
    n_steps: int
    burn: int
    thin: int
    acceptance: float
    idata: object = field(repr=False)
    move: str = "de"  # emcee move (SamplerSettings.move), or the NUTS sampler
    summary: dict[str, dict] = field(default_factory=dict)
    divergent: int = 0  # NUTS's divergent transitions after warm-up

    def flat(self, name: str) -> np.ndarray:
        return self.draws[..., self.names.index(name)].reshape(-1)

    @property
    def converged(self) -> bool:
        return all(s["r_hat"] <= MAX_R_HAT and s["ess_bulk"] >= MIN_ESS
                   for s in self.summary.values())


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


def sample_posterior(
    problem,
    point: PointEstimate,
    *,
    seed: int = 0,
    settings: SamplerSettings | None = None,
    store: bool = True,
) -> Posterior:
    """Sample the posterior of ``problem`` with emcee (see the module docstring).
    ``store=False`` leaves ``idata`` None (for a caller that builds its own)."""
    settings = settings or SamplerSettings()
    rng = np.random.default_rng(seed)
    d = point.u.size
    n_walkers = settings.n_walkers or max(32, 4 * d)
    n_walkers += n_walkers % 2

    # A linear-Gaussian problem's log-posterior runs on the host (NumPy on its sufficient
    # statistics): cheaper per emcee step than a call into JAX.
    host = getattr(problem, "host_log_posterior", lambda: None)()
    batch = host or log_posterior_batcher(problem)

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
            summary = summarise_draws(_to_natural(problem, draws_u), problem.names)
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
    natural = _to_natural(problem, draws_u)
    idata = to_inference_data(problem, draws_u, natural, lp,
                              sampler=sampler_description(settings, n_walkers)) if store else None
    return Posterior(
        names=problem.names,
        draws=natural,
        log_posterior=lp,
        tau_steps=np.asarray(tau),
        n_steps=int(sampler.iteration),
        burn=burn,
        thin=thin,
        acceptance=float(np.mean(sampler.acceptance_fraction)),
        move=settings.move,
        idata=idata,
        summary=summary,  # of these very draws (the last check's)
    )


def sampler_description(settings: SamplerSettings, n_walkers: int) -> str:
    """What sampled a posterior (InferenceData's ``sampler`` attribute)."""
    return f"emcee {emcee.__version__}, {settings.move} move, {n_walkers} walkers"


def _to_natural(problem, u: np.ndarray) -> np.ndarray:
    """``problem.to_natural`` in NumPy, for host-side draws."""
    return natural_from_sampling(u, problem.positive)


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


def to_inference_data(problem, draws_u: np.ndarray, natural: np.ndarray,
                      log_posterior: np.ndarray, sampler: str = "emcee"):
    """ArviZ InferenceData: posterior, block log-likelihood, observed data, sample stats.

    ``problem`` supplies ``names``, ``log_likelihood_blocks`` and the hooks
    ``observed_data()``, ``constant_data()`` and ``idata_attrs()``.
    """
    walkers, draws, d = draws_u.shape
    flat = draws_u.reshape(-1, d)
    chunk = 256
    padded = np.concatenate([flat, np.repeat(flat[-1:], -flat.shape[0] % chunk, axis=0)])
    blocks = problem_batcher(problem, "log_likelihood_blocks")
    log_lik = np.concatenate([np.asarray(blocks(padded[start:start + chunk]))
                              for start in range(0, padded.shape[0], chunk)])
    log_lik = log_lik[: flat.shape[0]].reshape(walkers, draws, -1)
    observed = problem.observed_data()
    constant = problem.constant_data()
    name = next(iter(observed))
    return az.from_dict(
        posterior={n: natural[..., i] for i, n in enumerate(problem.names)},
        log_likelihood={name: log_lik},
        observed_data=observed,
        constant_data=constant,
        sample_stats={"lp": log_posterior},
        dims={name: ["row"], **{k: ["row"] for k in constant}},
        attrs={**problem.idata_attrs(), "sampler": sampler},
    )


def interval_summary(values: np.ndarray) -> dict:
    """Mean, sd and central 95 % interval of draws of one derived quantity (no chains, so
    no r_hat or ESS: see :func:`summarise` for sampled parameters)."""
    values = np.asarray(values, dtype=float).reshape(-1)
    lo, hi = np.percentile(values, [2.5, 97.5])
    return {"mean": float(np.mean(values)), "sd": float(np.std(values, ddof=1)),
            "ci95": [float(lo), float(hi)]}


def summarise_draws(draws: np.ndarray, names: tuple[str, ...]) -> dict[str, dict]:
    """Summary of (walkers, draws, d) natural-unit draws, without building InferenceData."""
    posterior = az.from_dict(posterior={n: draws[..., i] for i, n in enumerate(names)})
    return summarise(posterior, names)


def summarise(idata, names: tuple[str, ...]) -> dict[str, dict]:
    """Mean, sd, 95 % interval, r_hat and bulk ESS of each parameter."""
    r_hat = az.rhat(idata)
    ess = az.ess(idata, method="bulk")
    out = {}
    for name in names:
        values = np.asarray(idata.posterior[name]).reshape(-1)
        lo, hi = np.percentile(values, [2.5, 97.5])
        out[name] = {
            "mean": float(values.mean()),
            "sd": float(values.std(ddof=1)),
            "ci95": [float(lo), float(hi)],
            "r_hat": float(r_hat[name]),
            "ess_bulk": float(ess[name]),
        }
    return out
