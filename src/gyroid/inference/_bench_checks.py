"""The self-checks of a bench fit (:func:`bench_checks`): the shared ones on its evidence
(:mod:`gyroid.inference._checks`), those that read only its mode (excitation, held-out
stretches, units, effect sizes, the dT/dt estimate and the thermometer's noise carried
through it, spikes behind means), and how far its intervals rest on the noise levels'
priors. The discrepancy search's final model is checked by the same function."""

from __future__ import annotations

import math

import numpy as np

from gyroid.inference._allowed_noise import AllowedNoise
from gyroid.inference._bench_predictive import bench_predictive
from gyroid.inference._bench_problem import BenchProblem
from gyroid.inference._check_report import Check, CheckReport
from gyroid.inference._checks import fit_checks
from gyroid.inference._excitation import excitation
from gyroid.inference._plausibility import effect_sizes, units_sanity
from gyroid.inference._posterior import Posterior
from gyroid.inference._problem import PointEstimate
from gyroid.inference._rate_estimate import rate_estimate
from gyroid.inference._residual_checks import outliers_among
from gyroid.inference._thermometer import COVERED_FROM, carried_thermometer, stated_coverage
from gyroid.io._logs import SampleDeviations, contiguous_segments


def bench_checks(problem: BenchProblem, point: PointEstimate, posterior: Posterior | None,
                 allowed: AllowedNoise | None = None) -> CheckReport:
    """Every self-check of a bench fit: the shared ones on its evidence, those that read
    only the mode (:func:`bench_point_checks`), and how far its intervals rest on the noise
    levels' priors (``allowed``, when given)."""
    report = fit_checks(problem.evidence(point, posterior)) + bench_point_checks(problem, point)
    if allowed is None:
        return report
    return report + CheckReport((allowed.check(),))


def bench_point_checks(problem: BenchProblem, point: PointEstimate) -> CheckReport:
    """The checks of a bench fit that read its mode and not its posterior: excitation, the
    predictive check (held-out stretches), units, effect sizes, and for a fit of segment
    means the spike check on the samples behind them; the thermometer's noise as the
    filter carries it (:func:`thermometer_noise`)."""
    time_s = np.asarray(problem.log.time_s)
    samples = problem.log if problem.segments is None else problem.segments.head
    checks = CheckReport((
        excitation(problem.model, problem.inputs, time_s, tuple(contiguous_segments(time_s))),
        bench_predictive(problem.density, time_s, np.asarray(point.u)),
        units_sanity(samples),
        effect_sizes(problem.model, point.value, problem.inputs,
                     np.asarray(problem.log.drift_deg_h)),
        _rate_estimate_check(problem, point, time_s),
        thermometer_noise(problem, point)))
    segments = problem.segments
    if segments is None:
        return checks
    # the means' own scatter: their white sd, or, for block means whose noise is
    # correlated, the RMS of their residuals
    sigma = (point.rms_residual if problem.block_rows > 1
             else point.value.get("sigma_deg_h", segments.within_sd))
    return checks + CheckReport((spikes_within_segments(
        segments, sigma_of_means=sigma, n_means=problem.n),))


def _rate_estimate_check(problem: BenchProblem, point: PointEstimate, time_s: np.ndarray
                         ) -> Check:
    """:func:`~gyroid.inference._rate_estimate.rate_estimate` of a bench fit: its dT/dt
    window, wD at the mode, and a window mean's white noise from the residuals."""
    window_s = float(problem.density.rate_window_s)
    wD = point.value.get("wD") if "temperature_rate" in problem.model.terms else None
    if wD is None or not problem.log.has("temperature_C"):
        return rate_estimate(time_s, time_s, window_s, None, 0.0)
    step = float(np.median(np.diff(time_s))) if time_s.size > 1 else 1.0
    noise = point.rms_residual / math.sqrt(max(window_s / step, 1.0))
    return rate_estimate(time_s, np.asarray(problem.log.columns["temperature_C"]), window_s,
                         float(wD), noise, rate_C_h=np.asarray(problem.inputs.rate_C_h))


def spikes_within_segments(samples: SampleDeviations, *, sigma_of_means: float,
                           n_means: int) -> Check:
    """The spike check of a fit of means (of segments or blocks), on the samples about
    their mean. A spike shifts the bias by its deviation / n; that is judged against the
    fit's sd of the bias (about ``sigma_of_means / sqrt(K)`` of the K means), not the
    samples' ``s / sqrt(n)``."""
    within = samples.within_sd / math.sqrt(samples.n)
    # samples that do not scatter about their means (z all 0) have no spike to weigh
    ratio = (sigma_of_means / math.sqrt(n_means)) / within if within > 0 else 1.0
    return outliers_among(samples.n, samples.rows, samples.z, samples.z_sum_sq,
                          where=samples.where, name="outliers_within_segments",
                          bias_sd_ratio=max(ratio, 1e-12), sets_noise_level=False)


def thermometer_noise(problem: BenchProblem, point: PointEstimate) -> Check:
    """A warning where the process that carries the thermometer's noise through dT/dt
    (under correlated noise) gives intervals that hold the truth less than
    :data:`~gyroid.inference._thermometer.COVERED_FROM` of the time under that error's exact
    covariance, at the mode's noise levels (:func:`~gyroid.inference._thermometer.
    stated_coverage` on :func:`carried_rows`). Its value is the worst coefficient's share of
    misses (larger is worse, as a pool's runs are combined)."""
    name, missed = "thermometer_noise", round(1.0 - COVERED_FROM, 3)
    noise = problem.noise
    if noise.rate_error is None:
        how = ("carried exactly, beside white noise" if noise.carried is not None else
               "not carried (the model reads no dT/dt, the thermometer's noise is "
               "negligible or not measured, or the rows are bursts or unevenly spaced)")
        return Check(name, True, "warning", None, missed,
                     f"the thermometer's noise in dT/dt is {how}")
    ratio, coverage = stated_coverage(*carried_rows(problem, point))
    worst = int(np.argmin(coverage))
    coefficient, held = problem.model.parameter_names[worst], float(coverage[worst])
    if held >= COVERED_FROM:
        return Check(name, True, "warning", round(1.0 - held, 3), missed,
                     "the thermometer's noise in dT/dt, carried as a process of the noise "
                     "model's filter: under its exact covariance every coefficient's 95 % "
                     f"interval holds the truth at least {100 * held:.1f} % of the time (at "
                     "the mode's noise levels)")
    return Check(
        name, False, "warning", round(1.0 - held, 3), missed,
        f"{coefficient}'s 95 % interval holds the truth about {100 * held:.1f} % of the "
        "time, not 95 %, under the thermometer's exact error in dT/dt: the noise model "
        f"carries that error (a {problem.thermometer_sd_C:.2g} degC thermometer's) as a "
        "stationary process, which misses its larger, one-sided part within a window "
        f"({problem.rate_window_s:.0f} s) of the log's ends; under the exact covariance "
        f"{coefficient}'s error is {float(ratio[worst]):.2f}x its stated sd (at the mode's "
        "noise levels); a longer --rate-window, a quieter or averaged thermometer, or "
        "--noise white where the gyro's noise is white (which carries it exactly) narrows "
        "the gap")


def carried_rows(problem: BenchProblem, point: PointEstimate
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What :func:`thermometer_noise` compares, for a fit whose filter carries the
    thermometer's noise as a process, at the mode's noise levels: the model's columns over
    the fitted rows, the rows' covariance as the filter states it (the gyro's terms and the
    process's), and the same with the rate error's exact covariance in the process's place
    (dense: at most a thousand block means)."""
    log, density, noise = problem.log, problem.density, problem.noise
    if noise.rate_error is None:
        raise ValueError("this fit carries no process for the thermometer's noise")
    time_s = np.asarray(log.time_s)
    n = time_s.size
    values = {k: point.value[k] for k in problem.noise_names}
    white = (np.asarray(density.sigma) if density.sigma is not None else
             float(noise.row_white_sd(values, step_s=density.step_s,
                                      row_scale=density.row_scale)))
    # the gyro's own noise over the rows (each a part of its own), as the filter reads them
    gyro = noise.without_rate_error().part_covariance(
        time_s, np.arange(n), n, float(np.median(np.diff(time_s))),
        np.broadcast_to(np.asarray(white, dtype=float) ** 2, (n,)), values,
        block_means=noise.rows_as_means(problem.block_rows))
    carried = carried_thermometer(log, problem.rate_window_s, problem.rate_error_wd,
                                  problem.thermometer_sd_C**2 / problem.block_rows)
    if carried is None:
        raise ValueError("a rate error's process with no thermometer noise carried")
    return (np.asarray(problem.model.design(problem.inputs)),
            gyro + noise.rate_error.row_covariance(), gyro + carried.covariance())
