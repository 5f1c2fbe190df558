"""The discrepancy workflow: where does a model disagree with a log, which missing effect
explains it, and how much does adding it close the gap?

Evidence. Every candidate model is a :class:`~gyroid.bench.BenchProblem` under a white +
Gauss-Markov noise model (``white+gm``, flat priors on the effects'
coefficients) and is fitted by the problem's own mode-finder, so slowly wandering noise
(bias instability) is not mistaken for an effect; the log-likelihood compared is the
problem's at that mode (a long log's rows are read as the exact block means of its
noise model). A candidate effect is scored by the BIC
difference ``dBIC = 2 (logL_with - logL_without) - k log n`` (``k`` its parameters, ``n``
rows), the large-sample (Laplace) approximation to twice the log Bayes factor. A candidate
is added when ``dBIC > 10`` ("very strong" on the Kass-Raftery scale: a Bayes factor above
150 after paying for the extra parameters). Each model's noise levels are its own mode's, so
an effect is not hidden by a noise model fitted without it. Two candidates whose scores are
within ``AMBIGUITY_DBIC`` of each other (a Bayes factor below 20) are reported as
interchangeable on this log.

Where the pieces live: the fits compared, :class:`~gyroid.bench.BenchProblem`; where and
with what the residuals disagree, and the "unexplained" test's reading,
:mod:`gyroid.workflows._residual_structure`; the greedy loop and the report (shared with roll
logs), :mod:`gyroid.workflows._discrepancy_report`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from gyroid.bench._checks import bench_checks
from gyroid.bench._options import BenchOptions
from gyroid.bench._problem import BenchProblem
from gyroid.bench._rate_window import choose_rate_window
from gyroid.errors import GyroidInputError
from gyroid.inference._problem import PointEstimate
from gyroid.io._logs import BenchLog, block_means
from gyroid.models import _effects as registry
from gyroid.models._drift import DriftModel
from gyroid.models._effects import EFFECTS, EXTRA_PREFIX, parameter
from gyroid.models._inputs import T0_C, DriftInputs
from gyroid.models._terms import resolve_terms
from gyroid.workflows._discrepancy_report import (
    DiscrepancyReport,
    NoiseLevels,
    Search,
    Step,
    Trial,
    add_while_evidence,
)
from gyroid.workflows._residual_structure import (
    MIN_FOLLOW_R,
    correlations,
    explaining_regressor,
    find_unexplained,
    flexible_columns,
    regressors,
    where_largest,
)

#: Fast logs are searched on means over about this long, s.
MEAN_OVER_S = 1.0
#: dBIC a candidate must reach to be added.
ADD_THRESHOLD = 10.0


#: Rate-estimator windows tried on logs whose model reads dT/dt, s.
RATE_WINDOWS_S = (300.0, 600.0, 1200.0)


def _applicable(
    effect: str, terms: tuple[str, ...], log: BenchLog, inputs: DriftInputs
) -> str | None:
    """Why a candidate cannot be tried on this log (None when it can)."""
    e = registry.effect(effect)
    missing = [c for c in e.columns if not log.has(c)]
    if missing:
        return f"the log has no {missing[0]} column"
    if any(need not in terms for need in e.needs_effects):
        return f"needs {', '.join(e.needs_effects)} in the model"
    try:
        DriftModel(terms=resolve_terms((*terms, effect))).check_identifiable(
            inputs, frozenset(log.columns)
        )
    except GyroidInputError as error:
        return str(error)
    return None


def _choose_rate_window(log: BenchLog, model: DriftModel, t0_C: float) -> float:
    """The rate window on the workflow's short grid (the fit's ``auto`` uses a wider one)."""
    return choose_rate_window(log, model, t0_C=t0_C, grid=np.asarray(RATE_WINDOWS_S))[0]


def _motion(column: str) -> bool:
    """A column that records motion (an accelerometer's), by its name."""
    name = column.lower()
    return any(key in name for key in ("accel", "acc_", "vibration")) or name in (
        "ax", "ay", "az")


def _plotted_regressor(steps: list[Step], regs: dict[str, np.ndarray], residual: np.ndarray
                       ) -> tuple[str, np.ndarray] | None:
    """What the figure draws the baseline residual against: the regressor the first added
    effect follows, else the one the residuals correlate with most."""
    name = steps[0].regressor if steps else next(iter(correlations(residual, regs)),
                                                 "elapsed time")
    return (name, regs[name]) if name in regs else None


def find_discrepancies(
    log: BenchLog,
    terms: str | tuple[str, ...],
    *,
    candidates: tuple[str, ...] | None = None,
    max_added: int = 3,
    t0_C: float = T0_C,
    progress=None,
) -> DiscrepancyReport:
    """Fit ``terms``, find what is missing from the registry's effects, add it, repeat.

    A fast log (samples closer than ``MEAN_OVER_S / 2``) is searched on means of equal runs
    of samples lasting about ``MEAN_OVER_S``: every candidate is slow against a second, a
    mean's white noise is a sample's over sqrt(samples), and the likelihood ratios are the
    samples' own (the within-mean scatter does not depend on the model), so the scores keep
    the samples' BIC penalty (``log n`` of the samples) while each fit costs per mean."""
    say = progress or (lambda _msg: None)
    n_samples = log.n
    start = DriftModel.from_terms(terms)
    search = _search_on(log, start, t0_C, say)
    start.check_identifiable(search.inputs, frozenset(search.log.columns))
    pool = candidates or tuple(
        [name for name in EFFECTS if name not in start.terms]
        + [EXTRA_PREFIX + column for column in search.log.extra_columns])
    found = add_while_evidence(
        search.trial(start), pool, try_adding=search.try_adding, describe=search.describe,
        n=n_samples, threshold=ADD_THRESHOLD, max_added=max_added, progress=say)
    say("  testing the final model against a flexible term ...")
    return search.report(found)


def _search_on(log: BenchLog, model: DriftModel, t0_C: float,
               say: Callable[[str], None] = lambda _m: None) -> _Search:
    """The search on ``log`` (on means of samples lasting about ``MEAN_OVER_S`` for a fast
    log) with the rate window chosen for ``model``."""
    step = float(np.median(np.diff(log.time_s))) if log.n > 1 else MEAN_OVER_S
    per_mean = round(MEAN_OVER_S / step) if step < MEAN_OVER_S / 2 else 1
    if per_mean > 1:
        say(f"  searching on means of {per_mean} samples ({per_mean * step:.3g} s) ...")
        log = block_means(log, per_mean)
    return _Search(log, per_mean, _choose_rate_window(log, model, t0_C), t0_C)


#: The extra column standing for a step at a given time (``step_at_time``).
STEP_COLUMN = "step_at_given_time"


def _with_columns(log: BenchLog, extra: dict[str, np.ndarray]) -> BenchLog:
    """``log`` with further extra columns (candidates' regressors)."""
    return BenchLog(columns=dict(log.columns) | extra, source=log.source,
                    comments=log.comments, extra_columns=(*log.extra_columns, *extra),
                    axis=log.axis)


def step_at_time(log: BenchLog, terms: tuple[str, ...], time_h: float, *,
                 t0_C: float = T0_C) -> tuple[float, float]:
    """The evidence for a bias step at a time given from outside this log (another axis's
    step), added to ``terms``: its dBIC (one parameter, its size: the time is not searched,
    so the penalty is ``log n``) and its size, deg/h; scored as :func:`find_discrepancies`
    scores candidates."""
    elapsed_h = (np.asarray(log.time_s) - log.time_s[0]) / 3600.0
    stepped = _with_columns(log, {STEP_COLUMN: (elapsed_h >= time_h).astype(float)})
    model = DriftModel(terms=resolve_terms(terms))
    search = _search_on(stepped, model, t0_C)
    without = search.trial(model)
    added = search.trial(DriftModel(terms=resolve_terms((*terms, EXTRA_PREFIX + STEP_COLUMN))))
    dbic = 2.0 * (added.log_likelihood - without.log_likelihood) - math.log(log.n)
    return dbic, float(added.fit.values["w_extra_" + STEP_COLUMN])


@dataclass(frozen=True)
class SearchFit:
    """A candidate model fitted by its problem: the mode and the residual on the search's
    rows (deg/h); its values, RMS and noise levels follow from them."""

    problem: BenchProblem
    point: PointEstimate
    residual: np.ndarray

    @property
    def values(self) -> dict[str, float]:
        """The model's parameters at the mode, natural units."""
        return {name: self.point.value[name] for name in self.problem.model.parameter_names}

    @property
    def noise(self) -> NoiseLevels:
        value = self.point.value
        return NoiseLevels(value["sigma_deg_h"], value["sigma_gm_deg_h"], value["tau_gm_s"])

    @property
    def rms(self) -> float:
        return float(np.sqrt(np.mean(self.residual**2)))


class _Search:
    """The discrepancy search on one log (or its means): its inputs, the fits it compares,
    the step descriptions and the final report."""

    def __init__(self, log: BenchLog, per_mean: int, window_s: float, t0_C: float) -> None:
        self.log, self.per_mean, self.window_s, self.t0_C = log, per_mean, window_s, t0_C
        self.inputs = log.inputs(t0_C=t0_C, rate_window_s=window_s)
        self.time_s = np.asarray(log.time_s)
        self.y = np.asarray(log.drift_deg_h)
        self.regs = regressors(self.inputs)
        self.of_means = f" (of {per_mean}-sample means)" if per_mean > 1 else ""

    def fit(self, model: DriftModel, log: BenchLog | None = None) -> SearchFit:
        """``model`` fitted to the search's log (or to ``log``, the same rows with more
        columns) by its problem under white + Gauss-Markov noise, flat coefficient
        priors."""
        log = self.log if log is None else log
        problem = BenchProblem.from_log(log, model, BenchOptions(
            noise="white+gm", prior_set="flat", t0_C=self.t0_C, rate_window_s=self.window_s,
            errors_in_variables=False))
        point = problem.mode()
        inputs = self.inputs if log is self.log else log.inputs(
            t0_C=self.t0_C, rate_window_s=self.window_s)
        theta = jnp.asarray([point.value[name] for name in model.parameter_names])
        return SearchFit(problem, point, self.y - np.asarray(model.predict(theta, inputs)))

    def trial(self, model: DriftModel) -> Trial:
        fit = self.fit(model)
        return Trial(model.terms, fit.problem.log_likelihood(fit.point.u),
                     len(model.parameters), fit)

    def try_adding(self, current: Trial, name: str) -> Trial | str:
        reason = _applicable(name, current.terms, self.log, self.inputs)
        if reason:
            return reason
        return self.trial(DriftModel(terms=resolve_terms((*current.terms, name))))

    def flexible_gain(self, final: Trial) -> tuple[float, np.ndarray]:
        """Twice the log-likelihood the flexible term (:func:`~gyroid.workflows.
        _residual_structure.flexible_columns`) adds to the final model, and its fitted
        curve on the search's rows, deg/h."""
        columns = flexible_columns(self.time_s)
        names = tuple(EXTRA_PREFIX + name for name in columns)
        model = DriftModel(terms=resolve_terms((*final.terms, *names)))
        flexible = self.fit(model, _with_columns(self.log, columns))
        curve = sum(flexible.values["w_extra_" + name] * values
                    for name, values in columns.items())
        gain = flexible.problem.log_likelihood(flexible.point.u) - final.log_likelihood
        return 2.0 * gain, np.asarray(curve)

    def describe(self, best, current, chosen, scores, rivals) -> Step:
        before, after = current.fit, chosen.fit
        effect = registry.effect(best)
        regressor, r = explaining_regressor(before.residual, before.residual - after.residual,
                                             self.regs, self.time_s, effect.signature)
        scale = "on 60 s means"
        if regressor in self.regs:  # sample by sample, a fast cause can show where means do not
            r_samples = float(np.corrcoef(before.residual, self.regs[regressor])[0, 1])
            if abs(r_samples) > abs(r):
                r, scale = r_samples, "sample by sample"
        if abs(r) >= MIN_FOLLOW_R:
            follows = f"residuals follow {regressor} (r = {r:.2f} {scale})"
        else:  # the effect's own form explains them: its RMS cut below says how much
            follows = (f"the residuals follow no single logged quantity closely (at most "
                       f"r = {r:.2f}, with {regressor}, {scale})")
        if best.startswith(EXTRA_PREFIX) and _motion(best[len(EXTRA_PREFIX):]):
            follows += " (a motion channel: handling or vibration, not a cause of drift)"
        size = {name: after.values[name] for name in effect.parameter_names}
        fitted = ", ".join(f"{name} = {value:.4g} {parameter(name).unit}"
                           for name, value in size.items())
        evidence = (
            f"{follows}; adding {best} ({fitted}) cuts the RMS{self.of_means} from "
            f"{before.rms:#.3g} to {after.rms:#.3g} deg/h; dBIC = {scores[best]:.1f} "
            f"(threshold {ADD_THRESHOLD:g})"
            + (f"; nearly interchangeable here with {', '.join(rivals)}" if rivals else "")
            + ("; it is a function of time alone, so it says when, not why: on a longer log "
               "it may prove a stand-in for a slow cause" if effect.reads_only_clock else "")
        )
        return Step(best, evidence, before.rms, after.rms, scores[best], scores, rivals,
                    regressor, r, size)

    def report(self, found: Search) -> DiscrepancyReport:
        baseline, final = found.baseline.fit, found.final.fit
        noise = final.noise
        return DiscrepancyReport(
            log_kind="bench",
            unexplained=find_unexplained(self.time_s, final.residual, noise, self.regs,
                                         ADD_THRESHOLD, self.flexible_gain(found.final)),
            # the final model's own problem's self-checks, as a fit of it would run them
            checks=bench_checks(final.problem, final.point, None),
            baseline_terms=found.baseline.terms,
            final_terms=found.final.terms,
            steps=found.steps,
            rms_baseline=baseline.rms,
            rms_final=min(final.rms, baseline.rms),
            rms_unit="deg/h" + self.of_means,
            threshold_dbic=ADD_THRESHOLD,
            rate_window_s=self.window_s,
            # The noise of one sample (a mean's white noise is a sample's over sqrt(n)).
            noise=NoiseLevels(noise.white * math.sqrt(self.per_mean), noise.gm, noise.tau_s),
            where=where_largest(self.time_s, baseline.residual, self.inputs, noise, self.log),
            lines_up_with=correlations(baseline.residual, self.regs),
            ambiguous=found.ambiguous,
            residual_before=baseline.residual,
            residual_after=final.residual,
            time_s=self.time_s,
            skipped=found.skipped,
            regressor=_plotted_regressor(found.steps, self.regs, baseline.residual),
        )
