"""The mode of a bench problem whose model is linear in its real coefficients once its
positive parameters are given (a warm-up's time constant, a lag's, a step's time: every
catalogued effect) under correlated noise; part of the bench mode-finder
(:func:`gyroid.inference._point.point_estimate`).

The real coefficients are integrated out exactly for given positive parameters (the
collapsed form of :mod:`gyroid.inference._collapsed` on the model's columns there), and the
rest is found by alternating twice, from the grid of :mod:`gyroid.inference._starts`:

1. the noise levels held, the positive parameters maximise the collapsed marginal
   posterior: the grid, then a bounded Nelder-Mead (Brent's method in one dimension) on
   host; each evaluation one forward filter pass, compiled once per model;
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

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from scipy.optimize import minimize, minimize_scalar

from gyroid.inference._collapsed import (
    collapse,
    conditional_solution,
    model_columns,
    padded,
    split_parameters,
)
from gyroid.inference._marginal_mode import at_marginal_mode, marginal_mode, safe_inverse
from gyroid.inference._starts import grid_points, start_grid

#: The local search's bounds about the grid: a fifth of its least value to 3.3 times its
#: largest (logs).
BELOW, ABOVE = math.log(0.2), math.log(50.0 / 15.0)


def _positive_log_prior(density, u_positive):
    _, positive = split_parameters(density)
    loc, scale, on = (jnp.asarray(a)[positive] for a in (
        density.prior_loc, density.prior_scale, density.prior_on))
    z = (u_positive - loc) / scale
    return jnp.sum(on * (-0.5 * z**2 - jnp.log(scale)))


def _collapsed_form(density, u_positive):
    """The collapsed form at positive parameters ``u_positive`` (logs)."""
    return collapse(density, model_columns(density, u_positive), split_parameters(density)[0])


_collapsed_at = eqx.filter_jit(_collapsed_form)


@eqx.filter_jit
def _log_likelihood(collapsed, u):
    return collapsed.log_likelihood(u)


def collapsed_log_likelihood(density, u: np.ndarray) -> float:
    """A correlated-noise density's log-likelihood at ``u`` (sampling coordinates) from its
    collapsed form at ``u``'s positive parameters: compiled once per number of real
    coefficients, whatever the model."""
    real, positive = split_parameters(density)
    p = density.n_model
    u = np.asarray(u, dtype=float)
    collapsed = padded(_collapsed_at(density, jnp.asarray(u[positive])) if positive.size
                       else collapse(density))
    beta = np.zeros(collapsed.beta_loc.size)
    beta[:real.size] = u[real]
    return float(_log_likelihood(collapsed, jnp.asarray(np.concatenate([beta, u[p:]]))))


@eqx.filter_jit
def _profile(density, u_positive, v):
    """The marginal log-posterior at positive parameters ``u_positive`` and noise levels
    ``v`` (coefficients integrated out), the positive parameters' prior included."""
    return (_collapsed_form(density, u_positive).log_posterior(v)
            + _positive_log_prior(density, u_positive))


def _best_positive(density, grid: list[np.ndarray], v: np.ndarray, start: np.ndarray | None
                   ) -> tuple[np.ndarray, bool]:
    """The positive parameters (logs) of highest profile at the noise levels ``v``: the
    best point of ``grid`` (given a ``start``: that), refined by a bounded local search
    (one parameter: Brent's method between the grid's neighbours of the best point, as the
    profile of a step's time has a maximum near every jump of the log); and whether that
    search converged."""
    def value(u):
        return float(_profile(density, jnp.asarray(u, dtype=float), jnp.asarray(v)))

    candidates = ([np.asarray(u) for u in grid_points(grid)] if start is None
                  else [np.asarray(start)])
    scores = [value(u) for u in candidates]
    finite = [s if math.isfinite(s) else -math.inf for s in scores]
    best = candidates[int(np.argmax(finite))]
    bounds = [(float(g.min()) + BELOW, float(g.max()) + ABOVE) for g in grid]
    if len(grid) == 1:
        values = np.sort(grid[0])
        below, above = values[values < best[0]], values[values > best[0]]
        bracket = (below[-1] if below.size else bounds[0][0],
                   above[0] if above.size else bounds[0][1])
        found = minimize_scalar(lambda x: -value([x]), bounds=bracket, method="bounded",
                                options={"xatol": 1e-4})
        x = np.array([found.x])
    else:
        found = minimize(lambda u: -value(u), best, method="Nelder-Mead", bounds=bounds,
                         options={"xatol": 1e-4, "fatol": 1e-4})
        x = np.asarray(found.x)
    if -found.fun < max(finite):
        return best, bool(found.success)
    return x, bool(found.success)


#: The central differences' step in the positive parameters (logs).
STEP = 1e-3


def _positive_covariance(density, u_positive: np.ndarray, v: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
    """The positive parameters' covariance (logs) from the profile's curvature at the noise
    levels ``v``, and the derivatives of the coefficients' conditional mean in them: by
    central differences (a profile evaluation is one forward filter pass)."""
    q, r = u_positive.size, split_parameters(density)[0].size
    steps = STEP * np.eye(q)

    def f(u):
        return float(_profile(density, jnp.asarray(u), jnp.asarray(v)))

    def mean(u):
        collapsed = padded(_collapsed_at(density, jnp.asarray(u)))
        return np.asarray(conditional_solution(collapsed, jnp.asarray(v))[0])[:r]

    hessian = np.empty((q, q))
    for i in range(q):
        for j in range(i, q):
            a, b = steps[i], steps[j]
            hessian[i, j] = hessian[j, i] = (f(u_positive + a + b) - f(u_positive + a - b)
                                             - f(u_positive - a + b)
                                             + f(u_positive - a - b)) / (4 * STEP**2)
    jacobian = np.column_stack([(mean(u_positive + e) - mean(u_positive - e)) / (2 * STEP)
                                for e in steps])
    return safe_inverse(-hessian), jacobian


def profiled_mode(density, noise_u: np.ndarray, correlated: tuple[int, ...]):
    """The mode (sampling coordinates, in the density's order), its covariance, whether it
    converged and the solver's message, from noise levels ``noise_u`` (with the extra
    starts of ``correlated``, :func:`~gyroid.inference._marginal_mode.marginal_mode`):
    the positive parameters from the start grid at ``noise_u``, the noise levels at them,
    then once more each from where it was."""
    real, positive = split_parameters(density)
    grid = start_grid(density.model.parameters, density.inputs)
    v = np.asarray(noise_u, dtype=float)
    u_positive, ok = _best_positive(density, grid, v, None)
    solution, _ = marginal_mode(_collapsed_at(density, jnp.asarray(u_positive)), v,
                                correlated)
    v = np.asarray(solution.value)
    u_positive, ok = _best_positive(density, grid, v, u_positive)
    collapsed = _collapsed_at(density, jnp.asarray(u_positive))
    solution, _ = marginal_mode(collapsed, v, ())
    joint, covariance_rv, converged, message = at_marginal_mode(
        collapsed, solution, np.zeros(real.size))
    p, k, r = density.n_model, v.size, real.size
    u = np.empty(p + k)
    u[real], u[positive], u[p:] = joint[:r], u_positive, joint[r:]
    # the coefficients given the positive parameters, those from the profile: by the law
    # of total covariance, Cov(beta) = P^-1 + J S J', Cov(beta, positive) = J S
    s_positive, jacobian = _positive_covariance(density, u_positive, joint[r:])
    order = np.concatenate([real, np.arange(p, p + k)])
    covariance = np.zeros((p + k, p + k))
    covariance[np.ix_(order, order)] = covariance_rv
    covariance[np.ix_(real, real)] += jacobian @ s_positive @ jacobian.T
    covariance[np.ix_(real, positive)] = jacobian @ s_positive
    covariance[np.ix_(positive, real)] = (jacobian @ s_positive).T
    covariance[np.ix_(positive, positive)] = s_positive
    if not ok:
        converged, message = False, "the time constants' search did not converge"
    return u, covariance, converged, message
