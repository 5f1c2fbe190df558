"""The self-checks of a bench fit (:func:`bench_checks`): the shared ones on its evidence
(:mod:`gyroid.inference._checks`), those that read only its mode (excitation, held-out
stretches, units, effect sizes, the dT/dt estimate, spikes behind means), and how far its
intervals rest on the noise levels' priors. The discrepancy search's final model is checked
by the same function."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from gyroid.bench._allowed_noise import AllowedNoise
from gyroid.bench._excitation import excitation
from gyroid.bench._plausibility import effect_sizes, units_sanity
from gyroid.bench._predictive import bench_predictive
from gyroid.bench._rate_estimate import rate_estimate
from gyroid.inference._check_report import Check, CheckReport
from gyroid.inference._checks import fit_checks
from gyroid.inference._posterior import Posterior
from gyroid.inference._problem import PointEstimate
from gyroid.inference._residual_checks import outliers_among
from gyroid.io._logs import SampleDeviations, contiguous_segments

if TYPE_CHECKING:
    from gyroid.bench._problem import BenchProblem


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
    means the spike check on the samples behind them."""
    time_s = np.asarray(problem.log.time_s)
    samples = problem.log if problem.segments is None else problem.segments.head
    checks = CheckReport((
        excitation(problem.model, problem.inputs, time_s, tuple(contiguous_segments(time_s))),
        bench_predictive(problem.density, time_s, np.asarray(point.u)),
        units_sanity(samples),
        effect_sizes(problem.model, point.value, problem.inputs,
                     np.asarray(problem.log.drift_deg_h)),
        _rate_estimate_check(problem, point, time_s)))
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
    """:func:`~gyroid.bench._rate_estimate.rate_estimate` of a bench fit: its dT/dt
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
