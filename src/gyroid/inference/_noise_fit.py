"""A noise fit's result (:class:`NoiseFit`, ``noise.json``) and :func:`fit_noise`, which
chooses the terms a static log resolves, samples their posterior and checks it.

Self-checks: the ones every fit has (convergence, point against posterior, prior-data
conflict), and the fit of each averaging time: a level's Haar coefficients' mean square
over the model's ``2 AVAR`` is ``chi2(n)/n`` when the model is right; a level whose
two-sided p-value times the number of levels is below ``LEVEL_P`` with a ratio beyond
``LEVEL_RATIO`` (or its inverse) is an error (the Allan deviation there is off by more than
``sqrt(2)``: a process the terms lack, a log that is not static, or a temperature drift),
a significant but smaller misfit a warning.

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

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.stats import chi2

from gyroid.inference._check_report import Check, CheckReport
from gyroid.inference._emcee import Emcee
from gyroid.inference._fit import fit
from gyroid.inference._haar import HaarStatistics, haar_statistics
from gyroid.inference._noise_model_fit import NoiseModelFit
from gyroid.inference._noise_problem import (
    NoiseProblem,
    TermChoice,
    choose_terms,
    deviance,
)
from gyroid.inference._noise_terms import NOISE_TERMS, TERM_NAMES, shapes, term
from gyroid.inference._problem import AbstractSampler
from gyroid.inference._result import FitResult

LEVEL_P = 1e-4
DISPERSION_P = 1e-3
#: Beyond this dispersion the terms do not describe the log (an error, not a widening).
DISPERSION_MAX = 10.0
LEVEL_RATIO = 2.0


@dataclass(frozen=True, eq=False)
class NoiseFit(FitResult):
    """A static log's noise model, averaged over the sets of terms the log supports
    (weights by BIC): each term's posterior (datasheet units; zero in the draws of sets
    without it), upper bounds for the terms it does not resolve, the Haar statistics fitted
    and the checks."""

    choice: TermChoice
    stats: HaarStatistics
    models: tuple[tuple[float, NoiseModelFit], ...]
    mixture: np.ndarray = field(repr=False)  # (draws, every term of NOISE_TERMS)
    checks: CheckReport
    label: str = ""
    #: How many times more the Allan variance scatters about the model than independent
    #: Haar coefficients allow (1: no more than chance); the intervals are its root wider.
    dispersion: float = 1.0

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
        return self.mixture**2 @ shapes(stats, TERM_NAMES).T

    def term_avar(self, name: str, tau_s: np.ndarray) -> np.ndarray:
        """(taus,) one term's Allan variance at its posterior median amplitude."""
        a = float(np.median(self.draws(name)))
        return a**2 * shapes(_at(self.stats, np.asarray(tau_s)), (name,))[:, 0]

    def summary(self) -> str:
        """Each term the log resolves (mean, 90 % interval) or its upper bound, and the
        failed checks."""
        lines = [f"noise of {self.label or 'the log'}; terms (datasheet units):"]
        for name, entry in self.term_summaries().items():
            if entry["resolved"]:
                lo, hi = entry["ci90"]
                lines.append(f"  {name} = {entry['mean']:.4g} {entry['unit']} "
                             f"(90 %: {lo:.4g} ... {hi:.4g})")
            elif entry["upper_bound_95"] is not None:
                lines.append(f"  {name} < {entry['upper_bound_95']:.4g} {entry['unit']} "
                             "(95 %; not resolved)")
        return "\n".join([*lines, *(f"  {line}" for line in self.checks.lines()),
                          f"  {self.checks.verdict()}"])

    def term_summaries(self) -> dict[str, dict]:
        """Per term of :data:`NOISE_TERMS`: mean, sd, 90 % interval (or the upper bound of
        a term the log does not resolve), unit, process, inclusion probability."""
        out = {}
        for item in NOISE_TERMS:
            entry = {"unit": item.unit, "process": item.process,
                     "inclusion": round(self.choice.inclusion(item.name), 4)}
            if item.name in self.terms:
                x = self.draws(item.name)
                entry |= {"mean": float(x.mean()), "sd": float(x.std(ddof=1)),
                          "ci90": [float(v) for v in np.quantile(x, [0.05, 0.95])],
                          "resolved": True}
            else:
                entry |= {"mean": None, "sd": None, "ci90": None, "resolved": False,
                          "upper_bound_95": self.choice.upper_bound_95.get(item.name),
                          "why": item.unresolved_hint}
            out[item.name] = entry
        return out

    def to_json(self) -> dict:
        """``noise.json`` (docs/formats.md section 5)."""
        band = np.sqrt(np.quantile(self.model_avar(), [0.05, 0.5, 0.95], axis=0))
        return {
            "log": self.label,
            "terms": self.term_summaries(),
            "model": [{"name": n, "process": term(n).process, "unit": term(n).unit}
                      for n in self.terms],
            "models_averaged": [{"terms": list(m.terms), "weight": round(w, 6),
                                 "posterior": m.posterior.method,
                                 "r_hat_max": max(v["r_hat"] for v in
                                                  m.posterior.summary.values())}
                                for w, m in self.models],
            "allan": {"tau_s": self.stats.tau_s.tolist(),
                      "adev_deg_h": np.sqrt(self.stats.avar).tolist(),
                      "pairs": self.stats.count.astype(int).tolist(),
                      "model_adev_deg_h": band[1].tolist(),
                      "model_adev_90_deg_h": [band[0].tolist(), band[2].tolist()],
                      "estimator": "non-overlapping Haar (block pairs never across a gap)"},
            "sample_s": self.stats.tau0_s, "n_samples": self.stats.n_samples,
            "segments": self.stats.segments,
            "dispersion": self.dispersion,
            "bic": self.choice.bic,
            "checks": self.checks.to_json(),
            "trustworthy": self.trustworthy,
        }


def _at(stats: HaarStatistics, tau_s: np.ndarray) -> HaarStatistics:
    m = tau_s / stats.tau0_s
    return HaarStatistics(m, np.ones_like(m), np.ones_like(m), stats.tau0_s, stats.n_samples,
                          stats.segments)


def level_fit(stats: HaarStatistics, model_avar: np.ndarray) -> Check:
    """Each averaging time's Allan variance against the model's (module docstring)."""
    from scipy import stats as st

    ratio = stats.avar / model_avar
    lower = st.chi2.cdf(stats.count * ratio, stats.count)
    p = np.minimum(1.0, 2.0 * np.minimum(lower, 1.0 - lower) * ratio.size)
    size = np.maximum(ratio, 1.0 / ratio)
    significant = p < LEVEL_P
    worst = int(np.argmax(np.where(significant, size, 0.0))) if significant.any() else int(
        np.argmax(size))
    tau = stats.tau_s[worst]
    if not significant.any():
        return Check("level_fit", True, "error", float(size[worst]), LEVEL_RATIO,
                     f"every averaging time's Allan variance fits the model (worst ratio "
                     f"{ratio[worst]:.2f} at {tau:.3g} s)")
    severity = "error" if size[worst] > LEVEL_RATIO else "warning"
    side = "above" if ratio[worst] > 1 else "below"
    return Check("level_fit", False, severity, float(size[worst]), LEVEL_RATIO,
                 f"the Allan variance at {tau:.3g} s is {ratio[worst]:.2f} times the model's "
                 f"({side} it, p {p[worst]:.1g}): a process the noise terms lack, a log that "
                 "is not static, or a temperature drift; cut the log to a static stretch "
                 "or remove the drift first (gyroid compensate)",
                 ("discrepancy",))


#: Model-averaged draws kept.
MIXTURE_DRAWS = 8000
#: A set of terms whose weight is at least this has its own checks reported.
CHECKED_WEIGHT = 0.05


def fit_noise(rate_deg_h: np.ndarray, sample_s: float, *,
              segments: list[tuple[int, int]] | None = None, seed: int = 0,
              sampler: AbstractSampler | None = None, label: str = "") -> NoiseFit:
    """Fit a static rate log's noise (deg/h every ``sample_s`` seconds; ``segments``: its
    contiguous stretches): every set of terms the log supports sampled and averaged by
    weight, the checks of each set that matters and of the averaged model's fit to every
    averaging time."""
    stats = haar_statistics(rate_deg_h, sample_s, segments)
    choice = choose_terms(stats)
    lack, dof = deviance(stats, choice.best)
    dispersion = lack / dof if dof > 0 and chi2.sf(lack, dof) < DISPERSION_P else 1.0
    fitted = stats
    if dispersion > 1.0:
        fitted = stats.deflated(dispersion)
        choice = choose_terms(fitted)
        if dispersion > DISPERSION_MAX:  # refused: its best set alone is sampled, to show
            choice = replace(choice, weights={choice.best: 1.0})
    rng = np.random.default_rng(seed)
    sampler = sampler if sampler is not None else Emcee(progress=False)
    models, blocks = [], []
    for k, (names, weight) in enumerate(choice.weights.items()):
        problem = NoiseProblem.from_statistics(fitted, names, label)
        model = fit(problem, sampler=sampler, seed=seed + k)
        models.append((weight, model))
        draws = model.posterior.draws.reshape(-1, len(names))
        take = rng.integers(0, draws.shape[0], int(round(weight * MIXTURE_DRAWS)))
        block = np.zeros((take.size, len(TERM_NAMES)))
        block[:, [TERM_NAMES.index(n) for n in names]] = draws[take]
        blocks.append(block)
    mixture = np.concatenate(blocks)
    avar = np.median(mixture**2 @ shapes(stats, TERM_NAMES).T, axis=0)
    checks = [*models[0][1].checks.checks]
    for weight, model in models[1:]:
        if weight >= CHECKED_WEIGHT:
            checks += [replace(c, name=f"{c.name}[{'+'.join(model.terms)}]")
                       for c in model.checks.failed]
    checks.append(level_fit(stats, avar))
    checks.append(dispersion_check(dispersion, lack, dof))
    return NoiseFit(choice, stats, tuple(models), mixture, CheckReport(tuple(checks)), label,
                    dispersion)


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
