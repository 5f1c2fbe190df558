"""Which noise terms a static log resolves: every identifiable set of terms fitted by
maximum likelihood and weighed by BIC, a set with the Gauss-Markov term G by its likelihood
averaged over G's correlation times (:func:`over_correlation_times`); a term left out gets
a one-sided 95 % profile-likelihood upper bound that holds in every set with weight; and
the deviance of a set (:func:`deviance`) that the overdispersion check reads.

Why G's time is integrated, not charged: BIC's ``ln n`` per parameter (``n`` some 10^5
Haar coefficients) assumes every coefficient informs it, while a correlation time is read
from a few long averaging times. Charged so, the true set (white noise, G and a walk) lost
to white noise with flicker on logs simulated with no flicker: G's intervals held 3 of 7,
14 of 50 logs reported flicker (``experiments/noise_coverage.py``, the ``gm`` grade)."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from gyroid.allan._haar import HaarStatistics
from gyroid.allan._problem import max_likelihood
from gyroid.allan._terms import (
    EXCLUSIVE,
    TERM_NAMES,
    compatible,
    envelope,
    shapes,
)
from gyroid.inference._mode import bracketed_root

#: One-sided 95 % profile-likelihood bound: 2 * drop in log-likelihood.
PROFILE_CHI2 = 2.705543454095404


@dataclass(frozen=True)
class TermChoice:
    """The candidate sets of terms worth sampling with their posterior weights
    (``exp(-BIC / 2)``, normalised; sets below ``MIN_WEIGHT`` of the best left out), the BIC
    of every set fitted (:func:`choose_terms`; a set with G that could not reach that weight
    is not), and an upper bound (datasheet units) for each
    term the log does not resolve (included with less than half the weight)."""

    weights: dict[tuple[str, ...], float]
    bic: dict[str, float]
    upper_bound_95: dict[str, float]
    #: Each kept set's maximum-likelihood log-amplitudes (where its posterior mode is).
    argmax: dict[tuple[str, ...], tuple[float, ...]] = field(default_factory=dict)
    #: Each kept set with G: the correlation time (s) of its greatest likelihood, where it is
    #: sampled (its weight integrates over every time).
    gm_tc_s: dict[tuple[str, ...], float] = field(default_factory=dict)
    #: G's correlation time where no set with G has weight (s): the widest set's best, at
    #: which G is bounded (NaN: a log of too few averaging times to try G).
    profile_tc_s: float = float("nan")

    def stats_for(self, stats: HaarStatistics, names: tuple[str, ...]) -> HaarStatistics:
        """``stats`` with the correlation time at which the set ``names`` is sampled."""
        if names not in self.gm_tc_s:
            return stats
        return replace(stats, gm_tc_s=self.gm_tc_s[names])

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


def gauss_markov_grid(stats: HaarStatistics) -> np.ndarray:
    """The Gauss-Markov term's correlation times tried (s): a half-octave grid from the
    log's second averaging time to its third-last, so that the bump's rise and fall both
    lie among the levels (none on a log of fewer than 6 levels)."""
    if stats.m.size < 6:
        return np.zeros(0)
    return np.exp(np.arange(math.log(stats.tau_s[1]), math.log(stats.tau_s[-3]) + 1e-9,
                            0.5 * math.log(2.0)))


#: Sets of terms whose weight is below this fraction of the best set's are not sampled.
MIN_WEIGHT = 0.01
#: A term the log does not resolve is bounded in every set of at least this weight, and
#: its bound is the largest of theirs: it holds whichever of them the gyro's noise is.
BOUNDED_WEIGHT = 0.05


def choose_terms(stats: HaarStatistics) -> TermChoice:
    """Every subset of the static terms (:data:`TERM_NAMES`) weighed by BIC (``n`` the
    number of Haar coefficients; a set with G by its likelihood averaged over G's
    correlation times): a model-averaged fit samples the sets with weight, so a term the
    log barely resolves neither vanishes nor biases the others; a profile-likelihood upper
    bound for each term the log does not resolve, the largest over the sets of at least
    :data:`BOUNDED_WEIGHT`."""
    n = float(stats.count.sum())
    grid = gauss_markov_grid(stats)
    candidates = TERM_NAMES if grid.size else tuple(n for n in TERM_NAMES if n != "G")
    sets = [names for size in range(1, len(candidates) + 1)
            for names in itertools.combinations(candidates, size)
            if n_parameters(names) <= stats.m.size - 1 and compatible(names)
            and ("F" in names or np.isnan(stats.prefilter_deg))]
    fits, argmax = {}, {}
    for names in (s for s in sets if "G" not in s):
        fits[names], argmax[names] = max_likelihood(
            stats, names, starts=nested_starts(stats, names, argmax))
    with_g = [s for s in sets if "G" in s]
    widest_g = [s for s in with_g if not any(set(s) < set(t) for t in with_g)]
    over_times = over_correlation_times(stats, widest_g, argmax)

    def criterion(value: float, names: tuple[str, ...]) -> float:
        """BIC, an amplitude per term (G's time is integrated out, not charged)."""
        return -2.0 * value + len(names) * math.log(n)

    best = min(criterion(value, names) for names, value in fits.items())
    # a set's likelihood is at most a wider set's, at every time: a set with G whose BIC
    # could not come within MIN_WEIGHT of the best set without G is not fitted
    reach = [s for s in with_g if s not in over_times and criterion(min(
        over_times[w].greatest for w in widest_g if set(s) <= set(w)), s)
        - best < -2.0 * math.log(MIN_WEIGHT)]
    over_times |= over_correlation_times(stats, reach, argmax)
    integrated = fits | {names: fit.integrated for names, fit in over_times.items()}
    tc = {names: fit.tc_s for names, fit in over_times.items()}
    argmax |= {names: fit.u for names, fit in over_times.items()}
    # where G is bounded when no set with it has weight: the widest set's best time
    widest = max(widest_g, key=lambda s: (len(s), over_times[s].greatest), default=None)
    profile = stats if widest is None else replace(stats, gm_tc_s=tc[widest])
    bic = {"+".join(names): criterion(value, names) for names, value in integrated.items()}
    lowest = min(bic.values())
    raw = {names: math.exp(-0.5 * (bic["+".join(names)] - lowest)) for names in integrated}
    kept = {names: w for names, w in raw.items() if w >= MIN_WEIGHT}
    total = sum(kept.values())
    weights = {names: w / total for names, w in sorted(kept.items(), key=lambda i: -i[1])}
    included = {n: sum(w for names, w in weights.items() if n in names) for n in candidates}
    bounds = {}
    for name in (n for n in candidates if included[n] < 0.5):
        held = [_bound_in(profile, names, name, tc.get(names)) for names, w in weights.items()
                if w >= BOUNDED_WEIGHT and (len(names) > 1 or name not in names)]
        if held:
            bounds[name] = max(held)
    return TermChoice(weights, bic, bounds,
                      {names: tuple(map(float, argmax[names])) for names in weights},
                      {names: tc[names] for names in weights if names in tc},
                      profile.gm_tc_s)


class TimeFit(NamedTuple):
    """A set with G over G's correlation times: its log-likelihood with the time integrated
    out, its greatest, the time of that (s) and the log-amplitudes there."""

    integrated: float
    greatest: float
    tc_s: float
    u: np.ndarray


def over_correlation_times(stats: HaarStatistics, sets: list[tuple[str, ...]],
                           argmax: dict[tuple[str, ...], np.ndarray]
                           ) -> dict[tuple[str, ...], TimeFit]:
    """Per set of terms with G, its fit over :func:`gauss_markov_grid` (:class:`TimeFit`;
    the integral is the mean over the grid of the maximum likelihood at each time: a prior
    uniform in log correlation time). Each time's fit starts from the same set's at the
    time before and from the set without G (``argmax``) with G small (the first time's
    from the data's own start too; after it, that start changed no weight or bound on the
    250 logs of ``experiments/noise_coverage.py`` and cost a third of the noise fit's
    time)."""
    grid = gauss_markov_grid(stats)
    curves: dict[tuple[str, ...], list[tuple[float, np.ndarray]]] = {n: [] for n in sets}
    for tc in grid:
        at = replace(stats, gm_tc_s=float(tc))
        for names in sets:
            without = tuple(n for n in names if n != "G")
            previous = (curves[names][-1][1],) if curves[names] else ()
            starts = previous + nested_starts(
                at, names, {without: argmax[without]} if without in argmax else {})
            curves[names].append(max_likelihood(at, names, starts=starts,
                                                data_start=not curves[names]))
    out = {}
    for names, curve in curves.items():
        values = np.array([value for value, _ in curve])
        top = int(np.argmax(values))
        mean = values[top] + math.log(float(np.mean(np.exp(values - values[top]))))
        out[names] = TimeFit(mean, float(values[top]), float(grid[top]), curve[top][1])
    return out


def _bound_in(stats: HaarStatistics, names: tuple[str, ...], name: str,
              gm_tc_s: float | None) -> float:
    """The upper bound of ``name`` given the set ``names`` (added to it, or freed in it;
    beside the other of Q and F, that one left out), with G's correlation time the set's
    (``gm_tc_s``) where it has G."""
    base = tuple(n for n in names if n != name)
    if not compatible((*base, name)):
        base = tuple(n for n in base if n not in EXCLUSIVE)
    at = stats if gm_tc_s is None or name == "G" else replace(stats, gm_tc_s=gm_tc_s)
    return _upper_bound(at, base, name, max_likelihood(at, base or (name,))[0])


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
