"""Whether a fit carries the thermometer's noise through the dT/dt estimator (errors in
variables, :mod:`gyroid.noise._rate_error_rows`), and how much: measured on the log, left out
where negligible or where the estimator cannot be written as a matrix over the rows (a log
of bursts); times wD at its least-squares value on the log, fixed for the fit; and the
term a fit's noise model carries on its rows (:func:`carried_thermometer`)."""

from __future__ import annotations

import numpy as np

from gyroid.bench._rate_window import grid_least_squares, window_grid
from gyroid.io._logs import BenchLog, MeansOfBlocks
from gyroid.models._derived import (
    MAX_OPERATOR_ROWS,
    RATE_POLY_DEGREE,
    estimator_grid_size,
    temperature_rate_operator,
)
from gyroid.models._drift import DriftModel
from gyroid.models._inputs import ACCEL_COLUMNS, FIELD_COLUMNS
from gyroid.models._rate_error import (
    estimator_autocovariance,
    one_sided_rows,
    rate_coefficient_index,
    rows_sharing_the_start,
    thermometer_noise_var,
    white_level_var,
)
from gyroid.noise._rate_error_rows import CarriedThermometer


def thermometer_to_carry(log: BenchLog | MeansOfBlocks, model: DriftModel,
                         rate_window_s: float | None, t0_C: float, cap: int
                         ) -> tuple[float, float]:
    """The thermometer's noise to carry (a sample's variance, degC^2, or 0) and the wD that
    scales it (deg/h per degC/h, least squares on the log): none where no noise is measured,
    on a log of bursts (its estimator differentiates on a grid across the gaps; a real
    burst log, PAN's: 875 rows on a grid of 52 158), where the model reads no dT/dt on
    rows least squares can fit, or where the noise is negligible (at ``rate_window_s``, or
    the shortest window the estimator may use)."""
    variance = _thermometer_var(log)
    if variance <= 0 or not _operator_fits(log, rate_window_s, cap):
        return 0.0, 0.0
    wd = _least_squares_rate_coefficient(log, model, t0_C)
    if wd is None or _negligible(log, variance, rate_window_s, wd):
        return 0.0, 0.0
    return variance, wd


def _thermometer_var(log: BenchLog | MeansOfBlocks) -> float:
    """The variance of a sample's thermometer noise, degC^2 (0 without a temperature): on
    the samples, or on a streamed log's block means (not aggregated further: a
    temperature's curvature dominates over tens of seconds), times the samples per mean."""
    rows = log.log if isinstance(log, MeansOfBlocks) else log
    if "temperature_C" not in rows.columns:
        return 0.0
    time_s, temperature = np.asarray(rows.time_s), np.asarray(rows.columns["temperature_C"])
    if isinstance(log, MeansOfBlocks):
        return log.rows_per_mean * thermometer_noise_var(time_s, temperature, (1,))
    return thermometer_noise_var(time_s, temperature)


#: The thermometer's noise is left out of the likelihood when, at the shortest window the
#: rate estimator may use, the rate error it causes (times wD) adds less than this fraction
#: to the variance of the drift's mean over one window.
NEGLIGIBLE_EIV = 0.01
#: Rows a log is thinned to for the least-squares wD of that test.
_THIN_ROWS = 20_000


def _negligible(log: BenchLog | MeansOfBlocks, thermometer_var: float,
                rate_window_s: float | None, wd: float) -> bool:
    """Whether the thermometer's noise (``thermometer_var``, a sample's, degC^2) hardly
    changes the likelihood (:data:`NEGLIGIBLE_EIV`). Over a window of ``N`` samples ``d``
    seconds apart, white thermometer noise gives the estimated rate an error of variance
    ``(3600 sT)^2 229.7 / (d^2 N^3)`` (:func:`~gyroid.models.temperature_rate_deg_c_per_h`),
    common to the window, against the white drift noise ``sigma^2 / N`` of its mean; wD is
    the least-squares value on the log (thinned), sigma the drift's first differences'
    robust level."""
    rows = log.log if isinstance(log, MeansOfBlocks) else log
    per_row = 1 if not isinstance(log, MeansOfBlocks) else log.rows_per_mean
    time_s = np.asarray(rows.time_s)
    sample_var = per_row * white_level_var(np.asarray(rows.drift_deg_h))
    step = float(np.median(np.diff(time_s))) / per_row  # a sample's
    window = rate_window_s if rate_window_s is not None else float(window_grid(time_s)[0])
    samples = max(window / step, 2.0 * RATE_POLY_DEGREE + 1)
    rate_var = (3600.0**2 * thermometer_var * 229.7 / (step**2 * samples**3))
    return wd**2 * rate_var * samples < NEGLIGIBLE_EIV * max(sample_var, 1e-300)


def _least_squares_rate_coefficient(log: BenchLog | MeansOfBlocks, model: DriftModel,
                                    t0_C: float) -> float | None:
    """wD by least squares on the log (thinned to :data:`_THIN_ROWS` rows; deg/h per
    degC/h); None where the model's design cannot be built on it."""
    rows = log.log if isinstance(log, MeansOfBlocks) else log
    every = max(1, rows.n // _THIN_ROWS)
    thin = BenchLog(columns={k: np.asarray(v)[::every] for k, v in rows.columns.items()
                             if k in ("time_s", "drift_deg_h", "temperature_C", *FIELD_COLUMNS,
                                      *ACCEL_COLUMNS)
                             or k in rows.extra_columns},
                    extra_columns=rows.extra_columns)
    y = np.asarray(thin.drift_deg_h)
    try:
        inputs = thin.inputs(t0_C=t0_C)
        if not model.is_linear:  # time constants: the start grid's best least squares
            theta = grid_least_squares(model, inputs, y)[1]
            return None if theta is None else float(theta[rate_coefficient_index(model)])
        design = np.asarray(model.design(inputs))
    except (KeyError, ValueError):
        return None
    return float(np.linalg.lstsq(design, y, rcond=None)[0][rate_coefficient_index(model)])


def _operator_fits(log: BenchLog | MeansOfBlocks, rate_window_s: float | None,
                   cap: int) -> bool:
    """Whether the rate estimator on the rows fitted (at most ``cap`` block means of
    ``log``; at the shortest window it may use) can be written as a matrix
    (:func:`~gyroid.models._derived.temperature_rate_operator`): a log of bursts spreads
    its grid over the gaps."""
    rows = log.log if isinstance(log, MeansOfBlocks) else log
    time_s = np.asarray(rows.time_s)
    window = rate_window_s if rate_window_s is not None else float(window_grid(time_s)[0])
    per_row = estimator_grid_size(time_s, window) / max(rows.n, 1)
    return max(1.0, per_row) * min(rows.n, cap) <= MAX_OPERATOR_ROWS


def carried_thermometer(log: BenchLog, window_s: float, wd: float, thermometer_var: float,
                        widest_s: float | None = None) -> CarriedThermometer | None:
    """The thermometer's noise a fit carries (a row's variance ``thermometer_var``, degC^2;
    none when 0) through the estimator's window ``window_s`` (s), times ``wd``: the rows'
    error per unit noise, the one-sided rows, and the interior's autocovariance at lags of
    one row (none for a log of bursts, whose estimator differentiates on a grid across the
    gaps: a kernel not the rows'); the rows the one-sided ones share samples with at the
    widest window the fit tries, ``widest_s`` (s; None: this one), and the directions an
    end's error spans at most (a slope of a polynomial of the estimator's degree: as many as
    the degree), so that its windows share shapes."""
    if thermometer_var <= 0 or log.n < 2:
        return None
    time_s = np.asarray(log.time_s)
    temperature = np.asarray(log.columns["temperature_C"])
    step = float(np.median(np.diff(time_s)))
    even = estimator_grid_size(time_s, window_s) <= 1.05 * log.n
    scale = wd * np.sqrt(thermometer_var)
    return CarriedThermometer(
        operator=lambda: scale * temperature_rate_operator(time_s, temperature, window_s),
        autocovariance=lambda: (wd**2 * estimator_autocovariance(window_s, step,
                                                                 thermometer_var)
                                if even else None),
        one_sided=one_sided_rows(time_s, window_s),
        white_var=white_level_var(np.asarray(log.drift_deg_h)),
        reach=rows_sharing_the_start(time_s, max(window_s, widest_s or window_s)),
        directions=RATE_POLY_DEGREE)
