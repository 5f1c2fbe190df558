"""A static rate log's noise as a sum of IEEE Std 952 processes
(:mod:`gyroid.inference._noise_terms`), fitted to its Haar statistics
(:mod:`gyroid.inference._haar`).

The likelihood treats each level's Haar coefficients as independent
``N(0, 2 AVAR)`` (exact for white noise and a random walk; the flicker floor is a constant
only for ``tau`` well above ``tau0``). Which terms the log resolves is chosen by BIC over
every subset; a term left out is reported with a one-sided 95 % profile-likelihood upper
bound instead of an interval. Priors on ``log a_k`` are normal with median a tenth of the
term's *envelope* (the amplitude at which it alone would explain the smallest Allan
variance the log shows, which the data bound it by) and log-sd ``ln 100``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float
from scipy import optimize

from gyroid.inference._emcee import Emcee
from gyroid.inference._haar import HaarStatistics
from gyroid.inference._noise_model_fit import noise_model_result
from gyroid.inference._noise_terms import (
    TERM_NAMES,
    envelope,
    level_log_likelihood,
    shapes,
)
from gyroid.inference._problem import AbstractProblem, PointEstimate
from gyroid.models._priors import Normal, natural_with_sd

PRIOR_BELOW_ENVELOPE = math.log(10.0)
PRIOR_LOG_SD = math.log(100.0)
#: One-sided 95 % profile-likelihood bound: 2 * drop in log-likelihood.
PROFILE_CHI2 = 2.705543454095404


@dataclass(frozen=True)
class TermChoice:
    """The candidate sets of terms worth sampling with their posterior weights
    (``exp(-BIC / 2)``, normalised; sets below ``MIN_WEIGHT`` of the best left out), the BIC
    of every set tried, and an upper bound (datasheet units) for each term the log does not
    resolve (included with less than half the weight)."""

    weights: dict[tuple[str, ...], float]
    bic: dict[str, float]
    upper_bound_95: dict[str, float]

    @property
    def best(self) -> tuple[str, ...]:
        return max(self.weights, key=self.weights.get)

    def inclusion(self, name: str) -> float:
        """The posterior probability that the log's noise has term ``name``."""
        return float(sum(w for terms, w in self.weights.items() if name in terms))

    @property
    def resolved(self) -> tuple[str, ...]:
        return tuple(n for n in TERM_NAMES if self.inclusion(n) >= 0.5)


class NoiseDensity(eqx.Module):
    """The JAX part of a noise problem: log-amplitudes ``u`` to a log-posterior."""

    shape: Float[Array, "levels terms"]
    count: Float[Array, " levels"]
    sum_sq: Float[Array, " levels"]
    prior_loc: Float[Array, " terms"]
    prior_scale: Float[Array, " terms"]

    def log_likelihood_blocks(self, u: Float[Array, " terms"]) -> Float[Array, " levels"]:
        variance = 2.0 * (self.shape @ jnp.exp(2.0 * u))
        return (-0.5 * self.count * jnp.log(2.0 * jnp.pi * variance)
                - 0.5 * self.sum_sq / variance)

    def log_prior(self, u: Float[Array, " terms"]) -> Float[Array, ""]:
        z = (u - self.prior_loc) / self.prior_scale
        return jnp.sum(-0.5 * z**2 - jnp.log(self.prior_scale)) - 0.5 * u.size * jnp.log(
            2.0 * jnp.pi)

    def log_posterior(self, u: Float[Array, " terms"]) -> Float[Array, ""]:
        return jnp.sum(self.log_likelihood_blocks(u)) + self.log_prior(u)


class NoiseProblem(AbstractProblem):
    """The posterior of a chosen set of noise terms' amplitudes (sampled as logs)."""

    density: NoiseDensity
    stats: HaarStatistics = eqx.field(static=True)
    terms: tuple[str, ...] = eqx.field(static=True)
    label: str = eqx.field(static=True, default="")

    @classmethod
    def from_statistics(cls, stats: HaarStatistics, terms: tuple[str, ...],
                        label: str = "") -> NoiseProblem:
        bound = envelope(stats)
        loc = np.array([math.log(bound[n]) - PRIOR_BELOW_ENVELOPE for n in terms])
        density = NoiseDensity(jnp.asarray(shapes(stats, terms)), jnp.asarray(stats.count),
                               jnp.asarray(stats.sum_sq), jnp.asarray(loc),
                               jnp.full(len(terms), PRIOR_LOG_SD))
        return cls(density, stats, tuple(terms), label)

    @property
    def names(self) -> tuple[str, ...]:
        return self.terms

    @property
    def positive(self) -> tuple[bool, ...]:
        return (True,) * len(self.terms)

    @property
    def priors(self) -> tuple[Normal, ...]:
        return tuple(Normal(float(a), float(b)) for a, b in
                     zip(self.density.prior_loc, self.density.prior_scale, strict=True))

    def host_log_posterior(self) -> Callable[[np.ndarray], np.ndarray]:
        g = shapes(self.stats, self.terms)
        loc, scale = np.asarray(self.density.prior_loc), np.asarray(self.density.prior_scale)

        def log_posterior(u: np.ndarray) -> np.ndarray:
            u = np.atleast_2d(u)
            with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
                ll = level_log_likelihood(2.0 * (np.exp(2.0 * u) @ g.T), self.stats
                                          ).sum(axis=-1)
            prior = np.sum(-0.5 * ((u - loc) / scale) ** 2 - np.log(scale), axis=-1)
            out = ll + prior
            return np.where(np.isfinite(out), out, -np.inf)

        return log_posterior

    def mode(self) -> PointEstimate:
        g = shapes(self.stats, self.terms)
        loc, scale = np.asarray(self.density.prior_loc), np.asarray(self.density.prior_scale)

        def target(u: np.ndarray) -> tuple[float, np.ndarray]:
            ll, grad = _log_likelihood_and_gradient(u, g, 0.0, self.stats)
            return (ll - 0.5 * float(np.sum(((u - loc) / scale) ** 2)),
                    grad - (u - loc) / scale**2)

        best = _maximise(target, _starts(self.stats, self.terms))
        covariance = np.linalg.pinv(-_hessian(lambda u: target(u)[0], best.x))
        x, sd = natural_with_sd(best.x, covariance, np.ones(len(self.terms), dtype=bool))
        return PointEstimate(names=self.terms, u=best.x, covariance_u=covariance,
                             value=dict(zip(self.terms, map(float, x), strict=True)),
                             sd=dict(zip(self.terms, map(float, sd), strict=True)),
                             converged=bool(best.success), message=str(best.message))

    def default_sampler(self) -> Emcee:
        return Emcee(progress=False)

    def result(self, point, posterior, *, seed: int):
        return noise_model_result(self, point, posterior)

    def observed_data(self) -> dict[str, np.ndarray]:
        return {"haar_sum_sq": self.stats.sum_sq}

    def constant_data(self) -> dict[str, np.ndarray]:
        return {"haar_count": self.stats.count, "tau_s": self.stats.tau_s}

    def idata_attrs(self) -> dict[str, str]:
        return {"model": "gyroid noise: " + " + ".join(self.terms),
                "likelihood": "Haar coefficients per level, independent N(0, 2 AVAR(tau))"}


def _starts(stats: HaarStatistics, names: tuple[str, ...]) -> list[np.ndarray]:
    bound = envelope(stats)
    top = np.log([bound[n] for n in names])
    return [top - math.log(len(names)) * 0.5 - shift for shift in (0.0, 1.0, 3.0)]


def _log_likelihood_and_gradient(u: np.ndarray, g: np.ndarray, held: np.ndarray | float,
                                 stats: HaarStatistics) -> tuple[float, np.ndarray]:
    """The Haar log-likelihood of log-amplitudes ``u`` (terms with shapes ``g``, plus a
    held Allan variance ``held``) and its gradient."""
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        a2 = np.exp(2.0 * np.clip(u, -350.0, 350.0))
        variance = 2.0 * (g @ a2 + held)
        ll = float(np.sum(level_log_likelihood(variance, stats)))
        d_variance = -0.5 * stats.count / variance + 0.5 * stats.sum_sq / variance**2
        gradient = (d_variance @ g) * 4.0 * a2
    if not (np.isfinite(ll) and np.all(np.isfinite(gradient))):
        return -1e300, np.zeros_like(u)
    return ll, gradient


def _maximise(function: Callable[[np.ndarray], tuple[float, np.ndarray]],
              starts: list[np.ndarray]):
    """The best of BFGS runs (with the analytic gradient) from ``starts``."""
    best = None
    for start in starts:
        found = optimize.minimize(lambda u: tuple(-v for v in function(u)), start, jac=True,
                                  method="BFGS", options={"gtol": 1e-8, "maxiter": 2000})
        if best is None or found.fun < best.fun:
            best = found
    best.success = bool(np.isfinite(best.fun) and np.max(np.abs(best.jac)) < 1e-3 * max(
        1.0, abs(best.fun)))
    return best


def _hessian(function: Callable[[np.ndarray], float], x: np.ndarray, h: float = 1e-4
             ) -> np.ndarray:
    d = x.size
    out = np.empty((d, d))
    for i in range(d):
        for j in range(i, d):
            e_i, e_j = np.eye(d)[i] * h, np.eye(d)[j] * h
            out[i, j] = out[j, i] = (function(x + e_i + e_j) - function(x + e_i - e_j)
                                     - function(x - e_i + e_j) + function(x - e_i - e_j)
                                     ) / (4 * h * h)
    return out


def _max_likelihood(stats: HaarStatistics, names: tuple[str, ...],
                    fixed: dict[str, float] | None = None) -> tuple[float, np.ndarray]:
    """The maximum log-likelihood of ``names`` (``fixed``: amplitudes held) and its argmax
    in log-amplitudes of the free terms."""
    fixed = fixed or {}
    free = tuple(n for n in names if n not in fixed)
    g_free = shapes(stats, free)
    held = (shapes(stats, tuple(fixed)) @ np.array([v**2 for v in fixed.values()])
            if fixed else 0.0)
    found = _maximise(lambda u: _log_likelihood_and_gradient(u, g_free, held, stats),
                      _starts(stats, free))
    return -float(found.fun), found.x


def deviance(stats: HaarStatistics, names: tuple[str, ...]) -> tuple[float, int]:
    """The deviance of the maximum-likelihood fit of ``names`` (``sum count (r - 1 - ln r)``
    over levels, ``r`` the empirical over the model Allan variance: about ``chi2(dof)`` when
    the model is right and the coefficients independent) and its degrees of freedom."""
    _, u = _max_likelihood(stats, names)
    ratio = stats.avar / (shapes(stats, names) @ np.exp(2.0 * u))
    return (float(np.sum(stats.count * (ratio - 1.0 - np.log(ratio)))),
            int(stats.m.size - len(names)))


#: Sets of terms whose weight is below this fraction of the best set's are not sampled.
MIN_WEIGHT = 0.01


def choose_terms(stats: HaarStatistics) -> TermChoice:
    """Every subset of :data:`NOISE_TERMS` weighed by BIC (``n`` the number of Haar
    coefficients): a model-averaged fit samples the sets with weight, so a term the log
    barely resolves neither vanishes nor biases the others; a profile-likelihood upper bound
    for each term the log does not resolve."""
    n = float(stats.count.sum())
    bic, fits = {}, {}
    for size in range(1, len(TERM_NAMES) + 1):
        for names in itertools.combinations(TERM_NAMES, size):
            if size > stats.m.size - 1:
                continue
            value, _ = _max_likelihood(stats, names)
            fits[names] = value
            bic["+".join(names)] = -2.0 * value + size * math.log(n)
    lowest = min(bic.values())
    raw = {names: math.exp(-0.5 * (bic["+".join(names)] - lowest)) for names in fits}
    kept = {names: w for names, w in raw.items() if w >= MIN_WEIGHT}
    total = sum(kept.values())
    weights = {names: w / total for names, w in sorted(kept.items(), key=lambda i: -i[1])}
    best = max(weights, key=weights.get)
    included = {n: sum(w for names, w in weights.items() if n in names) for n in TERM_NAMES}
    bounds = {name: _upper_bound(stats, best, name, fits[best])
              for name in TERM_NAMES if included[name] < 0.5 and name not in best}
    bounds |= {name: _upper_bound(stats, tuple(n for n in best if n != name), name,
                                  fits.get(tuple(n for n in best if n != name), fits[best]))
               for name in TERM_NAMES if included[name] < 0.5 and name in best
               and len(best) > 1}
    return TermChoice(weights, bic, bounds)


def _upper_bound(stats: HaarStatistics, chosen: tuple[str, ...], name: str,
                 best: float) -> float:
    """The amplitude of ``name`` (added to ``chosen``) at which the profile log-likelihood
    drops by half the one-sided 95 % chi-square quantile below ``best``."""
    names = (*chosen, name)
    if len(names) > stats.m.size - 1:
        return float("nan")
    top = envelope(stats)[name]

    def drop(log_a: float) -> float:
        value, _ = _max_likelihood(stats, names, {name: math.exp(log_a)})
        return 2.0 * (best - value) - PROFILE_CHI2

    low, high = math.log(top) - 12.0, math.log(top) + 2.0
    if drop(low) > 0:  # even a tiny amplitude is excluded: the term is at the envelope
        return float(math.exp(low))
    if drop(high) < 0:
        return float(math.exp(high))
    return float(math.exp(optimize.brentq(drop, low, high, xtol=1e-3)))
