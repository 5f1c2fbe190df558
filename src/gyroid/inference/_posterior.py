"""What a sampler gives (:class:`Posterior`: draws and their diagnostics) and the summaries
of draws shared by every kind of fit. It knows no problem: the sampler interface is
:class:`~gyroid.inference._problem.AbstractSampler`, the ArviZ storage
:mod:`gyroid.inference._storage`."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from gyroid.inference._checks import MAX_R_HAT, MIN_ESS
from gyroid.io._arviz import load_arviz


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
    #: Importance sampling's weighed draws of the marginal coordinates and their ``solved``
    #: rows (:class:`~gyroid.inference._marginal_target.MarginalTarget`), which
    #: :func:`~gyroid.bench._allowed_noise.allowed_noise` reuses; None for a chain.
    evaluated: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)

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
    az = load_arviz()
    out = {}
    for i, name in enumerate(names):
        chains = draws[..., i]  # ArviZ's diagnostics of a (chains, draws) array: a float
        values = chains.reshape(-1)
        lo, hi = np.percentile(values, [2.5, 97.5])
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="More chains .* than draws")
            r_hat, ess = az.rhat(chains), az.ess(chains, method="bulk")
        out[name] = {
            "mean": float(values.mean()),
            "sd": float(values.std(ddof=1)),
            "ci95": [float(lo), float(hi)],
            "r_hat": float(r_hat),
            "ess_bulk": float(ess),
        }
    return out
