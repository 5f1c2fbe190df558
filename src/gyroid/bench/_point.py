"""A bench problem's mode with optimistix: the posterior mode and its Gaussian covariance.

* A model linear in its parameters with white noise: closed form from the sufficient
  statistics (``_linear_gaussian``; from its rows where some are held out).
* A linear model under correlated noise (a thermometer's noise carried through dT/dt
  included): its coefficients integrated out, the noise levels' marginal mode
  (:mod:`gyroid.inference._marginal_mode`), found while the dT/dt window was chosen where
  it was.
* A model with positive parameters (time constants, a step's time) under any noise model:
  for given positive parameters every drift effect is linear in the real ones, which are
  integrated out; the positive parameters are profiled from the grid of
  :mod:`gyroid.bench._starts` and the noise levels found at the marginal's mode
  (:mod:`gyroid.bench._point_profiled`).

The covariance is the closed form's, or the marginal's (the coefficients' conditional
covariance beside the levels' inverse Hessian, widened by the positive parameters'
profile).
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
from scipy.linalg import block_diag

from gyroid.bench._density import BenchDensity, predicted
from gyroid.bench._point_profiled import profiled_mode
from gyroid.inference._batching import problem_batcher
from gyroid.inference._collapsed import filtered_form
from gyroid.inference._marginal_mode import at_marginal_mode, marginal_mode
from gyroid.inference._mode import Optimum
from gyroid.inference._problem import PointEstimate
from gyroid.models._priors import Normal, natural_with_sd


def noise_guess(problem: BenchDensity) -> tuple[np.ndarray, tuple[int, ...]]:
    """The noise model's own guess of its levels (sampling coordinates) from the residuals
    of a linear model's white-noise mode, and the indices of its correlated levels: where
    :func:`marginal_mode` starts."""
    p = problem.n_model
    theta = _white_start(problem)[:p]
    residual = np.asarray(problem.drift) - np.asarray(problem.model.design(problem.inputs)) @ theta
    scale = float(np.sqrt(np.sum(residual**2) / max(residual.size - p, 1)))
    return _noise_start(problem, residual, scale)[0], correlated_levels(problem)


def correlated_levels(problem: BenchDensity) -> tuple[int, ...]:
    """Indices of the noise levels other than the white one (where the mode's extra
    starts go)."""
    white = problem.noise.level_names[0]
    return tuple(i for i, name in enumerate(problem.noise_names) if name != white)


def _linear_gaussian(problem: BenchDensity, gram: np.ndarray, solution: np.ndarray,
                     rss_min: float, n: int) -> PointEstimate:
    """Closed form for a linear model with white noise: the posterior mode and covariance
    from the weighted Gram matrix, least-squares solution and residual sum of squares of
    its ``n`` rows (:func:`_white_rows`, or its sufficient statistics; exact, no
    iterations)."""
    p = problem.n_model
    theta, scale, covariance = _gaussian_coefficients(problem, gram, solution, rss_min, n)
    u, cov = theta, covariance
    if problem.noise_names:
        noise_u = np.array([math.log(scale / problem.row_scale)])  # a sample's sd
        u = np.concatenate([theta, noise_u])
        cov = np.asarray(block_diag(covariance, np.array([[1.0 / (2.0 * max(n - p, 1))]])))
    x, sd = natural_with_sd(u, cov, problem.positive)
    # One compiled call (shared by logs of this shape), not op-by-op JAX on every row.
    prediction = np.asarray(problem_batcher(problem.predict)(u[None, :]))[0]
    kept = slice(None) if problem.weight is None else np.asarray(problem.weight) > 0
    return PointEstimate(
        names=problem.names, u=u, covariance_u=cov,
        value={k: float(v) for k, v in zip(problem.names, x, strict=True)},
        sd={k: float(v) for k, v in zip(problem.names, sd, strict=True)},
        converged=True, message="converged (closed form: linear model, white noise)",
        n_starts=1,
        rms_residual=float(np.sqrt(np.mean(((np.asarray(problem.drift) - prediction)[kept])
                                           ** 2))),
    )


def _gaussian_coefficients(problem: BenchDensity, gram: np.ndarray, solution: np.ndarray,
                           rss_min: float, n: int) -> tuple[np.ndarray, float, np.ndarray]:
    """The mode of a linear model's coefficients under white noise and their Normal priors
    (others flat), from the weighted Gram matrix, least-squares solution and residual sum
    of squares of ``n`` rows: (coefficients, the noise scale, the coefficients'
    covariance). An unknown scale is the residual RMS with n - p degrees of freedom."""
    p = problem.n_model
    precision = np.zeros(p)
    mean = np.zeros(p)
    for i, prior in enumerate(problem.priors[:p]):
        if isinstance(prior, Normal):
            precision[i], mean[i] = 1.0 / prior.scale**2, prior.loc
    known = problem.sigma is not None
    scale = 1.0 if known else math.sqrt(rss_min / max(n - p, 1))
    # Unknown noise: the mode's coefficients and scale solve each other; iterate to the
    # fixed point (a prior that disagrees with the log takes more than two rounds).
    for _ in range(1 if known else 200):
        a = gram / scale**2 + np.diag(precision)
        theta = np.linalg.solve(a, gram @ solution / scale**2 + precision * mean)
        delta = theta - solution
        rss = rss_min + float(delta @ gram @ delta)
        if known:
            break
        new_scale = math.sqrt(rss / max(n - p, 1))
        done = abs(new_scale - scale) <= 1e-12 * scale
        scale = new_scale
        if done:
            break
    return theta, scale, np.linalg.inv(gram / scale**2 + np.diag(precision))


def noise_from_residual(problem: BenchDensity, residual: np.ndarray, white: float
                        ) -> np.ndarray:
    """The noise model's guess of its levels (sampling coordinates) from a residual whose
    rows' sd is ``white``."""
    return _noise_start(problem, residual, white)[0]


def _white_rows(problem: BenchDensity) -> tuple[np.ndarray, np.ndarray, float, int]:
    """A linear model's weighted Gram matrix, least-squares solution and residual sum of
    squares on the rows the likelihood reads, and their number (NumPy, from its design
    matrix)."""
    x = np.asarray(problem.model.design(problem.inputs))
    y = np.asarray(problem.drift)
    w = np.ones(problem.n) if problem.sigma is None else 1.0 / np.asarray(problem.sigma)
    if problem.weight is not None:
        keep = np.asarray(problem.weight) > 0
        x, y, w = x[keep], y[keep], w[keep]
    solution, *_ = np.linalg.lstsq(x * w[:, None], y * w, rcond=None)
    rss = float(np.sum(((y - x @ solution) * w) ** 2))
    return (x * w[:, None] ** 2).T @ x, solution, rss, y.size


def _white_start(problem: BenchDensity) -> np.ndarray:
    """A linear model's white-noise mode (:func:`_white_rows`), in sampling coordinates:
    where BFGS on a correlated likelihood starts, without tracing a least-squares solver
    for it."""
    theta, scale, _ = _gaussian_coefficients(problem, *_white_rows(problem))
    if not problem.noise_names:
        return theta
    return np.concatenate([theta, [math.log(max(scale / problem.row_scale, 1e-300))]])


def point_estimate(problem: BenchDensity, *,
                   noise_mode: Optimum | None = None) -> PointEstimate:
    """Posterior mode and covariance of a bench log's density (see the module
    docstring); ``noise_mode``: a linear model's noise levels at their marginal mode,
    found already (:func:`marginal_mode`, from the same starts, while choosing the dT/dt
    window): not searched again."""
    if problem.stats is not None:
        stats = problem.stats
        return _linear_gaussian(problem, np.asarray(stats.gram), np.asarray(stats.solution),
                                float(stats.rss_min), problem.n)
    collapsed = filtered_form(problem)
    if collapsed is not None:  # a linear model under correlated noise: its marginal's mode
        correlated = correlated_levels(problem)
        if noise_mode is None:
            noise_mode, _ = marginal_mode(collapsed, noise_guess(problem)[0], correlated,
                                          lanes=1 + len(correlated))
        u, covariance, converged, message = at_marginal_mode(
            collapsed, noise_mode, _white_start(problem)[:problem.n_model])
        return _point(problem, u, covariance, converged, message,
                      n_starts=1 + len(correlated))
    if problem.model.is_linear:  # white rows without their statistics (some held out)
        return _linear_gaussian(problem, *_white_rows(problem))
    return _profiled(problem)


def _profiled(problem: BenchDensity) -> PointEstimate:
    """The mode of a model linear in its real coefficients given its positive ones: those
    profiled, these integrated out
    (:func:`~gyroid.bench._point_profiled.profiled_mode`), the noise levels guessed by
    the noise model from the best white start's residual."""
    u, covariance, converged, message, n_starts = profiled_mode(
        problem, lambda residual, white: noise_from_residual(problem, residual, white),
        correlated_levels(problem))
    return _point(problem, u, covariance, converged, message, n_starts=n_starts)


def _point(problem: BenchDensity, u: np.ndarray, covariance: np.ndarray, converged: bool,
           message: str, *, n_starts: int) -> PointEstimate:
    """The point estimate at the mode ``u`` (sampling coordinates) with its covariance."""
    x, sd = natural_with_sd(u, covariance, problem.positive)
    if not np.all(np.isfinite(sd)):
        converged, message = False, "the covariance at the optimum is singular"
    prediction = np.asarray(predicted(problem, jnp.asarray(u)))
    kept = slice(None) if problem.weight is None else np.asarray(problem.weight) > 0
    rms = float(np.sqrt(np.mean(((np.asarray(problem.drift) - prediction)[kept]) ** 2)))
    return PointEstimate(
        names=problem.names,
        u=u,
        covariance_u=covariance,
        value={k: float(v) for k, v in zip(problem.names, x, strict=True)},
        sd={k: float(v) for k, v in zip(problem.names, sd, strict=True)},
        converged=converged,
        message=message,
        n_starts=n_starts,
        rms_residual=rms,
    )


def _noise_start(problem: BenchDensity, residual: np.ndarray, white: float):
    """Starting values (log coordinates) and a rough covariance for the noise levels (the
    noise model's own guess, :meth:`gyroid.noise.NoiseModel.start_levels`)."""
    dof = max(residual.size - problem.n_model, 1)
    start, variances = problem.noise.start_levels(residual, white, step_s=problem.step_s,
                                                  row_scale=problem.row_scale, dof=dof)
    names = problem.noise_names
    return (np.log(np.maximum([start[k] for k in names], 1e-12)),
            np.diag([variances[k] for k in names]))
