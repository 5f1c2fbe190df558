"""Compensation in service: a fitted drift model applied to a new log (paper A's purpose).

For each row: the modelled drift (posterior mean over draws), its sd over the posterior
draws (the model's own uncertainty; the gyro's noise is not in it), and the compensated
drift ``drift - model``. Judged by RMS and peak drift before and after, and the Allan
deviation's figures of merit before and after. A new log whose inputs leave the fitted
range (temperature, its rate, field, elapsed time for time-dependent effects) is flagged
instead of extrapolated silently.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from gyroid.allan import AllanDeviation, allan_deviation
from gyroid.fit import input_ranges
from gyroid.logs import BenchLog
from gyroid.propagate import FittedDrift

#: Effects whose contribution depends on elapsed time (extrapolating them in time matters).
_TIME_EFFECTS = {"warmup", "time_trend"}


@dataclass
class Compensation:
    model_deg_h: np.ndarray
    model_sd_deg_h: np.ndarray
    compensated_deg_h: np.ndarray
    summary: dict
    adev_before: AllanDeviation
    adev_after: AllanDeviation


def compensate(log: BenchLog, fitted: FittedDrift, fitted_ranges: dict[str, list[float]],
               *, max_draws: int = 400, seed: int = 0) -> Compensation:
    """Apply a fit's posterior to ``log``."""
    inputs = log.inputs(t0_C=fitted.t0_C)
    rng = np.random.default_rng(seed)
    draws = fitted.draws
    if draws.shape[0] > max_draws:
        draws = draws[rng.choice(draws.shape[0], max_draws, replace=False)]
    predictions = np.asarray(jax.vmap(lambda th: fitted.model.predict(th, inputs))(
        jnp.asarray(draws)))
    model = predictions.mean(axis=0)
    sd = predictions.std(axis=0, ddof=1) if predictions.shape[0] > 1 else np.zeros_like(model)
    drift = np.asarray(log.drift_deg_h)
    compensated = drift - model
    steps = np.diff(log.time_s)
    sample_s = float(np.median(steps))
    before, after = allan_deviation(drift, sample_s), allan_deviation(compensated, sample_s)

    def rms(x):
        return float(np.sqrt(np.mean(x**2)))

    new_ranges = input_ranges(inputs, fitted.model)
    outside = []
    for name, (lo, hi) in new_ranges.items():
        if name == "elapsed_h" and not _TIME_EFFECTS & set(fitted.model.terms):
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
        "allan_before": before.figures_of_merit(),
        "allan_after": after.figures_of_merit(),
        "extrapolation": outside,
        "within_fitted_range": not outside,
        "terms": list(fitted.model.terms),
        "posterior_draws_used": int(draws.shape[0]),
        "rows": int(drift.size),
    }
    return Compensation(model, sd, compensated, summary, before, after)


def _input_values(name: str, inputs) -> np.ndarray:
    from gyroid.inputs import FIELD_COLUMNS, H0_UT

    if name == "temperature_C":
        return np.asarray(inputs.temperature_C)
    if name == "dT_dt_C_h":
        return np.asarray(inputs.rate_C_h)
    if name == "elapsed_h":
        return np.asarray(inputs.time_h)
    return np.asarray(inputs.field_rel[:, FIELD_COLUMNS.index(name)]) * H0_UT


def fitted_ranges_from(folder: str | Path) -> dict[str, list[float]]:
    return json.loads((Path(folder) / "fit.json").read_text()).get("input_ranges", {})


def compensated_csv(log: BenchLog, result: Compensation, header: tuple[str, ...]) -> str:
    """Input columns (those gyroid read) plus the three compensation columns."""
    names = [c for c in header if c in log.columns]
    columns = [log.columns[c] for c in names]
    names += ["drift_model_deg_h", "drift_model_sd_deg_h", "drift_compensated_deg_h"]
    columns += [result.model_deg_h, result.model_sd_deg_h, result.compensated_deg_h]
    data = np.column_stack(columns)
    lines = [",".join(names)] + [",".join(f"{v:.10g}" for v in row) for row in data]
    return "\n".join(lines) + "\n"
