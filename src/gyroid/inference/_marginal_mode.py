"""The mode of a collapsed form (:mod:`gyroid.inference._collapsed`: a model's real
coefficients integrated out under correlated noise): BFGS on the noise levels' marginal
posterior (compiled once per number of coefficients, whatever the model), the coefficients'
conditional mean there, and the one Hessian routine, solver message and safe inverse the
bench mode-finder (:mod:`gyroid.inference._point`, :mod:`gyroid.inference._point_profiled`)
shares.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from gyroid.inference._collapsed import conditional_solution, padded


def _negative_marginal(v: jax.Array, collapsed) -> jax.Array:
    return -collapsed.log_posterior(v)


_marginal_gradient = eqx.filter_jit(jax.grad(_negative_marginal))
_marginal_value = eqx.filter_jit(_negative_marginal)


@eqx.filter_jit
def _marginal_bfgs(start, collapsed):
    """BFGS on the collapsed marginal from ``start``, compiled once per log shape and
    padded width (:func:`~gyroid.inference._collapsed.padded`; called
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
    collapsed = padded(collapsed)  # one compilation for 1 to 8 coefficients
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


def collapsed_mode(collapsed, u_model: np.ndarray, noise_u: np.ndarray,
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
    return at_marginal_mode(collapsed, marginal_mode(collapsed, noise_u, correlated)[0],
                            u_model)


def at_marginal_mode(collapsed, solution, u_model: np.ndarray):
    """The joint point at a marginal mode ``solution`` (:func:`marginal_mode`'s): the
    coefficients' conditional mean (``u_model`` where that is not finite) and the noise
    levels, their covariance, whether it converged and the solver's message."""
    r = collapsed.beta_loc.size
    collapsed = padded(collapsed)
    v = solution.value
    # central differences of the gradient (a few passes) rather than jax.hessian, whose
    # forward-over-reverse pass through the filter's scan took 46 s on the demo's log
    step = 1e-4
    hessian = np.stack([(np.asarray(_marginal_gradient(v + step * e, collapsed))
                         - np.asarray(_marginal_gradient(v - step * e, collapsed))) / (2 * step)
                        for e in jnp.eye(v.size)])
    hessian = 0.5 * (hessian + hessian.T)
    mean, factor = conditional_solution(collapsed, v)
    mean, factor = np.asarray(mean)[:r], np.asarray(factor)
    covariance = block_diag(safe_inverse(factor @ factor.T)[:r, :r], safe_inverse(hessian))
    converged, message = solver_message(solution.result)
    if not np.all(np.isfinite(np.asarray(mean))):
        return np.concatenate([u_model, np.asarray(v)]), covariance, False, message
    return np.concatenate([np.asarray(mean), np.asarray(v)]), covariance, converged, message


def solver_message(result) -> tuple[bool, str]:
    """Whether an optimistix solve succeeded, and its message in one line."""
    ok = bool(result == optx.RESULTS.successful)
    text = optx.RESULTS[result].split("\n")[0] if not ok else "converged"
    return ok, text


def safe_inverse(matrix: np.ndarray) -> np.ndarray:
    """The inverse, or NaNs where the matrix is singular."""
    try:
        return np.linalg.inv(matrix)
    except np.linalg.LinAlgError:
        return np.full_like(matrix, np.nan)


def block_diag(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.zeros((a.shape[0] + b.shape[0],) * 2)
    out[: a.shape[0], : a.shape[0]] = a
    out[a.shape[0] :, a.shape[0] :] = b
    return out
