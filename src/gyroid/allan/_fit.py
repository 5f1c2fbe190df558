"""A noise fit's result (:class:`NoiseFit`, ``noise.json``) and :func:`fit_noise`, which
chooses the terms a static log resolves, samples their posterior and checks it.

Self-checks: the ones every fit has (convergence, point against posterior, prior-data
conflict), the outliers found before the Allan statistics (:mod:`gyroid.inference.
_noise_outliers`), the shortest averaging times a prefilter shapes, and the fit of each
averaging time alone and of runs of adjacent ones (:mod:`gyroid.allan._levels`).

Overdispersion: when the best set of terms leaves a deviance (over the levels) that
``chi2(levels - terms)`` gives a p-value below ``DISPERSION_P``, the Haar coefficients
scatter more than the model's independent ones can (a process the terms lack, or
coefficients correlated across levels, as a gyro's digital low-pass filter makes them):
the fit is redone with every level's coefficients worth ``1 / phi`` (``phi`` the deviance
over its degrees of freedom), a quasi-likelihood whose intervals and bounds are
``sqrt(phi)`` wider, and the ``dispersion`` check says so (a warning; beyond
``DISPERSION_MAX`` an error: the terms do not describe the log). On seven static runs
of one real MPU6050 (``experiments/noise_real_logs.py``) the independent-coefficient fit had
read N up to 44 % above both Allan readings, with a 1 % interval and exit 0, on runs whose
Allan variance has bumps at the shortest averaging times.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
from scipy.stats import chi2

from gyroid.allan._choice import TermChoice, choose_terms, deviance
from gyroid.allan._haar import HaarStatistics, haar_statistics
from gyroid.allan._interval import AllanInterval, MeasuredAllan, measure
from gyroid.allan._levels import (
    drop_prefiltered,
    level_fit,
    level_runs,
    prefilter_check,
)
from gyroid.allan._model_fit import NoiseModelFit
from gyroid.allan._outliers import remove_outliers
from gyroid.allan._problem import NoiseProblem
from gyroid.allan._terms import IEEE_TERMS, TERM_NAMES, shapes, term
from gyroid.inference._check_report import Check, CheckReport
from gyroid.inference._fit import fit
from gyroid.inference._problem import AbstractSampler
from gyroid.inference._result import FitResult

DISPERSION_P = 1e-3
#: Beyond this dispersion the terms do not describe the log (an error, not a widening).
DISPERSION_MAX = 10.0


@dataclass(frozen=True, eq=False)
class NoiseFit(FitResult):
    """A static log's noise model, averaged over the sets of terms the log supports
    (weights by BIC): each term's posterior (datasheet units; zero in the draws of sets
    without it), upper bounds for the terms it does not resolve, the Haar statistics fitted
    and the checks."""

    choice: TermChoice
    stats: HaarStatistics
    models: tuple[tuple[float, NoiseModelFit], ...]
    mixture: np.ndarray = field(repr=False)  # (draws, every static term: TERM_NAMES)
    #: (draws,) the G correlation time each draw's set was sampled at, s.
    mixture_tc_s: np.ndarray = field(repr=False)
    checks: CheckReport
    label: str = ""
    #: How many times more the Allan variance scatters about the model than independent
    #: Haar coefficients allow (1: no more than chance); the intervals are its root wider.
    dispersion: float = 1.0
    #: Per term a datasheet gives, the verdict against it (``gyroid noise --datasheet``).
    spec: dict | None = None
    #: The shortest levels left out for a prefilter (the ``prefilter`` check), None if none.
    left_out: HaarStatistics | None = None
    #: The overlapping Allan deviation with its interval under the model (``allan_interval``).
    overlapping: AllanInterval | None = None

    @property
    def terms(self) -> tuple[str, ...]:
        """The terms the log resolves (included with at least half the weight)."""
        return self.choice.resolved

    def draws(self, name: str) -> np.ndarray:
        """A term's model-averaged posterior draws, datasheet units."""
        return self.mixture[:, TERM_NAMES.index(name)]

    def model_avar(self, tau_s: np.ndarray | None = None) -> np.ndarray:
        """(draws, taus) the model's Allan variance, (deg/h)^2, at ``tau_s`` (default: the
        fitted levels')."""
        stats = self.stats if tau_s is None else _at(self.stats, np.asarray(tau_s))
        return mixture_avar(stats, self.mixture, self.mixture_tc_s)

    def term_avar(self, name: str, tau_s: np.ndarray) -> np.ndarray:
        """(taus,) one term's Allan variance at its posterior median amplitude (G's at
        its reported correlation time)."""
        a = float(np.median(self.draws(name)))
        stats = _at(self.stats, np.asarray(tau_s))
        if name == "G":
            stats = replace(stats, gm_tc_s=self.gm_tc_s)
        return a**2 * shapes(stats, (name,))[:, 0]

    @property
    def gm_tc_s(self) -> float:
        """G's correlation time, s: the median over the draws of sets with G (each sampled
        at its own best time), else the time that best fits every term together."""
        return median_gm_time(self.mixture, self.mixture_tc_s, self.stats.gm_tc_s)

    def term_lines(self) -> list[str]:
        """One line per term (:meth:`reported_terms` and F): its mean, 90 % interval, unit
        and process where the log resolves it (and, where that interval reaches zero, how
        likely the term is and its interval where present), else its 95 % upper bound and
        why not."""
        lines = []
        for name, entry in (self.reported_terms() | {"F": self.prefilter()}).items():
            when = f", correlation time {entry['tau_s']:.3g} s" if name == "G" else ""
            if entry["resolved"]:
                lo, hi = entry["ci90"]
                if lo <= 0.0:
                    low, high = entry["ci90_if_present"]
                    when += (f"; present with probability {entry['inclusion']:.2f}, where "
                             f"present [{low:.4g}, {high:.4g}]")
                lines.append(f"{name} = {entry['mean']:.4g} [{lo:.4g}, {hi:.4g}] "
                             f"{entry['unit']} ({entry['process']}{when})")
            elif entry["upper_bound_95"] is not None:
                why = f"; {entry['why']}" if entry.get("why") else ""
                lines.append(f"{name}: not resolved, below {entry['upper_bound_95']:.3g} "
                             f"{entry['unit']} (95 %{why})")
        return lines

    def spec_lines(self) -> list[str]:
        """One line per term a datasheet gives: its value against the measured interval."""
        return [f"{name} against the datasheet's {verdict['datasheet']:.4g} {verdict['unit']}: "
                f"{verdict['verdict']} (measured {verdict['measured'][0]:.4g} ... "
                f"{verdict['measured'][1]:.4g})" for name, verdict in (self.spec or {}).items()]

    def summary(self) -> str:
        """Each term the log resolves (mean, 90 % interval) or its upper bound, the
        datasheet's verdicts, and the failed checks."""
        lines = [f"noise of {self.label or 'the log'}; terms (datasheet units):",
                 *self.term_lines(), *self.spec_lines()]
        return "\n".join([lines[0], *(f"  {line}" for line in lines[1:]),
                          *(f"  {line}" for line in self.checks.lines()),
                          f"  {self.checks.verdict()}"])

    def term_summaries(self) -> dict[str, dict]:
        """Per IEEE term (:data:`IEEE_TERMS`): mean, sd, 90 % interval (or the upper bound
        of a term the log does not resolve), unit, process, inclusion probability."""
        return {name: self._term_summary(name) for name in IEEE_TERMS}

    def reported_terms(self) -> dict[str, dict]:
        """:meth:`term_summaries` and, when the log had one to try, G
        (:meth:`gauss_markov`): what the summary and the command line print."""
        gm = self.gauss_markov()
        return self.term_summaries() | ({"G": gm} if gm is not None else {})

    def gauss_markov(self) -> dict | None:
        """The Gauss-Markov bias G as :meth:`term_summaries` gives a term, with its
        correlation time ``tau_s`` (s, :attr:`gm_tc_s`); None when the log has too few
        averaging times to try one."""
        if not np.isfinite(self.stats.gm_tc_s):
            return None
        return self._term_summary("G") | {"tau_s": self.gm_tc_s}

    def prefilter(self) -> dict:
        """The prefilter's deficit F as :meth:`term_summaries` gives a term (an amplitude of
        quantisation's shape that the Allan variance lies below white noise by)."""
        return self._term_summary("F")

    def _term_summary(self, name: str) -> dict:
        item = term(name)
        entry = {"unit": item.unit, "process": item.description,
                 "inclusion": round(self.choice.inclusion(name), 4)}
        if name in self.terms:
            x = self.draws(name)
            present = x[x > 0.0]  # the draws of the sets with the term
            return entry | {"mean": float(x.mean()), "sd": float(x.std(ddof=1)),
                            "ci90": [float(v) for v in np.quantile(x, [0.05, 0.95])],
                            "ci90_if_present": [float(v) for v in
                                                np.quantile(present, [0.05, 0.95])],
                            "resolved": True}
        return entry | {"mean": None, "sd": None, "ci90": None, "resolved": False,
                        "upper_bound_95": self.choice.upper_bound_95.get(name),
                        "why": item.unresolved_hint}

    def to_json(self) -> dict:
        """``noise.json`` (docs/formats.md section 5)."""
        band = np.sqrt(np.quantile(self.model_avar(), [0.05, 0.5, 0.95], axis=0))
        return {
            "log": self.label,
            "terms": self.term_summaries(),
            "gauss_markov": self.gauss_markov(),
            "prefilter": self.prefilter(),
            "model": [{"name": n, "process": term(n).description, "unit": term(n).unit}
                      for n in self.terms],
            "models_averaged": [{"terms": list(m.terms), "weight": round(w, 6),
                                 "posterior": m.sampled.method,
                                 "r_hat_max": max(v["r_hat"] for v in
                                                  m.sampled.summary.values())}
                                for w, m in self.models],
            "allan": {"tau_s": self.stats.tau_s.tolist(),
                      "adev_deg_h": np.sqrt(self.stats.avar).tolist(),
                      "pairs": self.stats.count.astype(int).tolist(),
                      "model_adev_deg_h": band[1].tolist(),
                      "model_adev_90_deg_h": [band[0].tolist(), band[2].tolist()],
                      "estimator": "non-overlapping Haar (block pairs never across a gap)",
                      "overlapping": (None if self.overlapping is None
                                      else self.overlapping.to_json()),
                      "left_out": None if self.left_out is None else {
                          "tau_s": self.left_out.tau_s.tolist(),
                          "adev_deg_h": np.sqrt(self.left_out.avar).tolist(),
                          "pairs": self.left_out.count.astype(int).tolist()}},
            "sample_s": self.stats.tau0_s, "n_samples": self.stats.n_samples,
            "segments": self.stats.segments,
            "dispersion": self.dispersion,
            "bic": self.choice.bic,
            "checks": self.checks.to_json(),
            "trustworthy": self.trustworthy,
        } | ({"spec": self.spec} if self.spec is not None else {})


def _at(stats: HaarStatistics, tau_s: np.ndarray) -> HaarStatistics:
    m = tau_s / stats.tau0_s
    return HaarStatistics(m, np.ones_like(m), np.ones_like(m), stats.tau0_s, stats.n_samples,
                          stats.segments, stats.gm_tc_s)


#: Model-averaged draws kept.
MIXTURE_DRAWS = 8000
#: A set of terms whose weight is at least this has its own checks reported.
CHECKED_WEIGHT = 0.05


def fit_noise(rate_deg_h: np.ndarray, sample_s: float, *,
              segments: list[tuple[int, int]] | None = None, seed: int = 0,
              sampler: AbstractSampler | None = None, label: str = "",
              where: Callable[[int], str] | None = None) -> NoiseFit:
    """Fit a static rate log's noise (deg/h every ``sample_s`` seconds; ``segments``: its
    contiguous stretches): every set of terms the log supports sampled and averaged by
    weight, the checks of each set that matters and of the averaged model's fit to every
    averaging time, and of what it states (each term's interval, or its bound) against the
    log's overlapping Allan deviation."""
    cleaned, outliers = remove_outliers(rate_deg_h, segments, sample_s=sample_s)
    every_level = haar_statistics(cleaned, sample_s, segments)
    stats, prefiltered = drop_prefiltered(every_level)
    left_out = every_level.levels(slice(None, prefiltered)) if prefiltered else None
    choice = choose_terms(stats)
    stats = replace(stats, gm_tc_s=choice.profile_tc_s)
    lack, dof = deviance(choice.stats_for(stats, choice.best), choice.best)
    dispersion = lack / dof if dof > 0 and chi2.sf(lack, dof) < DISPERSION_P else 1.0
    fitted = stats
    if dispersion > 1.0:
        fitted = stats.deflated(dispersion)
        choice = choose_terms(fitted)  # every likelihood scaled alike: the same best times
        if dispersion > DISPERSION_MAX:  # refused: its best set alone is sampled, to show
            choice = replace(choice, weights={choice.best: 1.0})
    measured = measure(cleaned, stats, segments or [(0, cleaned.size)])
    average = _averaged(choice, stats, fitted, measured, seed=seed, sampler=sampler,
                        label=label)
    models, mixture, mixture_tc, avar, overlapping = average
    checks = [*models[0][1].checks.checks]
    for weight, model in models[1:]:
        if weight >= CHECKED_WEIGHT:
            checks += [replace(c, name=f"{c.name}[{'+'.join(model.terms)}]")
                       for c in model.checks.failed]
    checks.append(outliers.check(where))
    checks.append(prefilter_check(prefiltered, sample_s))
    checks.append(level_fit(stats, avar))
    checks.append(level_runs(stats, avar))
    checks.append(dispersion_check(dispersion, lack, dof))
    checks.append(overlapping.check())
    return NoiseFit(choice, stats, models, mixture, mixture_tc, CheckReport(tuple(checks)),
                    label, dispersion, left_out=left_out, overlapping=overlapping)


class _Average(NamedTuple):
    """The sampled sets of terms (weight, fit), the model-averaged draws and their G times,
    the median model's Allan variance per level and the overlapping interval against it."""

    models: tuple[tuple[float, NoiseModelFit], ...]
    mixture: np.ndarray
    mixture_tc_s: np.ndarray
    avar: np.ndarray
    overlapping: AllanInterval


def _averaged(choice: TermChoice, stats: HaarStatistics, fitted: HaarStatistics,
              measured: MeasuredAllan, *, seed: int, sampler: AbstractSampler | None,
              label: str) -> _Average:
    """Each weighed set of ``choice`` sampled on ``fitted`` (``stats``, deflated for
    overdispersion) and their draws mixed by weight; the overlapping Allan deviation
    against the model's 90 % band, its top raised by any one unresolved term at its upper
    bound (``stats``' G time, the bound's; an unresolved F lowers its foot)."""
    rng = np.random.default_rng(seed)
    models, blocks, times = [], [], []
    for k, (names, weight) in enumerate(choice.weights.items()):
        problem = NoiseProblem.from_statistics(choice.stats_for(fitted, names), names, label,
                                               choice.argmax.get(names, ()))
        model = fit(problem, sampler=sampler, seed=seed + k)
        models.append((weight, model))
        draws = model.sampled.draws.reshape(-1, len(names))
        take = rng.integers(0, draws.shape[0], int(round(weight * MIXTURE_DRAWS)))
        block = np.zeros((take.size, len(TERM_NAMES)))
        block[:, [TERM_NAMES.index(n) for n in names]] = draws[take]
        blocks.append(block)
        times.append(np.full(take.size, choice.gm_tc_s.get(names, stats.gm_tc_s)))
    mixture, mixture_tc = np.concatenate(blocks), np.concatenate(times)
    levels = mixture_avar(stats, mixture, mixture_tc)
    avar = np.median(levels, axis=0)
    bounded = np.array([bound**2 * shapes(stats, (name,))[:, 0]
                        for name, bound in choice.upper_bound_95.items()
                        if np.isfinite(bound)]).reshape(-1, stats.m.size)
    # any one unresolved term up to its bound raises the band's top (F, a deficit, its
    # foot): each bound is its own statement, not all of them at once
    band = np.stack([np.maximum(np.quantile(levels, 0.05, axis=0)
                                + np.minimum(bounded, 0.0).min(axis=0, initial=0.0), 0.0),
                     avar,
                     np.quantile(levels, 0.95, axis=0)
                     + np.maximum(bounded, 0.0).max(axis=0, initial=0.0)])
    amplitudes = {name: float(np.median(mixture[:, k])) for k, name in enumerate(TERM_NAMES)}
    tc_s = median_gm_time(mixture, mixture_tc, stats.gm_tc_s)
    return _Average(tuple(models), mixture, mixture_tc, avar,
                    measured.against(amplitudes, tc_s, band, stats))


def median_gm_time(mixture: np.ndarray, tc_s: np.ndarray, otherwise: float) -> float:
    """G's correlation time (s): the median over the model-averaged draws of sets with G
    (``tc_s`` each draw's), else ``otherwise``."""
    with_g = mixture[:, TERM_NAMES.index("G")] > 0
    return float(np.median(tc_s[with_g])) if with_g.any() else otherwise


def mixture_avar(stats: HaarStatistics, mixture: np.ndarray, tc_s: np.ndarray) -> np.ndarray:
    """(draws, levels) the Allan variance of each model-averaged draw (amplitudes of every
    term, :data:`TERM_NAMES`; ``tc_s`` its set's G correlation time), (deg/h)^2."""
    avar = np.zeros((mixture.shape[0], stats.m.size))
    for tc in np.unique(tc_s):
        rows = tc_s == tc if np.isfinite(tc) else ~np.isfinite(tc_s)
        at = replace(stats, gm_tc_s=float(tc))
        avar[rows] = mixture[rows] ** 2 @ shapes(at, TERM_NAMES).T
    return avar


def dispersion_check(dispersion: float, lack: float, dof: int) -> Check:
    """Whether the Allan variance scatters about the model more than chance allows (module
    docstring): a warning while the widened intervals serve, an error beyond
    ``DISPERSION_MAX``."""
    if dispersion == 1.0:
        return Check("dispersion", True, "warning", lack / max(dof, 1), DISPERSION_MAX,
                     f"the Allan variance scatters about the model as chance allows "
                     f"(deviance {lack:.3g} on {dof} degrees of freedom)")
    what = (f"the Allan variance scatters about the model {dispersion:.3g} times more than "
            f"independent Haar coefficients allow (deviance {lack:.3g} on {dof} degrees of "
            "freedom)")
    if dispersion > DISPERSION_MAX:
        return Check("dispersion", False, "error", dispersion, DISPERSION_MAX,
                     f"{what}: the noise terms do not describe this log (look at allan.png "
                     "for a bump: a vibration, a filtered output, samples dropped or "
                     "repeated by the logger), so its numbers are not a datasheet's")
    return Check("dispersion", False, "warning", dispersion, DISPERSION_MAX,
                 f"{what}: a process the terms lack, or a filtered output; every interval "
                 f"and bound is widened {dispersion ** 0.5:.2g}x for it")
