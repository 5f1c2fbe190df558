"""The mode of a bench problem whose model is linear in its real coefficients once its
positive parameters are given (a warm-up's time constant, a lag's, a step's time: every
catalogued effect) under any noise model; part of the bench mode-finder
(:func:`gyroid.bench._point.point_estimate`).

The real coefficients are integrated out exactly for given positive parameters (the
collapsed form of :mod:`gyroid.inference._collapsed` on the model's columns there), and the
rest is found by alternating twice, from the grid of :mod:`gyroid.bench._starts`
(the noise levels first guessed from the residual of the grid's best white least
squares):

1. the noise levels held, the positive parameters maximise the collapsed marginal
   posterior: the grid (its points side by side, ``COLUMN_BATCH`` of
   :mod:`gyroid.inference._collapsed` at a time), then a bounded Nelder-Mead (Brent's
   method in one dimension) on host; each evaluation one forward filter pass. Only the
   model's columns (:func:`~gyroid.inference._model_columns.columns_at`) are compiled per
   model; the filter and the marginal are shared by every model of as many coefficients
   on the log's rows;
2. the positive parameters held, the noise levels at the marginal's mode
   (:func:`~gyroid.inference._marginal_mode.marginal_mode`: BFGS compiled once per number of
   coefficients, whatever the model).

Joint BFGS on every parameter instead compiled a gradient and a Hessian through the filter
for every model: 3-6 s each (measured 2026-11-27), most of a discrepancy search's time. The
covariance: the positive parameters' from the profile's curvature, the coefficients'
conditional one widened by how their mean moves with those (the law of total covariance),
the noise levels' inverse Hessian beside them.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import jax.numpy as jnp
import numpy as np

from gyroid._exported import exported
from gyroid.bench._starts import best_least_squares, grid_points, start_grid
from gyroid.inference._collapsed import (
    collapsed_form,
    conditional_solution,
    log_posteriors_at,
    padded,
)
from gyroid.inference._marginal_mode import at_marginal_mode, marginal_mode
from gyroid.inference._mode import BoundedSearch, safe_inverse, value_hessian
from gyroid.inference._model_columns import (
    chunks,
    columns_at,
    positive_log_prior,
    split_parameters,
)

#: The local search's bounds about the grid: a fifth of its least value to 3.3 times its
#: largest (logs).
BELOW, ABOVE = math.log(0.2), math.log(50.0 / 15.0)
#: The central differences' step in the positive parameters (logs).
STEP = 1e-3
#: The local search about the grid's best point (each evaluation a filter pass).
_SEARCH = BoundedSearch(xatol=1e-4, fatol=1e-4)


class _Profile:
    """A density's collapsed marginal as a function of its positive parameters: their
    start grid, the model's columns there, and the collapsed form (``base``; padded,
    ``template``) whose columns each evaluation replaces."""

    def __init__(self, density) -> None:
        self.density = density
        self.real, self.positive = split_parameters(density)
        self.grid = start_grid(density.model.parameters, density.inputs)
        self.points = np.stack(list(grid_points(self.grid)))
        raw = self._model_columns(self.points)
        self.base = collapsed_form(density, jnp.asarray(raw[0]), self.real)
        self.template = padded(self.base)
        self.grid_columns = self._padded(raw)

    def _model_columns(self, points: np.ndarray) -> np.ndarray:
        """The model's columns (:func:`~gyroid.inference._model_columns.columns_at`) at each
        row of ``points``."""
        return columns_at(self.density, points)

    def _padded(self, columns: np.ndarray) -> np.ndarray:
        extra = self.template.columns.shape[1] - columns.shape[2]
        return np.concatenate([columns, np.zeros((*columns.shape[:2], extra))], axis=2)

    def columns(self, points: np.ndarray) -> np.ndarray:
        """The model's columns at each row of ``points``, zero columns appended to the
        padded form's width."""
        return self._padded(self._model_columns(points))

    def values(self, points: np.ndarray, v: np.ndarray,
               columns: np.ndarray | None = None) -> np.ndarray:
        """The marginal log-posterior, the positive parameters' prior included, at each row
        of ``points`` and the noise levels ``v`` (given their ``columns``, read from
        there)."""
        columns = self.columns(points) if columns is None else columns
        levels = jnp.asarray(v, dtype=float)
        if len(points) == 1:
            found = np.asarray(log_posteriors_at(self.template, jnp.asarray(columns), levels))
        else:
            found = np.concatenate([np.asarray(log_posteriors_at(
                self.template, jnp.asarray(chunk), levels)) for chunk in chunks(columns)])
        return found[: len(points)] + positive_log_prior(self.density, points)

    def value(self, point, v: np.ndarray) -> float:
        return float(self.values(np.asarray(point, dtype=float)[None, :], v)[0])

    def at(self, point: np.ndarray):
        """The collapsed form at the positive parameters ``point``."""
        return self.base.with_columns(jnp.asarray(self._model_columns(point[None, :])[0]))

    def white_guess(self, noise_start: Callable[[np.ndarray, float], np.ndarray]
                    ) -> tuple[np.ndarray, np.ndarray]:
        """The grid point whose least squares in the real coefficients fits best (on the
        rows of positive weight) and the noise levels ``noise_start(residual, white)``
        guesses from its residual (``white``: the rows' sd with n - p degrees of
        freedom)."""
        density = self.density
        keep = slice(None) if density.weight is None else np.asarray(density.weight) > 0
        index, rss, _, residual = best_least_squares(c[keep] for c in self.grid_columns)
        if residual is None:
            raise ValueError("no point of the start grid gives finite model columns")
        scale = math.sqrt(rss / max(density.n_observed - density.n_model, 1))
        return self.points[index], np.asarray(noise_start(residual, scale), dtype=float)


@exported
def _log_likelihood(collapsed, u):
    return collapsed.log_likelihood(u)


def collapsed_at_white_start(density, noise_start: Callable[[np.ndarray, float], np.ndarray]):
    """A model with positive parameters: its collapsed form at the
    start grid's best white least-squares point, and the noise levels guessed by
    ``noise_start(residual, white)`` from that point's residual (what the rate window's
    marginal compares, :mod:`gyroid.bench._rate_window_marginal`)."""
    profile = _Profile(density)
    point, guess = profile.white_guess(noise_start)
    return profile.at(point), guess


def collapsed_log_likelihood(density, u: np.ndarray) -> float:
    """A correlated-noise density's log-likelihood at ``u`` (sampling coordinates) from its
    collapsed form at ``u``'s positive parameters: compiled once per number of real
    coefficients, whatever the model."""
    real, positive = split_parameters(density)
    p = density.n_model
    u = np.asarray(u, dtype=float)
    collapsed = padded(
        collapsed_form(density, jnp.asarray(columns_at(density, u[positive])[0]), real)
        if positive.size else collapsed_form(density))
    beta = np.zeros(collapsed.beta_loc.size)
    beta[:real.size] = u[real]
    return float(_log_likelihood(collapsed, jnp.asarray(np.concatenate([beta, u[p:]]))))


def _best_positive(profile: _Profile, v: np.ndarray, start: np.ndarray | None
                   ) -> tuple[np.ndarray, bool]:
    """The positive parameters (logs) of highest profile at the noise levels ``v``: the
    best point of the grid (given a ``start``: that), refined by a bounded local search
    (one parameter: Brent's method between the grid's neighbours of the best point, as the
    profile of a step's time has a maximum near every jump of the log); and whether that
    search converged."""
    grid = profile.grid
    if start is None:
        candidates = profile.points
        scores = profile.values(candidates, v, profile.grid_columns)
    else:
        candidates = np.asarray(start, dtype=float)[None, :]
        scores = profile.values(candidates, v)
    finite = np.where(np.isfinite(scores), scores, -math.inf)
    best = candidates[int(np.argmax(finite))]
    bounds = [(float(g.min()) + BELOW, float(g.max()) + ABOVE) for g in grid]
    if len(grid) == 1:
        values = np.sort(grid[0])
        below, above = values[values < best[0]], values[values > best[0]]
        bounds = [(below[-1] if below.size else bounds[0][0],
                   above[0] if above.size else bounds[0][1])]
    found = _SEARCH.minimise(lambda u: -profile.value(u, v), best, bounds)
    if -found.objective < float(np.max(finite)):
        return best, found.converged
    return found.value, found.converged


def _positive_covariance(profile: _Profile, u_positive: np.ndarray, v: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
    """The positive parameters' covariance (logs) from the profile's curvature at the noise
    levels ``v``, and the derivatives of the coefficients' conditional mean in them: by
    central differences (the profile's points side by side)."""
    r = profile.real.size
    steps = STEP * np.eye(u_positive.size)
    hessian = value_hessian(lambda points: profile.values(points, v), u_positive, STEP)

    def mean(u):
        return np.asarray(conditional_solution(padded(profile.at(u)), jnp.asarray(v))[0])[:r]

    jacobian = np.column_stack([(mean(u_positive + e) - mean(u_positive - e)) / (2 * STEP)
                                for e in steps])
    return safe_inverse(-hessian), jacobian


def profiled_mode(density, noise_start: Callable[[np.ndarray, float], np.ndarray],
                  correlated: tuple[int, ...]):
    """The mode (sampling coordinates, in the density's order), its covariance, whether it
    converged, the solver's message and the number of grid points: the noise levels
    guessed by ``noise_start(residual, white)`` from the best white start's residual (with
    the extra starts of ``correlated``, :func:`~gyroid.inference._marginal_mode.
    marginal_mode`), the positive parameters from the start grid at them, the noise levels
    at those, then once more each from where it was."""
    profile = _Profile(density)
    real, positive = profile.real, profile.positive
    _, v = profile.white_guess(noise_start)
    lanes = 1 + len(correlated)
    u_positive, ok = _best_positive(profile, v, None)
    solution, _ = marginal_mode(profile.at(u_positive), v, correlated, lanes=lanes)
    v = np.asarray(solution.value)
    u_positive, ok = _best_positive(profile, v, u_positive)
    collapsed = profile.at(u_positive)
    solution, _ = marginal_mode(collapsed, v, (), lanes=lanes)
    joint, covariance_rv, converged, message = at_marginal_mode(
        collapsed, solution, np.zeros(real.size))
    p, k, r = density.n_model, v.size, real.size
    u = np.empty(p + k)
    u[real], u[positive], u[p:] = joint[:r], u_positive, joint[r:]
    # the coefficients given the positive parameters, those from the profile: by the law
    # of total covariance, Cov(beta) = P^-1 + J S J', Cov(beta, positive) = J S
    s_positive, jacobian = _positive_covariance(profile, u_positive, joint[r:])
    order = np.concatenate([real, np.arange(p, p + k)])
    covariance = np.zeros((p + k, p + k))
    covariance[np.ix_(order, order)] = covariance_rv
    covariance[np.ix_(real, real)] += jacobian @ s_positive @ jacobian.T
    covariance[np.ix_(real, positive)] = jacobian @ s_positive
    covariance[np.ix_(positive, real)] = (jacobian @ s_positive).T
    covariance[np.ix_(positive, positive)] = s_positive
    if not ok:
        converged, message = False, "the time constants' search did not converge"
    return u, covariance, converged, message, len(profile.points)
