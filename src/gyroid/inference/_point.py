"""A bench problem's mode with optimistix: the posterior mode and its Gaussian covariance.

1. For given positive parameters (time constants) every drift effect is linear in the
   real parameters, so those are solved exactly (variable projection); the grid of
   :mod:`gyroid.inference._starts` over the time constants gives the starting values
   (several starts where the model is nonlinear).
2. Levenberg-Marquardt (optimistix) on the noise-weighted residuals plus standardised prior
   residuals, from the best starts; the white-noise level, when unknown, is the residual
   RMS with ``n - p`` degrees of freedom.
3. With a correlated noise model (``white+gm``, or white noise with the thermometer's
   noise carried through dT/dt), BFGS on the full log-posterior.

A model linear in its parameters with white noise needs none of this: its mode and
covariance follow in closed form from the sufficient statistics (``_linear_gaussian``).

The covariance is the Gauss-Newton ``(J'J)^-1`` of the weighted residuals at the optimum
(exact for a linear model), or the inverse Hessian of the log-posterior (``white+gm``).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from gyroid.inference._batching import problem_batcher
from gyroid.inference._bench_density import BenchDensity
from gyroid.inference._collapsed import collapse, conditional_solution
from gyroid.inference._problem import PointEstimate
from gyroid.inference._starts import grid_points, start_grid
from gyroid.models._priors import Normal, natural_with_sd


def _real_mask(problem: BenchDensity) -> np.ndarray:
    return ~np.asarray(problem.positive[: problem.n_model])


@eqx.filter_jit
def _projected(problem: BenchDensity, u_model: jax.Array, weights: jax.Array):
    """Exact solve of the real parameters with the positive ones fixed (variable projection)."""
    real = np.flatnonzero(_real_mask(problem))  # static: from the model's terms
    n_noise = len(problem.noise_names)

    def predict(values):
        full = u_model.at[real].set(values)
        return problem.predict(jnp.concatenate([full, jnp.zeros(n_noise)]))

    zero = jnp.zeros(real.size)
    offset = predict(zero)
    design = jax.jacfwd(predict)(zero)
    values, *_ = jnp.linalg.lstsq(design * weights[:, None], (problem.drift - offset) * weights)
    rss = jnp.sum(((problem.drift - offset - design @ values) * weights) ** 2)
    return u_model.at[real].set(values), rss


def _weighted_residuals(u_model, args):
    problem, weights = args
    u = jnp.concatenate([u_model, jnp.zeros(len(problem.noise_names))])
    data = (problem.drift - problem.predict(u)) * weights
    prior = problem.prior_residuals(u)[: problem.n_model]
    return jnp.concatenate([data, prior])


@eqx.filter_jit
def _levenberg_marquardt(problem: BenchDensity, u0: jax.Array, weights: jax.Array):
    solver = optx.LevenbergMarquardt(rtol=1e-10, atol=1e-10)
    solution = optx.least_squares(
        _weighted_residuals, solver, u0, args=(problem, weights), max_steps=500, throw=False
    )
    residuals = _weighted_residuals(solution.value, (problem, weights))
    jacobian = jax.jacfwd(_weighted_residuals)(solution.value, (problem, weights))
    return solution.value, solution.result, jnp.sum(residuals**2), jacobian


def _negative_log_posterior(u, problem):
    return -problem.log_posterior(u)


@eqx.filter_jit
def _bfgs(problem: BenchDensity, u0: jax.Array):
    solver = optx.BFGS(rtol=1e-9, atol=1e-9)
    solution = optx.minimise(
        _negative_log_posterior, solver, u0, args=problem, max_steps=2000, throw=False
    )
    hessian = jax.hessian(_negative_log_posterior)(solution.value, problem)
    return solution.value, solution.result, hessian


def _negative_marginal(v: jax.Array, collapsed) -> jax.Array:
    return -collapsed.log_posterior(v)


_marginal_gradient = eqx.filter_jit(jax.grad(_negative_marginal))
_marginal_value = eqx.filter_jit(_negative_marginal)


@eqx.filter_jit
def _marginal_bfgs(start, collapsed):
    """BFGS on the collapsed marginal from ``start``, compiled once per log shape (called
    outside jit, optimistix traced its loop anew on every call: 0.2 s a start)."""
    return optx.minimise(_negative_marginal, optx.BFGS(rtol=1e-9, atol=1e-9), start,
                         args=collapsed, max_steps=2000, throw=False)


#: The correlated noise levels' extra starts: each raised this many times above its guess.
RAISED_START = 30.0


def marginal_mode(collapsed, noise_u: np.ndarray, correlated: tuple[int, ...] = ()):
    """BFGS on a collapsed problem's marginal from ``noise_u`` and from each level of
    ``correlated`` raised :data:`RAISED_START` times; the best plausible solution (its
    levels within 6 prior sds of each prior's median: far beyond, the filter's arithmetic,
    a walk's variance 1e30 times the data's, is no likelihood) and its log-posterior."""
    starts = [jnp.asarray(noise_u)] + [jnp.asarray(noise_u).at[i].add(math.log(RAISED_START))
                                       for i in correlated]
    solutions = [_marginal_bfgs(start, collapsed) for start in starts]
    loc, scale = np.asarray(collapsed.noise_loc), np.asarray(collapsed.noise_scale)
    on = np.asarray(collapsed.noise_on) > 0
    values = [float(_marginal_value(s.value, collapsed)) for s in solutions]
    plausible = [i for i, s in enumerate(solutions) if np.isfinite(values[i]) and np.all(
        ~on | (np.abs(np.asarray(s.value) - loc) <= 6.0 * scale))]
    best = min(plausible, key=values.__getitem__) if plausible else 0
    return solutions[best], -values[best]


def _collapsed_mode(collapsed, u_model: np.ndarray, noise_u: np.ndarray,
                    correlated: tuple[int, ...] = ()):
    """The mode of a collapsed problem's noise levels (their marginal posterior, the
    coefficients integrated out) and the coefficients' conditional mean there: the point
    the sampled posterior is centred on. The joint mode's noise levels are biased low
    wherever the coefficients can absorb the noise (a random walk's level, say), which the
    point-against-posterior check would then flag. Covariance: the coefficients'
    conditional one beside the levels' inverse Hessian.

    The marginal can have a mode for each way of explaining slow wander (flicker or a random
    walk: a real log's, 33 +/- 7 deg/h/sqrt(h) of walk, had a second mode with none and
    more flicker, where the guess's BFGS stopped): besides the guess, BFGS starts from each
    level of ``correlated`` (indices into the levels) raised :data:`RAISED_START` times,
    and the best of them is the mode."""
    solution = marginal_mode(collapsed, noise_u, correlated)[0]
    v = solution.value
    # central differences of the gradient (a few passes) rather than jax.hessian, whose
    # forward-over-reverse pass through the filter's scan took 46 s on the demo's log
    step = 1e-4
    hessian = np.stack([(np.asarray(_marginal_gradient(v + step * e, collapsed))
                         - np.asarray(_marginal_gradient(v - step * e, collapsed))) / (2 * step)
                        for e in jnp.eye(v.size)])
    hessian = 0.5 * (hessian + hessian.T)
    mean, factor = conditional_solution(collapsed, v)
    factor = np.asarray(factor)
    covariance = _block_diag(_inverse(factor @ factor.T), _inverse(hessian))
    converged, message = _message(solution.result)
    if not np.all(np.isfinite(np.asarray(mean))):
        return np.concatenate([u_model, np.asarray(v)]), covariance, False, message
    return np.concatenate([np.asarray(mean), np.asarray(v)]), covariance, converged, message


def noise_guess(problem: BenchDensity) -> tuple[np.ndarray, tuple[int, ...]]:
    """The noise model's own guess of its levels (sampling coordinates) from the residuals
    of a linear model's white-noise mode, and the indices of its correlated levels: where
    :func:`marginal_mode` starts."""
    p = problem.n_model
    theta = _white_start(problem)[:p]
    residual = np.asarray(problem.drift) - np.asarray(problem.model.design(problem.inputs)) @ theta
    scale = float(np.sqrt(np.sum(residual**2) / max(residual.size - p, 1)))
    return _noise_start(problem, residual, scale)[0], _correlated_levels(problem)


def _correlated_levels(problem: BenchDensity) -> tuple[int, ...]:
    """Indices of the noise levels other than the white one (where the mode's extra
    starts go)."""
    white = problem.noise.level_names[0]
    return tuple(i for i, name in enumerate(problem.noise_names) if name != white)


def _message(result) -> tuple[bool, str]:
    ok = bool(result == optx.RESULTS.successful)
    text = optx.RESULTS[result].split("\n")[0] if not ok else "converged"
    return ok, text


def _starts(problem: BenchDensity) -> list[np.ndarray]:
    """Sampling-coordinate starts for the model parameters: real ones 0, positive ones on
    the grid of :mod:`gyroid.inference._starts`."""
    parameters = problem.model.parameters
    positive = [i for i, p in enumerate(parameters) if p.positive]
    starts = []
    for point in grid_points(start_grid(parameters, problem.inputs)):
        u = np.zeros(problem.n_model)
        u[positive] = point
        starts.append(u)
    return starts


def _linear_gaussian(problem: BenchDensity) -> PointEstimate:
    """Closed form for a linear model with white noise: the posterior mode and covariance
    from the sufficient statistics (exact; no iterations)."""
    n, p = problem.n, problem.n_model
    theta, scale, covariance = _gaussian_coefficients(
        problem, np.asarray(problem.gram), np.asarray(problem.solution),
        float(problem.rss_min), n)
    u, cov = theta, covariance
    if problem.noise_names:
        noise_u = np.array([math.log(scale / problem.row_scale)])  # a sample's sd
        u = np.concatenate([theta, noise_u])
        cov = _block_diag(covariance, np.array([[1.0 / (2.0 * max(n - p, 1))]]))
    x, sd = natural_with_sd(u, cov, problem.positive)
    # One compiled call (shared by logs of this shape), not op-by-op JAX on every row.
    prediction = np.asarray(problem_batcher(problem.predict)(u[None, :]))[0]
    return PointEstimate(
        names=problem.names, u=u, covariance_u=cov,
        value={k: float(v) for k, v in zip(problem.names, x, strict=True)},
        sd={k: float(v) for k, v in zip(problem.names, sd, strict=True)},
        converged=True, message="converged (closed form: linear model, white noise)",
        n_starts=1,
        rms_residual=float(np.sqrt(np.mean((np.asarray(problem.drift) - prediction) ** 2))),
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


def _white_start(problem: BenchDensity) -> np.ndarray:
    """A linear model's white-noise mode on the rows the likelihood reads (NumPy, from its
    design matrix), in sampling coordinates: where BFGS on a correlated likelihood starts
    (the thermometer's noise carried), without tracing a least-squares solver for it."""
    x = np.asarray(problem.model.design(problem.inputs))
    y = np.asarray(problem.drift)
    w = np.ones(problem.n) if problem.sigma is None else 1.0 / np.asarray(problem.sigma)
    if problem.weight is not None:
        keep = np.asarray(problem.weight) > 0
        x, y, w = x[keep], y[keep], w[keep]
    solution, *_ = np.linalg.lstsq(x * w[:, None], y * w, rcond=None)
    rss = float(np.sum(((y - x @ solution) * w) ** 2))
    gram = (x * w[:, None] ** 2).T @ x
    theta, scale, _ = _gaussian_coefficients(problem, gram, solution, rss, y.size)
    if not problem.noise_names:
        return theta
    return np.concatenate([theta, [math.log(max(scale / problem.row_scale, 1e-300))]])


def point_estimate(problem: BenchDensity, *, max_refine: int = 3,
                   noise_start: tuple[float, ...] | None = None) -> PointEstimate:
    """Posterior mode and covariance of a bench log's density (see the module
    docstring); ``noise_start``: a collapsed problem's noise levels at their marginal mode,
    found already (:func:`marginal_mode`, while choosing the dT/dt window): the only
    start."""
    if problem.gram is not None:
        return _linear_gaussian(problem)
    if problem.errors_in_variables and problem.model.is_linear:
        # a linear model carrying the thermometer: BFGS from its white mode (NumPy)
        value, result, hessian = _bfgs(problem, jnp.asarray(_white_start(problem)))
        return _point(problem, np.asarray(value), _inverse(np.asarray(hessian)),
                      *_message(result), n_starts=1)
    n, p = problem.n_observed, problem.n_model
    known = problem.sigma is not None and not problem.noise.correlated
    weights = 1.0 / problem.sigma if known else jnp.ones(problem.n)
    if problem.weight is not None:  # rows left out (a predictive check's training fit)
        weights = weights * problem.weight
    candidates = []
    for start in _starts(problem):
        u_model, rss = _projected(problem, jnp.asarray(start), weights)
        candidates.append((float(rss), np.asarray(u_model)))
    candidates.sort(key=lambda c: c[0] if math.isfinite(c[0]) else math.inf)
    best_rss = candidates[0][0]
    scale = 1.0 if known else math.sqrt(best_rss / max(n - p, 1))
    refined = []
    for _, start in candidates[: max_refine if len(candidates) > 1 else 1]:
        value, result, objective, jacobian = _levenberg_marquardt(
            problem, jnp.asarray(start), weights / scale
        )
        refined.append((float(objective), np.asarray(value), result, np.asarray(jacobian)))
    refined.sort(key=lambda r: r[0] if math.isfinite(r[0]) else math.inf)
    _, u_model, result, jacobian = refined[0]
    converged, message = _message(result)
    padded = jnp.concatenate([jnp.asarray(u_model), jnp.zeros(len(problem.noise_names))])
    residual = np.asarray(problem.drift) - np.asarray(problem.predict(padded))
    if problem.weight is not None:
        residual = residual[np.asarray(problem.weight) > 0]
    if not known:
        # Unknown white level: the residual RMS with n - p degrees of freedom (the exact
        # posterior scale of a linear model under a flat prior); refine the weights once.
        w = np.ones(n) if problem.sigma is None else 1.0 / np.asarray(problem.sigma)
        if problem.sigma is not None and problem.weight is not None:
            w = w[np.asarray(problem.weight) > 0]
        scale = math.sqrt(float(np.sum((residual * w) ** 2)) / max(n - p, 1))
        value, result, _, jacobian = _levenberg_marquardt(
            problem, jnp.asarray(u_model), weights / scale
        )
        u_model, jacobian = np.asarray(value), np.asarray(jacobian)
        converged, message = _message(result)
    covariance_model = _inverse(jacobian.T @ jacobian)
    u = u_model
    covariance = covariance_model
    if problem.noise_names:
        noise_u, noise_cov = _noise_start(problem, residual, scale)
        u = np.concatenate([u_model, noise_u])
        covariance = _block_diag(covariance_model, noise_cov)
    collapsed = collapse(problem)
    if collapsed is not None:
        if noise_start is not None:
            u, covariance, converged, message = _collapsed_mode(
                collapsed, u[:p], np.asarray(noise_start), ())
        else:
            u, covariance, converged, message = _collapsed_mode(
                collapsed, u[:p], u[p:], _correlated_levels(problem))
    elif problem.noise.correlated or problem.errors_in_variables:
        value, result, hessian = _bfgs(problem, jnp.asarray(u))
        u = np.asarray(value)
        converged, message = _message(result)
        covariance = _inverse(np.asarray(hessian))
    return _point(problem, u, covariance, converged, message, n_starts=len(candidates))


def _point(problem: BenchDensity, u: np.ndarray, covariance: np.ndarray, converged: bool,
           message: str, *, n_starts: int) -> PointEstimate:
    """The point estimate at the mode ``u`` (sampling coordinates) with its covariance."""
    x, sd = natural_with_sd(u, covariance, problem.positive)
    if not np.all(np.isfinite(sd)):
        converged, message = False, "the covariance at the optimum is singular"
    prediction = np.asarray(problem.predict(jnp.asarray(u)))
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


def _inverse(matrix: np.ndarray) -> np.ndarray:
    try:
        return np.linalg.inv(matrix)
    except np.linalg.LinAlgError:
        return np.full_like(matrix, np.nan)


def _block_diag(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.zeros((a.shape[0] + b.shape[0],) * 2)
    out[: a.shape[0], : a.shape[0]] = a
    out[a.shape[0] :, a.shape[0] :] = b
    return out
