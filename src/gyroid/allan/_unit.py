"""A unit's noise terms (or a lot's) from several static runs: what a datasheet or an
estimator wants, where one run's interval describes that run only.

Per IEEE term, the runs whose fits are trustworthy and resolve it give ``y_i``, the log of
its posterior median, and ``s_i``, its posterior sd on that scale (from the 90 % interval).
They are pooled by the random-effects model ``y_i ~ N(mu, tau^2 + s_i^2)``: ``mu`` the
unit's log-term (flat prior), ``tau`` the run-to-run spread of the log (half-normal prior,
sd :data:`SPREAD_PRIOR_SD`: a factor ``exp(0.5) = 1.65`` at one sd). ``tau``'s posterior is
computed on a grid (``mu`` integrated out exactly), ``mu`` drawn from its normal
conditional, and a new run's term from ``N(mu, tau^2 + s^2)`` (``s`` the runs' median
``s_i``): the interval a further run's fit should land in. On six 2.8 h runs of one
ADIS16405 each run's N had an interval of +/-0.3 % while the runs differed by up to 9 %.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2, norm

from gyroid.allan._fit import NoiseFit
from gyroid.allan._terms import IEEE_TERMS, term
from gyroid.inference._check_report import Check, CheckReport
from gyroid.inference._result import FitResult

#: Prior sd of a term's run-to-run spread on the log scale.
SPREAD_PRIOR_SD = 0.5
#: The spread's grid: points, and its top (a factor exp(3) = 20 between runs).
GRID_POINTS, GRID_TOP = 4001, 3.0
#: Draws of the unit's and a new run's term.
UNIT_DRAWS = 8000
_Z90 = float(norm.isf(0.05))


@dataclass(frozen=True)
class UnitTerm:
    """One term over the runs that resolve it: each run's posterior median and 90 %
    interval, the unit's (``exp(mu)``), the run-to-run spread (``exp(tau)``, a factor at one
    sd), a new run's 90 % interval, and Cochran's homogeneity p-value (small: the runs
    differ by more than their intervals)."""

    name: str
    runs: tuple[str, ...]
    run_median: tuple[float, ...]
    run_ci90: tuple[tuple[float, float], ...]
    unit_median: float
    unit_ci90: tuple[float, float]
    spread_median: float
    spread_ci90: tuple[float, float]
    new_run_ci90: tuple[float, float]
    homogeneity_p: float

    @property
    def runs_inside(self) -> int:
        """The runs whose median lies inside :attr:`new_run_ci90`."""
        lo, hi = self.new_run_ci90
        return sum(lo <= m <= hi for m in self.run_median)

    def to_json(self) -> dict:
        item = term(self.name)
        return {"unit": item.unit, "process": item.description,
                "runs": {r: {"median": m, "ci90": list(c)} for r, m, c in
                         zip(self.runs, self.run_median, self.run_ci90, strict=True)},
                "unit_median": self.unit_median, "unit_ci90": list(self.unit_ci90),
                "run_to_run_factor": self.spread_median,
                "run_to_run_factor_ci90": list(self.spread_ci90),
                "new_run_ci90": list(self.new_run_ci90), "runs_inside": self.runs_inside,
                "homogeneity_p": self.homogeneity_p}


@dataclass(frozen=True, eq=False)
class UnitNoise(FitResult):
    """The noise terms of the unit behind several runs (module docstring) and the checks."""

    labels: tuple[str, ...]
    fits: tuple[NoiseFit, ...] = field(repr=False)
    terms: dict[str, UnitTerm]
    checks: CheckReport

    def summary(self) -> str:
        lines = [f"noise of the unit behind {len(self.labels)} runs (median, 90 %):"]
        for name, t in self.terms.items():
            unit = term(name).unit
            lines.append(
                f"  {name} = {t.unit_median:.4g} {unit} ({t.unit_ci90[0]:.4g} ... "
                f"{t.unit_ci90[1]:.4g}); a new run: {t.new_run_ci90[0]:.4g} ... "
                f"{t.new_run_ci90[1]:.4g} ({t.runs_inside} of {len(t.runs)} runs inside); "
                f"run to run x{t.spread_median:.3g}")
        return "\n".join([*lines, *(f"  {line}" for line in self.checks.lines()),
                          f"  {self.checks.verdict()}"])

    def to_json(self) -> dict:
        return {"runs": list(self.labels),
                "run_trustworthy": {label: fit.trustworthy
                                    for label, fit in zip(self.labels, self.fits, strict=True)},
                "terms": {name: t.to_json() for name, t in self.terms.items()},
                "model": "log term ~ N(unit, spread^2 + run sd^2); spread ~ half-normal("
                         f"{SPREAD_PRIOR_SD}); unit flat",
                "checks": self.checks.to_json(), "trustworthy": self.trustworthy}


def _run_summary(fit: NoiseFit, name: str) -> tuple[float, float, float, float] | None:
    """(log median, its sd, 5 %, 95 %) of a run's term, or None when the run's fit is not
    trustworthy or does not resolve it."""
    if not fit.trustworthy or name not in fit.terms:
        return None
    draws = fit.draws(name)
    draws = draws[draws > 0]
    if draws.size < 10:
        return None
    lo, med, hi = np.quantile(draws, [0.05, 0.5, 0.95])
    return float(np.log(med)), max(float(np.log(hi / lo)) / (2 * _Z90), 1e-9), lo, hi


def pool_term(name: str, labels: Sequence[str], y: np.ndarray, s: np.ndarray,
              intervals: Sequence[tuple[float, float]], rng: np.random.Generator) -> UnitTerm:
    """The random-effects pooling of one term's log values ``y`` with sds ``s``."""
    tau = np.linspace(0.0, GRID_TOP, GRID_POINTS)
    var = tau[:, None] ** 2 + s[None, :] ** 2
    w = 1.0 / var
    mean = (w @ y) / w.sum(axis=1)
    log_post = (-0.5 * (tau / SPREAD_PRIOR_SD) ** 2 - 0.5 * np.log(var).sum(axis=1)
                - 0.5 * np.log(w.sum(axis=1)) - 0.5 * (w * (y[None, :] - mean[:, None]) ** 2)
                .sum(axis=1))
    prob = np.exp(log_post - log_post.max())
    cdf = np.cumsum(prob) / prob.sum()
    pick = np.minimum(np.searchsorted(cdf, rng.uniform(size=UNIT_DRAWS)), tau.size - 1)
    tau_draws = tau[pick]
    mu = mean[pick] + rng.standard_normal(UNIT_DRAWS) / np.sqrt(w[pick].sum(axis=1))
    new = mu + np.sqrt(tau_draws**2 + float(np.median(s)) ** 2) * rng.standard_normal(
        UNIT_DRAWS)
    w0 = 1.0 / s**2
    cochran = float(np.sum(w0 * (y - (w0 @ y) / w0.sum()) ** 2))
    def q(x: np.ndarray) -> tuple[float, float]:
        low, high = np.exp(np.quantile(x, [0.05, 0.95]))
        return float(low), float(high)

    return UnitTerm(name, tuple(labels), tuple(float(v) for v in np.exp(y)),
                    tuple((float(a), float(b)) for a, b in intervals),
                    float(np.exp(np.median(mu))), q(mu), float(np.exp(np.median(tau_draws))),
                    q(tau_draws), q(new), float(chi2.sf(cochran, y.size - 1)))


def fit_unit_noise(fits: Sequence[NoiseFit], labels: Sequence[str], *, seed: int = 0
                   ) -> UnitNoise:
    """Pool several runs' noise fits into their unit's terms (module docstring). A run
    whose fit is not trustworthy is left out (a warning names it); a term fewer than two
    runs resolve is not pooled; no pooled N is an error."""
    rng = np.random.default_rng(seed)
    terms = {}
    for name in IEEE_TERMS:
        rows = [(label, r) for label, fit in zip(labels, fits, strict=True)
                if (r := _run_summary(fit, name)) is not None]
        if len(rows) >= 2:
            y = np.array([r[0] for _, r in rows])
            s = np.array([r[1] for _, r in rows])
            terms[name] = pool_term(name, [lab for lab, _ in rows], y, s,
                                    [(r[2], r[3]) for _, r in rows], rng)
    refused = [label for label, fit in zip(labels, fits, strict=True) if not fit.trustworthy]
    checks = [Check("runs", not refused, "warning", float(len(refused)), 0.0,
                    "every run's fit is trustworthy" if not refused else
                    f"left out (their fits are not trustworthy): {', '.join(refused)}"),
              Check("unit_resolved", "N" in terms, "error", float(len(terms)), 1.0,
                    "N is pooled over " + f"{len(terms['N'].runs)} runs" if "N" in terms else
                    "fewer than two trustworthy runs resolve N: no unit to speak of")]
    return UnitNoise(tuple(labels), tuple(fits), terms, CheckReport(tuple(checks)))
