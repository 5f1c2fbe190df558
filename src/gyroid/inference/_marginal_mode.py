"""The mode of a collapsed form (:mod:`gyroid.inference._collapsed`: a model's real
coefficients integrated out under correlated noise): BFGS on the noise levels' marginal
posterior (:class:`~gyroid.inference._mode.MarginalBFGS`, compiled once per number of
coefficients, whatever the model; each start's coordinates whitened by the marginal's
Hessian there), and the coefficients' conditional mean there.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from scipy.linalg import block_diag

from gyroid._exported import exported
from gyroid.inference._collapsed import conditional_solution, padded
from gyroid.inference._mode import MarginalBFGS, Optimum, gradient_hessian, safe_inverse


def _negative_marginal(v: jax.Array, collapsed) -> jax.Array:
    return -collapsed.log_posterior(v)


#: The marginal's gradient at each row of an array of noise levels (one compiled call).
_marginal_gradients = exported(eqx.filter_vmap(jax.grad(_negative_marginal), in_axes=(0, None)),
                               name="marginal_gradients")

#: BFGS on the marginal: a step's size in posterior sds (whitened coordinates) ends it.
MODE_ATOL = 1e-6
_FINDER = MarginalBFGS(rtol=1e-9, atol=MODE_ATOL, max_steps=2000)


#: Central differences' step in the noise levels' sampling coordinates (logs).
_HESSIAN_STEP = 1e-4


def marginal_hessian(collapsed, v: np.ndarray) -> np.ndarray:
    """The marginal's Hessian at the levels ``v`` by central differences of its gradient
    (:func:`~gyroid.inference._mode.gradient_hessian`: one compiled call of ``2 k``
    gradients)."""
    return gradient_hessian(lambda points: _marginal_gradients(jnp.asarray(points), collapsed),
                            v, _HESSIAN_STEP)


def _whitening(collapsed, starts: np.ndarray) -> np.ndarray:
    """Per start, a matrix ``M`` with ``M' H M = I`` for the marginal's Hessian ``H`` there
    (its eigenvalues taken as their magnitudes, at least 1e-6 of the largest: a start far
    from the mode may sit where the marginal curves down), or the identity where ``H`` is
    not finite. BFGS starts from the identity as its Hessian; in the levels' own
    coordinates, where the marginal of 10^4 rows curves some 10^3 times faster in the
    white level than in a walk the log barely resolves, it took 33-63 steps to the mode of
    paper A's bench from the fit's three starts, and 21-27 in these."""
    maps = {}
    for row in map(tuple, np.asarray(starts, dtype=float)):
        if row in maps:
            continue
        hessian = marginal_hessian(collapsed, np.asarray(row))
        maps[row] = np.eye(len(row))
        if np.all(np.isfinite(hessian)):
            value, vectors = np.linalg.eigh(hessian)
            size = np.abs(value)
            if np.max(size) > 0:
                maps[row] = vectors / np.sqrt(np.maximum(size, 1e-6 * np.max(size)))
    return np.stack([maps[row] for row in map(tuple, np.asarray(starts, dtype=float))])


#: The correlated noise levels' extra starts: each raised this many times above its guess.
RAISED_START = 30.0


def marginal_mode(collapsed, noise_u: np.ndarray, correlated: tuple[int, ...] = (), *,
                  lanes: int | None = None) -> tuple[Optimum, float]:
    """BFGS on a collapsed problem's marginal from ``noise_u`` and from each level of
    ``correlated`` raised :data:`RAISED_START` times (the marginal can have a mode for each
    way of explaining slow wander: a real log's, 33 +/- 7 deg/h/sqrt(h) of walk, had a
    second mode with none and more flicker, where the guess's BFGS stopped); the best
    plausible solution (its
    levels within 6 prior sds of each prior's median: far beyond, the filter's arithmetic,
    a walk's variance 1e30 times the data's, is no likelihood) and its log-posterior.
    ``lanes``: run this many starts side by side, repeating ``noise_u`` (a call with fewer
    starts then shares the compiled program of one with more: repeats cost little beside a
    compilation)."""
    collapsed = padded(collapsed)  # one compilation for 1 to 8 coefficients
    start = np.asarray(noise_u, dtype=float)
    if start.size == 0:  # every row's sd given, no correlated level: the closed form
        value = float(collapsed.log_posterior(jnp.zeros(0)))
        return Optimum(start, True, "converged (closed form: no noise level to find)",
                       -value), value
    starts = [start] + [start + math.log(RAISED_START) * (np.arange(start.size) == i)
                        for i in correlated]
    starts += [start] * max((lanes or 0) - len(starts), 0)
    starts = np.stack(starts)
    solutions = _FINDER.minimise(_negative_marginal, starts, _whitening(collapsed, starts),
                                 collapsed)
    loc, scale = np.asarray(collapsed.noise_loc), np.asarray(collapsed.noise_scale)
    on = np.asarray(collapsed.noise_on) > 0
    plausible = [i for i, s in enumerate(solutions) if np.isfinite(s.objective) and np.all(
        ~on | (np.abs(s.value - loc) <= 6.0 * scale))]
    best = min(plausible, key=lambda i: solutions[i].objective) if plausible else 0
    return solutions[best], -solutions[best].objective


def at_marginal_mode(collapsed, solution: Optimum, u_model: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, bool, str]:
    """The joint point at a marginal mode ``solution`` (:func:`marginal_mode`'s): the
    coefficients' conditional mean (``u_model`` where that is not finite) and the noise
    levels, their covariance (the coefficients' conditional one beside the levels' inverse
    Hessian), whether it converged and the solver's message. This is the point the sampled
    posterior is centred on: the joint mode's noise levels are biased low wherever the
    coefficients can absorb the noise (a random walk's level, say), which the
    point-against-posterior check would then flag."""
    r = collapsed.beta_loc.size
    collapsed = padded(collapsed)
    v = solution.value
    hessian = marginal_hessian(collapsed, v) if v.size else np.zeros((0, 0))
    mean, factor = conditional_solution(collapsed, jnp.asarray(v))
    mean, factor = np.asarray(mean)[:r], np.asarray(factor)
    covariance = np.asarray(block_diag(safe_inverse(factor @ factor.T)[:r, :r],
                                       safe_inverse(hessian)))
    if not np.all(np.isfinite(mean)):
        return np.concatenate([u_model, v]), covariance, False, solution.message
    return np.concatenate([mean, v]), covariance, solution.converged, solution.message
