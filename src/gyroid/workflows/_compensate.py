"""Compensation in service: a fitted drift model applied to a new log (paper A's purpose).

For each row: the modelled drift (posterior mean over draws), its sd over the posterior
draws (the model's own uncertainty; the gyro's noise is not in it), and the compensated
drift ``drift - model``. Judged by RMS and peak drift before and after, and the Allan
deviation's figures of merit before and after. A new log whose inputs leave the fitted
range (temperature, its rate, field, elapsed time for time-dependent effects) is flagged
instead of extrapolated silently.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from gyroid._compiled_programs import release_if_crowded
from gyroid.bench._plausibility import units_sanity
from gyroid.errors import GyroidInputError
from gyroid.inference._checks import Check, CheckReport, fit_verdict
from gyroid.inference._predictive import (
    HeldOut,
    part_means,
    predictive_check,
    stretches,
)
from gyroid.io._fitted import FittedDrift
from gyroid.io._logs import BenchLog, contiguous_segments
from gyroid.models._drift import DriftModel
from gyroid.models._effects import EXTRA_PREFIX, effect
from gyroid.workflows._allan import AllanDeviation, allan_deviation
from gyroid.workflows._turn_on import SAME_RUN, StartUp, TurnOn, turn_on_check, with_turn_on
from gyroid.workflows._window_means import measured_mean_covariance, window_bands, window_means


@dataclass(frozen=True, eq=False)
class Compensation:
    """A log compensated with a fitted model: per row the modelled drift, its sd over the
    posterior draws and the compensated drift (deg/h); the Allan deviations before and
    after; ``summary`` (compensate.json) and the self-checks."""

    log: BenchLog = field(repr=False)
    model_deg_h: np.ndarray = field(repr=False)
    model_sd_deg_h: np.ndarray = field(repr=False)
    compensated_deg_h: np.ndarray = field(repr=False)
    summary: dict = field(repr=False)
    adev_before: AllanDeviation = field(repr=False)
    adev_after: AllanDeviation = field(repr=False)
    checks: CheckReport = field(repr=False)
    #: Per consecutive window of the log (``compensated_means.csv``): its span and samples,
    #: the measured and modelled means and the 95 % band for the measured one (deg/h).
    window_means: dict[str, np.ndarray] = field(repr=False, default_factory=dict)

    def __repr__(self) -> str:
        s = self.summary
        return (f"Compensation(rows={s['rows']}, rms {s['rms_before_deg_h']:.3g} -> "
                f"{s['rms_after_deg_h']:.3g} deg/h, trustworthy={self.checks.trustworthy})")

    @property
    def trustworthy(self) -> bool:
        return self.checks.trustworthy

    def to_json(self) -> dict:
        """``compensate.json``."""
        return self.summary


@dataclass(frozen=True)
class DrawPredictions:
    """The modelled drift over posterior draws on a log: its mean and sd per row (deg/h),
    and its means over parts of the log per draw. A linear model never forms the draws x
    rows matrix (400 draws of 10^6 rows are 3.2 GB): the mean is the design times the mean
    draw, the sd the design's quadratic form in the draws' covariance (the same numbers)."""

    mean: np.ndarray
    sd: np.ndarray
    part_means: Callable[[np.ndarray, int], np.ndarray]

    @classmethod
    def of(cls, model: DriftModel, inputs, draws: np.ndarray, startup: StartUp | None = None
           ) -> DrawPredictions:
        """With ``startup``: each draw's drift less its mean over the start-up rows, plus
        the measured start-up mean (the run's bias set by its start-up calibration)."""
        offset = 0.0 if startup is None else startup.mean_deg_h
        if model.is_linear:
            design = np.asarray(model.design(inputs))
            if startup is not None:
                design = design - design[startup.rows].mean(axis=0)
            covariance = (np.atleast_2d(np.cov(draws, rowvar=False)) if draws.shape[0] > 1
                          else np.zeros((draws.shape[1],) * 2))
            variance = np.einsum("ij,jk,ik->i", design, covariance, design)

            def linear_part_means(part: np.ndarray, n_parts: int) -> np.ndarray:
                columns = [part_means(design[:, i], part, n_parts)
                           for i in range(design.shape[1])]
                return draws @ np.column_stack(columns).T + offset

            return cls(design @ draws.mean(axis=0) + offset,
                       np.sqrt(np.maximum(variance, 0.0)), linear_part_means)
        predictions = np.asarray(_predict_draws(model, jnp.asarray(draws), inputs))
        if startup is not None:
            predictions = (predictions - predictions[:, startup.rows].mean(axis=1)[:, None]
                           + offset)
        sd = (predictions.std(axis=0, ddof=1) if predictions.shape[0] > 1
              else np.zeros(predictions.shape[1]))
        return cls(predictions.mean(axis=0), sd, lambda part, n_parts: np.stack(
            [part_means(row, part, n_parts) for row in predictions]))


@eqx.filter_jit
def _predict_draws(model: DriftModel, draws, inputs):
    """A nonlinear model's drift for every draw: one compiled call."""
    return jax.vmap(lambda theta: model.predict(theta, inputs))(draws)


#: ``gyroid compensate --window``'s default, s.
WINDOW_S = 600.0


#: What the compensated residual's Allan curve is (compensate.json's ``allan_after``).
RESIDUAL_CURVE = ("the compensated residual (the drift less the model): its floor is what "
                  "the compensation leaves, not the gyro's bias instability")


def compensate(log: BenchLog, fitted: FittedDrift, *, max_draws: int = 400, seed: int = 0,
               window_s: float = WINDOW_S, turn_on: TurnOn = SAME_RUN) -> Compensation:
    """Apply a fit's posterior (``fitted``: ``BenchFit.fitted_drift()``, or a fit's folder
    read back) to ``log``; rows beyond the ranges the fit saw are flagged; the means over
    consecutive windows of ``window_s`` seconds with their bands (:func:`window_means`).
    ``turn_on``: whether ``log`` is another power-on than the fitted run's, and how its bias
    is known: the turn-on spread, or its start-up calibration's rows
    (:mod:`gyroid.workflows._turn_on`)."""
    extra = [name for name in fitted.model.terms if name.startswith(EXTRA_PREFIX)]
    if extra:
        raise GyroidInputError(
            f"the fit has {', '.join(extra)}: such a term is linear in its column's deviation "
            "from the fitted log's own mean, which a new log does not share, so it cannot "
            "compensate another run; refit without it (it is for finding causes)")
    release_if_crowded()
    inputs = log.inputs(t0_C=fitted.t0_C, rate_window_s=fitted.rate_window_s)
    rng = np.random.default_rng(seed)
    draws = fitted.draws
    if draws.shape[0] > max_draws:
        draws = draws[rng.choice(draws.shape[0], max_draws, replace=False)]
    draws = with_turn_on(fitted, turn_on, draws, rng)
    drift = np.asarray(log.drift_deg_h)
    startup = (StartUp.of(np.asarray(log.time_s), drift, turn_on.rezero_s)
               if turn_on.rezero_s is not None else None)
    predictions = DrawPredictions.of(fitted.model, inputs, draws, startup)
    model, sd = predictions.mean, predictions.sd
    compensated = drift - model
    steps = np.diff(log.time_s)
    sample_s = float(np.median(steps))
    time_s = np.asarray(log.time_s)
    before = allan_deviation(drift, sample_s, time_s=time_s)
    after = allan_deviation(compensated, sample_s, time_s=time_s)

    def rms(x):
        return float(np.sqrt(np.mean(x**2)))

    new_ranges = fitted.model.input_ranges(inputs)
    fitted_ranges = fitted.input_ranges
    outside = []
    for name, (lo, hi) in new_ranges.items():
        if name == "elapsed_h" and not any(effect(t).reads_only_clock
                                           for t in fitted.model.terms):
            continue
        if name not in fitted_ranges:
            continue
        f_lo, f_hi = fitted_ranges[name]
        margin = 0.02 * (f_hi - f_lo)
        values = _input_values(name, inputs)
        fraction = float(np.mean((values < f_lo - margin) | (values > f_hi + margin)))
        if fraction > 0:
            outside.append({"input": name, "fitted_range": [f_lo, f_hi], "new_range": [lo, hi],
                            "fraction_of_rows_outside": fraction})
    summary = {
        "rms_before_deg_h": rms(drift),
        "rms_after_deg_h": rms(compensated),
        "peak_before_deg_h": float(np.max(np.abs(drift))),
        "peak_after_deg_h": float(np.max(np.abs(compensated))),
        "fraction_removed": 1.0 - rms(compensated) / rms(drift),
        "model_sd_note": "drift_model_sd_deg_h is the sd of the modelled drift over posterior "
                         "draws (the model's uncertainty), without the gyro's own noise",
        "allan_before": before.summary("the measured drift (before compensation)"),
        "allan_after": after.summary(RESIDUAL_CURVE),
        "extrapolation": outside,
        "within_fitted_range": not outside,
        "terms": list(fitted.model.terms),
        "model_source": fitted.source,
        "turn_on": turn_on.to_json() | ({"startup_rows": int(startup.rows.sum()),
                                          "startup_mean_deg_h": startup.mean_deg_h}
                                         if startup is not None else {}),
        "posterior_draws_used": int(draws.shape[0]),
        "rows": int(drift.size),
    }
    windows, window_cov = window_means(log, fitted, predictions.part_means, window_s, startup)
    checks = compensation_checks(drift, compensated, outside, fitted.trustworthy) + \
        CheckReport((compensation_predictive(log, fitted, predictions.part_means, startup),
                     window_bands(windows, window_cov, window_s, seed=seed),
                     turn_on_check(fitted, turn_on), units_sanity(log)))
    summary.update(checks.to_json())
    return Compensation(log, model, sd, compensated, summary, before, after, checks, windows)


#: Rows outside the fitted ranges above this fraction make the compensation an
#: extrapolation (an error); fewer are a warning.
EXTRAPOLATED_FRACTION = 0.1


def compensation_checks(drift: np.ndarray, compensated: np.ndarray, outside: list[dict],
                        fit_trustworthy: bool) -> CheckReport:
    """Extrapolation, the gain over removing a constant, and the fit's own verdict."""
    worst = max((item["fraction_of_rows_outside"] for item in outside), default=0.0)
    if not outside:
        extrapolation = Check("extrapolation", True, "error", 0.0, EXTRAPOLATED_FRACTION,
                              "every input stays within the fitted ranges")
    else:
        names = ", ".join(item["input"] for item in outside)
        severe = worst > EXTRAPOLATED_FRACTION
        extrapolation = Check(
            "extrapolation", False, "error" if severe else "warning", worst,
            EXTRAPOLATED_FRACTION,
            f"{100 * worst:.0f} % of rows leave the fitted range of {names}: the model is "
            "extrapolated there; fit a log that covers these conditions")
    spread_before = float(np.std(drift))
    spread_after = float(np.std(compensated))
    ratio = spread_after / spread_before if spread_before > 0 else 1.0
    # A model no better than a constant leaves the spread as it is (ratio 1); sampling noise
    # of the sd is ~1/sqrt(2n), so 1.01 is far beyond chance for any usable log.
    gain = Check(
        "compensation_gain", ratio <= 1.01, "error", ratio, 1.01,
        f"compensation leaves {100 * ratio:.0f} % of the drift's spread about its mean"
        if ratio <= 1.01 else
        f"compensation makes the drift's spread about its mean {ratio:.2f}x larger than "
        "removing a constant would: do not use this model on this log")
    return CheckReport((extrapolation, gain, fit_verdict(fit_trustworthy, "compensating with it")))


def compensation_predictive(log: BenchLog, fitted: FittedDrift,
                            draw_part_means: Callable[[np.ndarray, int], np.ndarray],
                            startup: StartUp | None = None) -> Check:
    """The predictive check of a compensation: the compensated drift's means over parts of
    the new log (up to 16, whole bursts for a log of bursts; after the start-up
    calibration's rows, with ``startup``) against the fit's bands: the model's uncertainty
    (the covariance of the parts' means over the posterior draws) plus the fit's noise
    model's covariance of those means (of each less the start-up mean, with ``startup``;
    :mod:`gyroid.inference._predictive`; ``draw_part_means(part, n_parts)``: the modelled
    drift's part means per draw). A fit whose stated uncertainty describes this log passes;
    a log that departs from it (another unit, wander the fit's noise model lacks) fails,
    saying by how much. White noise is taken at this log's own sample interval
    (:func:`~gyroid.workflows._window_means.measured_mean_covariance`), so a log sampled
    faster than the fitted one is not refused for its larger per-sample noise."""
    noise = fitted.noise
    time_s = np.asarray(log.time_s)
    after = np.arange(log.n) if startup is None else np.flatnonzero(~startup.rows)
    segments = tuple(contiguous_segments(time_s[after]))
    parts = stretches(after.size, segments if len(segments) > 1 else None, folds=1)
    if parts is None or noise is None:
        return predictive_check(None, why_none=(
            "the fit's noise model is unknown (an old fit folder?): the bands are not tested "
            "on this log" if noise is None else ""))
    part = np.full(log.n, -1)
    part[after] = parts.part
    means = draw_part_means(part, parts.n_parts)
    model_cov = np.cov(means, rowvar=False) if means.shape[0] > 1 else np.zeros(
        (parts.n_parts,) * 2)
    counts = np.bincount(part[part >= 0], minlength=parts.n_parts).astype(float)
    covariance = np.atleast_2d(model_cov) + measured_mean_covariance(
        log, noise, part, parts.n_parts, startup)
    held = HeldOut(observed=part_means(np.asarray(log.drift_deg_h), part, parts.n_parts),
                   predicted=means.mean(axis=0), covariance=covariance, counts=counts)
    durations = [np.ptp(time_s[part == s]) for s in range(parts.n_parts)]
    return predictive_check([held], part_s=float(np.median(durations)) or None,
                            subject="on this log, which the fit did not see")


def _input_values(name: str, inputs) -> np.ndarray:
    from gyroid.models._inputs import ACCEL_COLUMNS, FIELD_COLUMNS, H0_UT

    if name == "temperature_C":
        return np.asarray(inputs.temperature_C)
    if name == "dT_dt_C_h":
        return np.asarray(inputs.rate_C_h)
    if name == "elapsed_h":
        return np.asarray(inputs.time_h)
    if name in ACCEL_COLUMNS:
        return np.asarray(inputs.accel_g[:, ACCEL_COLUMNS.index(name)])
    return np.asarray(inputs.field_rel[:, FIELD_COLUMNS.index(name)]) * H0_UT
