"""The predictive check of a bench fit (:mod:`gyroid.inference._predictive`): each fold left
out, the drift model refitted on the rest, the fold's part means predicted.

A linear model with white noise is refitted in closed form from per-part sums (one pass
over the design in blocks of rows, whatever the log's length); any other model's
coefficients by their exact conditional posterior on the rows kept, its noise levels and
positive parameters held at the full fit's mode; without that mode (a pool's runs), by its
posterior mode with the fold's rows masked (:meth:`BenchDensity.without_rows`)."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from gyroid.bench._density import BenchDensity, predicted
from gyroid.bench._point import point_estimate
from gyroid.inference._check_report import Check
from gyroid.inference._collapsed import collapsed_form, conditional_solution, padded
from gyroid.inference._model_columns import columns_at, split_parameters
from gyroid.inference._predictive import (
    HeldOut,
    Stretches,
    mean_jacobian,
    part_means,
    predictive_check,
    stretches,
)
from gyroid.io._logs import contiguous_segments


def bench_predictive(density: BenchDensity, time_s: np.ndarray,
                     point_u: np.ndarray | None = None) -> Check:
    """The predictive check of a bench log's density (rows at ``time_s``, s); ``point_u``:
    the full fit's mode (sampling coordinates), whose noise levels (and, under correlated
    noise, time constants) are held in each fold's refit under correlated noise (a
    generalised least-squares fit; a carried thermometer's noise included)."""
    folds, part_s = bench_held_out(density, time_s, point_u)
    bursts = len(contiguous_segments(np.asarray(time_s))) > 1
    remedies = tuple(code for code in density.noise.remedies
                     if bursts or code != "segment_means")  # no bursts: no burst means
    return predictive_check(folds, part_s=part_s, remedies=remedies)


def bench_held_out(density: BenchDensity, time_s: np.ndarray,
                   point_u: np.ndarray | None = None
                   ) -> tuple[list[HeldOut] | None, float | None]:
    """The held-out folds of a bench log's density and the median part's duration (s);
    None when the log is too short to hold a stretch out. ``time_s``: the density's rows'
    times (a fit of block means: the means', ``BenchProblem.log.time_s``)."""
    time_s = np.asarray(time_s)
    if time_s.shape != (density.n,):
        raise ValueError(f"bench_held_out: {time_s.size} times for a density of {density.n} "
                         "rows (a fit of block means: pass the means' times)")
    segments = tuple(contiguous_segments(time_s))
    parts = stretches(density.n, segments if len(segments) > 1 else None)
    if parts is None:
        return None, None
    if density.stats is not None:
        folds = _linear_folds(density, parts)
    elif point_u is not None:
        folds = _collapsed_folds(density, parts, time_s, np.asarray(point_u))
    else:
        folds = _refit_folds(density, parts, time_s)
    return folds, _part_seconds(parts, time_s)


def _part_seconds(parts: Stretches, time_s: np.ndarray) -> float | None:
    """The median part's duration, s (None for parts of one instant)."""
    durations = [np.ptp(time_s[parts.part == s]) for s in range(parts.n_parts)]
    return float(np.median(durations)) or None


def _part_sums(density: BenchDensity, parts: Stretches) -> dict[str, np.ndarray]:
    """Per part: row count, sum of the design rows and of the drift (unweighted, for the
    means), and the weighted cross products a least-squares fit needs."""
    p, n_parts = density.n_model, parts.n_parts
    y = np.asarray(density.drift)
    sigma = None if density.sigma is None else np.asarray(density.sigma)
    out = {"count": np.zeros(n_parts), "x": np.zeros((n_parts, p)), "y": np.zeros(n_parts),
           "xx": np.zeros((n_parts, p, p)), "xy": np.zeros((n_parts, p)),
           "yy": np.zeros(n_parts), "var": np.zeros(n_parts)}
    for rows, x in density.model.design_blocks(density.inputs):
        index, yb = parts.part[rows], y[rows]
        w2 = np.ones(yb.size) if sigma is None else 1.0 / sigma[rows] ** 2
        out["count"] += np.bincount(index, minlength=n_parts)
        out["y"] += np.bincount(index, yb, n_parts)
        out["yy"] += np.bincount(index, w2 * yb**2, n_parts)
        if sigma is not None:
            out["var"] += np.bincount(index, sigma[rows] ** 2, n_parts)
        for i in range(p):
            out["x"][:, i] += np.bincount(index, x[:, i], n_parts)
            out["xy"][:, i] += np.bincount(index, w2 * x[:, i] * yb, n_parts)
            for j in range(i, p):
                out["xx"][:, i, j] += np.bincount(index, w2 * x[:, i] * x[:, j], n_parts)
                out["xx"][:, j, i] = out["xx"][:, i, j]
    return out


def _coefficient_prior(density: BenchDensity) -> tuple[np.ndarray, np.ndarray]:
    """The model coefficients' Normal priors as a precision and a mean (precision 0 where a
    prior is flat): what a closed-form refit adds to its normal equations."""
    p = density.n_model
    precision = np.asarray(density.prior_on)[:p] / np.asarray(density.prior_scale)[:p] ** 2
    return precision, np.asarray(density.prior_loc)[:p]


def _linear_folds(density: BenchDensity, parts: Stretches) -> list[HeldOut]:
    """Closed-form refits of a linear model with white noise, one per fold."""
    sums = _part_sums(density, parts)
    p = density.n_model
    precision, prior_mean = _coefficient_prior(density)
    known = density.sigma is not None
    folds = []
    for k in range(int(parts.fold_of.max()) + 1):
        held = parts.fold_of == k
        train = {key: value[~held].sum(axis=0) for key, value in sums.items()}
        gram, xy = train["xx"], train["xy"]
        scale2 = 1.0
        if not known:
            solution = np.linalg.lstsq(gram, xy, rcond=None)[0]
            rss = train["yy"] - 2.0 * solution @ xy + solution @ gram @ solution
            scale2 = max(float(rss) / max(train["count"] - p, 1.0), 1e-300)
        a = gram / scale2 + np.diag(precision)
        covariance = np.linalg.pinv(a)
        theta = covariance @ (xy / scale2 + precision * prior_mean)
        counts = sums["count"][held]
        x_mean = sums["x"][held] / counts[:, None]
        noise = sums["var"][held] / counts**2 if known else scale2 / counts
        folds.append(HeldOut(observed=sums["y"][held] / counts, predicted=x_mean @ theta,
                             covariance=x_mean @ covariance @ x_mean.T + np.diag(noise),
                             counts=counts,
                             noise_dof=np.inf if known else float(train["count"] - p)))
    return folds


def _collapsed_folds(density: BenchDensity, parts: Stretches, time_s: np.ndarray,
                     point_u: np.ndarray) -> list[HeldOut]:
    """Refits of a model linear in its real coefficients given its positive ones (under any
    noise model), with its noise levels and positive parameters held at the full fit's
    mode ``point_u``: each fold's coefficients are their exact Gaussian posterior given
    those (:mod:`gyroid.inference._collapsed`, the filter predicting through the fold).
    Holding them leaves their uncertainty out of the bands, which can only make the check
    stricter."""
    real, positive = split_parameters(density)
    p = density.n_model
    drift = np.asarray(density.drift)
    observed = part_means(drift, parts.part, parts.n_parts)
    counts = np.bincount(parts.part, minlength=parts.n_parts).astype(float)
    if positive.size:
        columns = jnp.asarray(columns_at(density, point_u[positive])[0])
        offset, design = drift - np.asarray(columns[:, 0]), np.asarray(columns[:, 1:])
    else:
        columns, offset = None, np.zeros_like(drift)
        design = np.asarray(density.model.design(density.inputs))
    offset_means = part_means(offset, parts.part, parts.n_parts)
    design_means = np.column_stack([part_means(design[:, i], parts.part, parts.n_parts)
                                    for i in range(real.size)])
    v = jnp.asarray(point_u[p:])
    values = dict(zip(density.noise_names, np.exp(point_u[p:]), strict=True))
    noise_cov = _noise_covariance(density, values, parts, time_s)
    folds = []
    for k in range(int(parts.fold_of.max()) + 1):
        held = parts.fold_of == k
        # padded as the mode's form is, so the two share one compiled program
        kept = padded(collapsed_form(density.without_rows(parts.rows_of_fold(k)), columns,
                                     None if columns is None else real))
        mean, factor = conditional_solution(kept, v)
        factor = np.asarray(factor)
        covariance = np.linalg.inv(factor @ factor.T)[:real.size, :real.size]
        x = design_means[held]
        folds.append(HeldOut(observed=observed[held],
                             predicted=offset_means[held] + x @ np.asarray(mean)[:real.size],
                             covariance=x @ covariance @ x.T + noise_cov[np.ix_(held, held)],
                             counts=counts[held]))
    return folds



def _refit_folds(density: BenchDensity, parts: Stretches, time_s: np.ndarray
                 ) -> list[HeldOut]:
    """Refits by the posterior mode with each fold's rows masked (any model, any noise
    model); every fold has the same shapes, so they share one compilation."""
    p = density.n_model
    y = np.asarray(density.drift)
    observed = part_means(y, parts.part, parts.n_parts)
    counts = np.bincount(parts.part, minlength=parts.n_parts).astype(float)
    folds = []
    for k in range(int(parts.fold_of.max()) + 1):
        held = parts.fold_of == k
        point = point_estimate(density.without_rows(parts.rows_of_fold(k)))
        means = part_means(np.asarray(predicted(density, jnp.asarray(point.u))), parts.part,
                           parts.n_parts)
        jacobian = mean_jacobian(density.predict, point.u[:p], point.u[p:], parts.part,
                                 parts.n_parts)[held]
        model = jacobian @ point.covariance_u[:p, :p] @ jacobian.T
        folds.append(HeldOut(observed=observed[held], predicted=means[held],
                             covariance=model + _noise_covariance(density, point.value, parts,
                                                                  time_s)[np.ix_(held, held)],
                             counts=counts[held]))
    return folds


def _noise_covariance(density: BenchDensity, values: dict, parts: Stretches,
                      time_s: np.ndarray) -> np.ndarray:
    """The noise model's covariance of the parts' means, at the training fit's noise levels
    (``values``: by name, natural units), as the likelihood reads the rows (a carried
    thermometer's noise included)."""
    counts = np.bincount(parts.part, minlength=parts.n_parts).astype(float)
    white_levels = {k: values[k] for k in density.noise_names}
    if density.sigma is not None:
        white = (np.bincount(parts.part, np.asarray(density.sigma) ** 2, parts.n_parts)
                 / counts**2)
    else:
        white = float(density.noise.row_white_sd(white_levels, step_s=density.step_s,
                                                 row_scale=density.row_scale)) ** 2 / counts
    covariance = density.noise.part_covariance(time_s, parts.part, parts.n_parts,
                                               density.step_s, white, white_levels,
                                               block_means=density.gap_s is not None)
    return covariance
