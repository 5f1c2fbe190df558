"""The thermometer's noise carried into the estimated dT/dt (errors in variables).

The drift model reads dT/dt estimated from a logged temperature ``T + e``. The estimator is
linear in the temperature (:func:`~gyroid.models._derived.temperature_rate_operator`, ``L``),
so the rate it gives is the true rate's estimate plus ``L e``: a thermometer noise that is
white at the sample scale becomes a rate error correlated over the estimator's window, and
``wD L e`` enters the drift residuals. With white thermometer noise of variance ``v`` per row
the rate error's covariance is ``v L L'`` ((degC/h)^2); the drift likelihood adds ``wD^2``
times it (:class:`~gyroid.bench._density.BenchDensity`).

What is left out, and why: the temperature error's direct effect on ``w1 t + w2 t^2`` is
``(w1 + 2 w2 t) e``, white, and about ``w1 sT`` (1e-3 deg/h for paper A's gyro and a
0.01 degC thermometer): it is absorbed into the white level, ``sigma_deg_h``, which then
means the gyro's white noise and this together. Where it is not small (coefficients drawn
from wide priors, ``|w1 + 2 w2 t|`` up to 7 deg/h/degC: experiments/sbc.py) sigma's
posterior sits above the gyro's own level while the coefficients stay calibrated. The
error's effect on the rate coefficient's *estimate* (attenuation by var(rate) / (var(rate)
+ var(L e))) is below 1e-4 on a bench whose rate spans a few degC/h; it is not corrected.
"""

from __future__ import annotations

import numpy as np

from gyroid.models._derived import (
    estimator_grid_size,
    grid_plan,
    half_and_degree,
    slope_kernel_weights,
)
from gyroid.models._drift import DriftModel

#: Rows are aggregated by these factors when the thermometer's noise is measured on the
#: samples; the largest estimate is kept (see :func:`thermometer_noise_var`).
AGGREGATIONS = (1, 2, 4, 8, 16, 32)
#: ... but means over no more than this many seconds: over longer ones a temperature's
#: own curvature shows (a 15 degC cycle of 100 min, read over 320 s, looks like 0.5 degC of
#: noise).
MAX_AGGREGATION_S = 20.0
#: Fewest third differences an aggregation's estimate uses.
MIN_DIFFERENCES = 100
#: Binomial weight of a third difference of white noise: 1 + 9 + 9 + 1.
_THIRD_DIFFERENCE_GAIN = 20.0


def _third_difference_var(time_s: np.ndarray, temperature_C: np.ndarray) -> float | None:
    """The white-noise variance behind the third differences of ``temperature_C`` over
    steps of the median length (differences across a gap are left out); None when there
    are too few."""
    steps = np.diff(time_s)
    if steps.size < 3:
        return None
    step = float(np.median(steps))
    regular = np.abs(steps - step) <= 0.01 * step
    usable = regular[:-2] & regular[1:-1] & regular[2:]
    if np.count_nonzero(usable) < MIN_DIFFERENCES:
        return None
    third = np.diff(temperature_C, n=3)[usable]
    return float(np.mean(third**2) / _THIRD_DIFFERENCE_GAIN)


def thermometer_noise_var(time_s: np.ndarray, temperature_C: np.ndarray,
                          aggregations: tuple[int, ...] = AGGREGATIONS) -> float:
    """The variance of the thermometer's white noise in one row, degC^2 (0 for a temperature
    with no high-frequency content).

    Third differences remove a temperature that is locally quadratic or smoother, and a
    white noise of variance ``v`` gives them variance ``20 v``. A thermometer that updates
    more slowly than the log (each value held, or interpolated, over ``u`` rows) looks
    quieter at the row scale than it is over a window: the estimate is repeated on means of
    ``k`` rows (``aggregations``, spanning at most :data:`MAX_AGGREGATION_S`; times ``k``)
    and the largest kept; on paper A's bench at 1 Hz, a value held for 10 rows is read at
    0.8 of its low-frequency level, a white one at 1.02. Longer holds are underestimated
    (the whiteness check then still sees the rest). On rows that are already means over
    tens of seconds, aggregate no further (``aggregations=(1,)``): a temperature's
    curvature dominates there."""
    time_s = np.asarray(time_s, dtype=float)
    temperature_C = np.asarray(temperature_C, dtype=float)
    estimates = [0.0]
    step = float(np.median(np.diff(time_s))) if time_s.size > 1 else 0.0
    for k in aggregations:
        rows = (time_s.size // k) * k
        if rows < 4 * k or (k > 1 and k * step > MAX_AGGREGATION_S):
            break
        estimate = _third_difference_var(time_s[:rows].reshape(-1, k).mean(axis=1),
                                         temperature_C[:rows].reshape(-1, k).mean(axis=1))
        if estimate is not None:
            estimates.append(k * estimate)
    return max(estimates)


def one_sided_rows(time_s: np.ndarray, window_s: float) -> np.ndarray:
    """The rows (a boolean mask) where the estimator's window is one-sided: within its half
    window (on the grid it differentiates on) of either end of the log."""
    time_s = np.asarray(time_s, dtype=float)
    if time_s.size < 2:
        return np.ones(time_s.size, dtype=bool)
    _, step = grid_plan(time_s, window_s)
    half, _ = half_and_degree(window_s, step, estimator_grid_size(time_s, window_s))
    reach = half * step * (1.0 - 1e-9)
    return (time_s - time_s[0] < reach) | (time_s[-1] - time_s < reach)


def rows_sharing_the_start(time_s: np.ndarray, window_s: float) -> int:
    """How many of the log's first rows may read a thermometer sample that a one-sided
    row's window at the start reads (:func:`one_sided_rows`: the first ``2 half`` samples
    of the grid; a centred window reaches ``half`` samples either side, so within
    ``3 half`` of the start), at ``window_s`` (s)."""
    time_s = np.asarray(time_s, dtype=float)
    if time_s.size < 2:
        return time_s.size
    _, step = grid_plan(time_s, window_s)
    half, _ = half_and_degree(window_s, step, estimator_grid_size(time_s, window_s))
    return int(np.searchsorted(time_s - time_s[0], (3 * half + 1) * step))


def estimator_autocovariance(window_s: float, step_s: float, noise_var_C2: float
                             ) -> np.ndarray:
    """The interior autocovariance of the dT/dt estimator's error ((degC/h)^2 at lags 0, 1,
    ... rows) on rows ``step_s`` apart, for white thermometer noise of ``noise_var_C2`` per
    row: the differentiating kernel correlated with itself (zero beyond two half-windows)."""
    weights = slope_kernel_weights(window_s, step_s)
    return noise_var_C2 * np.correlate(weights, weights, mode="full")[weights.size - 1:]


def rate_coefficient_index(model: DriftModel) -> int:
    """Where the dT/dt coefficient (wD) sits among the model's parameters."""
    effect = next(e for e in model.effects if e.name == "temperature_rate")
    return model.parameter_names.index(effect.parameters[0].name)


def white_level_var(drift_deg_h: np.ndarray) -> float:
    """The white noise's variance from the drift's first differences, robustly (MAD): a
    kink in dT/dt is a jump in the drift, and a few jumps must not set it. (deg/h)^2.

    The drift's own curvature counts too: on the FOG bench of
    ``experiments/fog_thermal_bench.py`` (1000 block means) this reads 2.4-5.2x the block
    means' true white variance, and 480x on the SBC's ramped thermal logs. It is only the
    floor the thermometer's process is matched above
    (:func:`gyroid.noise._rate_error_process.match`, beside a correlated term; white noise
    alone carries the exact covariance): fitted with the true white level instead, that
    bench's coefficients and noise levels moved at most 0.01 posterior sd (seeds 0 and 1,
    2026-12-01)."""
    steps = np.diff(np.asarray(drift_deg_h, dtype=float))
    return float((1.4826 * np.median(np.abs(steps - np.median(steps)))) ** 2 / 2.0)
