"""A static rate log's noise as a sum of IEEE Std 952 processes, a Gauss-Markov bias and a
prefilter's deficit (:mod:`gyroid.allan._terms`), fitted to its Haar statistics
(:mod:`gyroid.allan._haar`): the posterior of one set of terms, and the maximum
likelihood every set's choice (:mod:`gyroid.allan._choice`) rests on.

The likelihood treats each level's Haar coefficients as independent
``N(0, 2 AVAR)`` (exact for white noise and a random walk; the flicker floor is a constant
only for ``tau`` well above ``tau0``). Which terms the log resolves is weighed by BIC over
every subset (:mod:`gyroid.allan._choice`); a term left out is reported with a
one-sided 95 % profile-likelihood upper bound instead of an interval. Priors on
``log a_k`` are normal with median a tenth of the term's *envelope* (the amplitude at which
it alone would explain the smallest Allan variance the log shows, which the data bound it
by) and log-sd ``ln 100``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.allan._haar import HaarStatistics
from gyroid.allan._model_fit import NoiseModelFit, noise_model_result
from gyroid.allan._terms import (
    ceiling,
    envelope,
    level_log_likelihood,
    shapes,
)
from gyroid.inference._emcee import Emcee
from gyroid.inference._importance import Importance
from gyroid.inference._marginal_target import MarginalTarget, whole_posterior
from gyroid.inference._mode import BoundedGradientSearch, FisherScoring, value_hessian
from gyroid.inference._posterior import Posterior
from gyroid.inference._problem import AbstractDensity, AbstractProblem, PointEstimate
from gyroid.models._priors import Normal, natural_with_sd

PRIOR_BELOW_ENVELOPE = math.log(10.0)
PRIOR_LOG_SD = math.log(100.0)
#: The sd of F's log-amplitude read at the levels left out for it (:func:`_reading`): those
#: levels' shape departs from F's ``1 / tau^2`` by up to some 40 % of the deficit (F 20 %)
#: for the low-pass filters of :mod:`gyroid.allan._levels`.
PREFILTER_LOG_SD = 0.25
#: The posterior mode's search (L-BFGS-B with the analytic gradient, polished by BFGS).
_SEARCH = BoundedGradientSearch(gtol=1e-8, ftol=1e-15, max_steps=5000, polish_steps=2000)
#: The maximum likelihood's Fisher scoring: steps at most, the relative rise that ends them.
_SCORING = FisherScoring(max_steps=500, tol=1e-12)


class NoiseDensity(AbstractDensity):
    """The JAX part of a noise problem: log-amplitudes ``u`` to a log-posterior."""

    shape: Float[Array, "levels terms"]
    count: Float[Array, " levels"]
    sum_sq: Float[Array, " levels"]
    prior_loc: Float[Array, " terms"]
    prior_scale: Float[Array, " terms"]
    #: A reading of each log-amplitude from levels the Haar likelihood leaves out, and its
    #: sd (inf: none): F's, at the shortest levels a prefilter shapes (:func:`_reading`).
    reading_loc: Float[Array, " terms"]
    reading_scale: Float[Array, " terms"]

    def log_likelihood_blocks(self, u: Float[Array, " terms"]) -> Float[Array, " levels"]:
        variance = 2.0 * (self.shape @ jnp.exp(2.0 * u))
        safe = jnp.where(variance > 0, variance, 1.0)  # a prefilter deeper than the white
        return jnp.where(variance > 0, -0.5 * self.count * jnp.log(2.0 * jnp.pi * safe)
                         - 0.5 * self.sum_sq / safe, -jnp.inf)

    def log_prior(self, u: Float[Array, " terms"]) -> Float[Array, ""]:
        z = (u - self.prior_loc) / self.prior_scale
        return jnp.sum(-0.5 * z**2 - jnp.log(self.prior_scale)) - 0.5 * u.size * jnp.log(
            2.0 * jnp.pi)

    def log_reading(self, u: Float[Array, " terms"]) -> Float[Array, ""]:
        """The readings' log-likelihood (up to a constant)."""
        return -0.5 * jnp.sum(((u - self.reading_loc) / self.reading_scale) ** 2)

    def log_posterior(self, u: Float[Array, " terms"]) -> Float[Array, ""]:
        return jnp.sum(self.log_likelihood_blocks(u)) + self.log_reading(u) + self.log_prior(u)


class NoiseProblem(AbstractProblem[NoiseModelFit]):
    """The posterior of a chosen set of noise terms' amplitudes (sampled as logs)."""

    density: NoiseDensity
    stats: HaarStatistics = eqx.field(static=True)
    terms: tuple[str, ...] = eqx.field(static=True)
    label: str = eqx.field(static=True, default="")
    #: Where the mode is searched from besides the usual starts (the set's maximum
    #: likelihood, :attr:`TermChoice.argmax`), log-amplitudes.
    start: tuple[float, ...] = eqx.field(static=True, default=())

    @classmethod
    def from_statistics(cls, stats: HaarStatistics, terms: tuple[str, ...],
                        label: str = "", start: tuple[float, ...] = ()) -> NoiseProblem:
        bound = envelope(stats)
        loc = np.array([math.log(bound[n]) - PRIOR_BELOW_ENVELOPE for n in terms])
        reading, reading_sd = _reading(stats, terms)
        density = NoiseDensity(jnp.asarray(shapes(stats, terms)), jnp.asarray(stats.count),
                               jnp.asarray(stats.sum_sq), jnp.asarray(loc),
                               jnp.full(len(terms), PRIOR_LOG_SD), jnp.asarray(reading),
                               jnp.asarray(reading_sd))
        return cls(density, stats, tuple(terms), label, tuple(start))

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

    def _gaussian_terms(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The prior's and the readings' log-density at log-amplitudes ``u`` (rows; the
        density's ``log_prior + log_reading`` on the host) and its gradient: the one place
        the host writes them, for the importance sampler and the mode."""
        density = self.density
        loc, scale = np.asarray(density.prior_loc), np.asarray(density.prior_scale)
        read, read_sd = np.asarray(density.reading_loc), np.asarray(density.reading_scale)
        value = (np.sum(-0.5 * ((u - loc) / scale) ** 2 - np.log(scale), axis=-1)
                 - 0.5 * u.shape[-1] * math.log(2.0 * math.pi)
                 - 0.5 * np.sum(((u - read) / read_sd) ** 2, axis=-1))
        return value, -(u - loc) / scale**2 - (u - read) / read_sd**2

    def host_log_posterior(self) -> Callable[[np.ndarray], np.ndarray]:
        g = shapes(self.stats, self.terms)

        def log_posterior(u: np.ndarray) -> np.ndarray:
            u = np.atleast_2d(u)
            with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
                ll = level_log_likelihood(2.0 * (np.exp(2.0 * u) @ g.T), self.stats
                                          ).sum(axis=-1)
            out = ll + self._gaussian_terms(u)[0]
            return np.where(np.isfinite(out), out, -np.inf)

        return log_posterior

    def result(self, point: PointEstimate, posterior: Posterior | None, *,
               seed: int) -> NoiseModelFit:
        """The fit's frozen :class:`~gyroid.allan.NoiseModelFit`, its self-checks first."""
        return noise_model_result(self, point, posterior, seed=seed)

    def mode(self) -> PointEstimate:
        g = shapes(self.stats, self.terms)

        def target(u: np.ndarray) -> tuple[float, np.ndarray]:
            ll, grad = _log_likelihood_and_gradient(u, g, 0.0, self.stats)
            value, gradient = self._gaussian_terms(u)
            return ll + float(value), grad + gradient

        extra = [np.asarray(self.start)] if self.start else []
        best = _SEARCH.maximise(target, [*extra, *_starts(self.stats, self.terms)],
                                _bounds(self.stats, self.terms))
        covariance = np.linalg.pinv(-value_hessian(
            lambda points: np.array([target(u)[0] for u in points]), best.value, 1e-4))
        x, sd = natural_with_sd(best.value, covariance, np.ones(len(self.terms), dtype=bool))
        return PointEstimate(names=self.terms, u=best.value, covariance_u=covariance,
                             value=dict(zip(self.terms, map(float, x), strict=True)),
                             sd=dict(zip(self.terms, map(float, sd), strict=True)),
                             converged=best.converged, message=best.message)

    def marginal_target(self) -> MarginalTarget:
        """Every coordinate is a term's log-amplitude, each with its prior: importance
        sampling integrates the whole posterior (there is no coefficient to draw given
        them), in NumPy on the host."""
        density = self.density
        return whole_posterior(self.host_log_posterior(), self.positive, density.prior_loc,
                               density.prior_scale, np.ones(len(self.terms)),
                               "terms' log-amplitudes")

    def default_sampler(self) -> Importance:
        return Importance(fallback=Emcee(progress=False))

    def observed_data(self) -> dict[str, np.ndarray]:
        return {"haar_sum_sq": self.stats.sum_sq}

    def constant_data(self) -> dict[str, np.ndarray]:
        return {"haar_count": self.stats.count, "tau_s": self.stats.tau_s}

    def idata_attrs(self) -> dict[str, str]:
        return {"model": "gyroid noise: " + " + ".join(self.terms),
                "likelihood": "Haar coefficients per level, independent N(0, 2 AVAR(tau))"}


def _reading(stats: HaarStatistics, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Each term's log-amplitude as read from levels the Haar likelihood leaves out, and its
    sd (inf where none): F's at the shortest levels a prefilter shapes
    (``stats.prefilter_deg``; :func:`~gyroid.allan._levels.drop_prefiltered`),
    sd :data:`PREFILTER_LOG_SD`. It is the log's own measurement of the filter, a likelihood
    term, not a belief: F's prior stays the default's, so the prior-data check asks only of
    the priors (a pull of some 0.6-1 posterior sd between the two readings of one log is the
    filter's shape at the levels left out)."""
    loc, sd = np.zeros(len(names)), np.full(len(names), np.inf)
    if "F" in names and np.isfinite(stats.prefilter_deg):
        loc[names.index("F")] = math.log(stats.prefilter_deg)
        sd[names.index("F")] = PREFILTER_LOG_SD
    return loc, sd


def _starts(stats: HaarStatistics, names: tuple[str, ...]) -> list[np.ndarray]:
    """Starting log-amplitudes: each term a share of its envelope. The prefilter F, which
    subtracts, starts at fractions of the most the other terms' start leaves room for (the
    Allan variance must stay positive at every level); from a tiny F its gradient, which
    scales with F^2, never grew."""
    bound = envelope(stats)
    top = np.log([bound[n] for n in names])
    starts = [top - math.log(len(names)) * 0.5 - shift for shift in (0.0, 1.0, 3.0)]
    if "F" not in names:
        return starts
    k = names.index("F")
    others = [n for n in names if n != "F"]
    g_f = -shapes(stats, ("F",))[:, 0]
    out = []
    for start in starts:
        rest = shapes(stats, tuple(others)) @ np.exp(2.0 * np.delete(start, k))
        room = float(np.min(rest / g_f)) if others else 0.0
        for share in (0.5, 0.05):
            x = start.copy()
            x[k] = 0.5 * math.log(share * room) if room > 0 else start[k] - 10.0
            out.append(x)
    return out


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


#: Log-amplitudes are searched from this far below a term's envelope (a term 10^-11 of it
#: is absent, and a bound keeps its gradient alive: unbounded, a term driven towards zero
#: while another adjusted was lost at log-amplitude -140, where its gradient vanishes) to
#: this far above its ceiling (:func:`~gyroid.allan._terms.ceiling`).
BELOW_ENVELOPE, ABOVE_CEILING = 25.0, 1.0


def _bounds(stats: HaarStatistics, names: tuple[str, ...]) -> list[tuple[float, float]]:
    """Log-amplitude bounds: from far below the envelope to a little above the ceiling."""
    low, high = envelope(stats), ceiling(stats)
    return [(math.log(low[n]) - BELOW_ENVELOPE, math.log(high[n]) + ABOVE_CEILING)
            for n in names]


def max_likelihood(stats: HaarStatistics, names: tuple[str, ...],
                   fixed: dict[str, float] | None = None, starts: tuple[np.ndarray, ...] = (),
                   data_start: bool = True) -> tuple[float, np.ndarray]:
    """The maximum log-likelihood of ``names`` (``fixed``: amplitudes held) and its argmax
    in log-amplitudes of the free terms (a term at zero: its lower search bound);
    ``starts`` (log-amplitudes) are tried beside the data's own start (without it, when
    ``data_start`` is False and there are starts).

    The Allan variance is linear in each term's variance ``x_k = a_k^2`` (F's enters with
    the minus sign of its shape), so the maximum is found by Fisher scoring, which here is
    iterated non-negative least squares: each step fits ``x >= 0`` to the empirical Allan
    variances weighted by ``n_l / (2 V_l^2)`` at the current model ``V`` (the first step at
    the data's), a step halved until the likelihood rises and the variance stays positive.
    A term at zero keeps its say in every step. (A gradient search on log-amplitudes lost
    terms driven towards zero, whose gradient vanishes there, and stopped against the wall
    a too-deep F makes: on an ADIS16405 and on a two-tap average, sets fitted worse than
    their own subsets, by up to 200 nats.)"""
    fixed = fixed or {}
    free = tuple(n for n in names if n not in fixed)
    bound = envelope(stats)
    scale = np.array([bound[n] ** 2 for n in free])
    columns = shapes(stats, free) * scale
    held = (shapes(stats, tuple(fixed)) @ np.array([v**2 for v in fixed.values()])
            if fixed else np.zeros(stats.m.size))

    def log_likelihood(x: np.ndarray) -> float:
        variance = 2.0 * (columns @ x + held)
        if not np.all(variance > 0):
            return -np.inf
        return float(np.sum(level_log_likelihood(variance, stats)))

    tries = [_SCORING.maximise(log_likelihood, columns, held, stats.avar, stats.count, start)
             for start in ((None,) if data_start or not starts else ())
             + tuple(np.exp(2.0 * np.asarray(u)) / scale for u in starts)]
    best = max(tries, key=log_likelihood)
    u = 0.5 * np.log(np.maximum(best, np.exp(-2.0 * BELOW_ENVELOPE)) * scale)
    return log_likelihood(best), u


