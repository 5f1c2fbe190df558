"""Which noise terms a static log resolves: every identifiable set of terms fitted by
maximum likelihood and weighed by BIC (a term left out gets a one-sided 95 %
profile-likelihood upper bound), the Gauss-Markov term's correlation time chosen by profile
likelihood first, and the deviance of a set (:func:`deviance`) that the overdispersion
check reads."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace

import numpy as np

from gyroid.inference._haar import HaarStatistics
from gyroid.inference._mode import bracketed_root
from gyroid.inference._noise_problem import max_likelihood
from gyroid.inference._noise_terms import (
    EXCLUSIVE,
    TERM_NAMES,
    compatible,
    envelope,
    shapes,
)

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
    #: Each kept set's maximum-likelihood log-amplitudes (where its posterior mode is).
    argmax: dict[tuple[str, ...], tuple[float, ...]] = field(default_factory=dict)

    @property
    def best(self) -> tuple[str, ...]:
        return max(self.weights, key=self.weights.__getitem__)

    def inclusion(self, name: str) -> float:
        """The posterior probability that the log's noise has term ``name``."""
        return float(sum(w for terms, w in self.weights.items() if name in terms))

    @property
    def resolved(self) -> tuple[str, ...]:
        return tuple(n for n in TERM_NAMES if self.inclusion(n) >= 0.5)


#: A term added to a fitted set starts this far (in log-amplitude) below its envelope.
ADDED_BELOW = 8.0


def nested_starts(stats: HaarStatistics, names: tuple[str, ...],
                  argmax: dict[tuple[str, ...], np.ndarray]) -> tuple[np.ndarray, ...]:
    """Starts for ``names`` from the fits of its subsets one term smaller (``argmax``), the
    missing term small: the likelihood of such sets has a basin per way of sharing the
    Allan variance (an ADIS16405's: a low N with a large flicker, or the white N with a
    prefilter), and a set must do at least as well as any of its subsets."""
    bound = envelope(stats)
    out = []
    for k, name in enumerate(names):
        subset = names[:k] + names[k + 1:]
        if subset in argmax:
            out.append(np.insert(argmax[subset], k, math.log(bound[name]) - ADDED_BELOW))
    return tuple(out)


def n_parameters(names: tuple[str, ...]) -> int:
    """A set of terms' free parameters: an amplitude each, and G's correlation time."""
    return len(names) + ("G" in names)


def deviance(stats: HaarStatistics, names: tuple[str, ...]) -> tuple[float, int]:
    """The deviance of the maximum-likelihood fit of ``names`` (``sum count (r - 1 - ln r)``
    over levels, ``r`` the empirical over the model Allan variance: about ``chi2(dof)`` when
    the model is right and the coefficients independent) and its degrees of freedom."""
    _, u = max_likelihood(stats, names)
    ratio = stats.avar / (shapes(stats, names) @ np.exp(2.0 * u))
    return (float(np.sum(stats.count * (ratio - 1.0 - np.log(ratio)))),
            int(stats.m.size - n_parameters(names)))


def gauss_markov_time(stats: HaarStatistics) -> HaarStatistics:
    """``stats`` with the Gauss-Markov term's correlation time chosen: the value, on a
    half-octave grid of the log's averaging times (from its second to its third-last, so
    that the bump's rise and fall both lie among the levels), that maximises the likelihood
    of every term together (the wider of the sets with Q and with F; a profile likelihood,
    which BIC then charges G for). A log of too few levels keeps none (no G)."""
    grid = np.exp(np.arange(math.log(stats.tau_s[1]), math.log(stats.tau_s[-3]) + 1e-9,
                            0.5 * math.log(2.0))) if stats.m.size >= 6 else np.zeros(0)
    widest = [tuple(n for n in TERM_NAMES if n not in (drop, "G")) for drop in EXCLUSIVE]
    base = {names: max_likelihood(stats, names)[1] for names in widest}
    best, chosen = -np.inf, float("nan")
    for tc in grid:
        at = replace(stats, gm_tc_s=float(tc))
        value = max(max_likelihood(at, (*names, "G"),
                                   starts=nested_starts(at, (*names, "G"), base))[0]
                    for names in widest)
        if value > best:
            best, chosen = value, float(tc)
    return replace(stats, gm_tc_s=chosen)


#: Sets of terms whose weight is below this fraction of the best set's are not sampled.
MIN_WEIGHT = 0.01


def choose_terms(stats: HaarStatistics) -> TermChoice:
    """Every subset of the static terms (:data:`TERM_NAMES`) weighed by BIC (``n`` the
    number of Haar coefficients): a model-averaged fit samples the sets with weight, so a
    term the log barely resolves neither vanishes nor biases the others; a
    profile-likelihood upper bound for each term the log does not resolve."""
    n = float(stats.count.sum())
    candidates = TERM_NAMES if np.isfinite(stats.gm_tc_s) else tuple(
        n for n in TERM_NAMES if n != "G")
    bic, fits, argmax = {}, {}, {}
    for size in range(1, len(candidates) + 1):
        for names in itertools.combinations(candidates, size):
            if n_parameters(names) > stats.m.size - 1 or not compatible(names):
                continue
            value, argmax[names] = max_likelihood(
                stats, names, starts=nested_starts(stats, names, argmax))
            fits[names] = value
            bic["+".join(names)] = -2.0 * value + n_parameters(names) * math.log(n)
    lowest = min(bic.values())
    raw = {names: math.exp(-0.5 * (bic["+".join(names)] - lowest)) for names in fits}
    kept = {names: w for names, w in raw.items() if w >= MIN_WEIGHT}
    total = sum(kept.values())
    weights = {names: w / total for names, w in sorted(kept.items(), key=lambda i: -i[1])}
    best = max(weights, key=weights.__getitem__)
    included = {n: sum(w for names, w in weights.items() if n in names) for n in candidates}
    bounds = {name: _upper_bound(stats, best, name, fits[best])
              for name in candidates if included[name] < 0.5 and name not in best
              and compatible((*best, name))}
    # Q beside a best set with F, or F beside one with Q: bounded in the set without either
    bare = tuple(n for n in best if n not in EXCLUSIVE)
    bounds |= {name: _upper_bound(stats, bare, name, fits.get(bare, fits[best]))
               for name in candidates if included[name] < 0.5 and name not in best
               and not compatible((*best, name)) and bare}
    bounds |= {name: _upper_bound(stats, tuple(n for n in best if n != name), name,
                                  fits.get(tuple(n for n in best if n != name), fits[best]))
               for name in candidates if included[name] < 0.5 and name in best
               and len(best) > 1}
    return TermChoice(weights, bic, bounds,
                      {names: tuple(map(float, argmax[names])) for names in weights})


def _upper_bound(stats: HaarStatistics, chosen: tuple[str, ...], name: str,
                 best: float) -> float:
    """The amplitude of ``name`` (added to ``chosen``) at which the profile log-likelihood
    drops by half the one-sided 95 % chi-square quantile below ``best``."""
    names = (*chosen, name)
    if n_parameters(names) > stats.m.size - 1:
        return float("nan")
    top = envelope(stats)[name]

    def drop(log_a: float) -> float:
        value, _ = max_likelihood(stats, names, {name: math.exp(log_a)})
        return 2.0 * (best - value) - PROFILE_CHI2

    low, high = math.log(top) - 12.0, math.log(top) + 2.0
    if drop(low) > 0:  # even a tiny amplitude is excluded: the term is at the envelope
        return float(math.exp(low))
    if drop(high) < 0:
        return float(math.exp(high))
    return math.exp(bracketed_root(drop, low, high, xtol=1e-3))
