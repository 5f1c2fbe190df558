"""The mode of a collapsed form (:mod:`gyroid.inference._collapsed`: a model's real
coefficients integrated out under correlated noise): BFGS on the noise levels' marginal
posterior (compiled once per number of coefficients, whatever the model; each start's
coordinates whitened by the marginal's Hessian there), the coefficients' conditional mean
there, and the one Hessian routine, solver message and safe inverse the
bench mode-finder (:mod:`gyroid.inference._point`, :mod:`gyroid.inference._point_profiled`)
shares.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from gyroid.inference._collapsed import conditional_solution, padded


def _negative_marginal(v: jax.Array, collapsed) -> jax.Array:
    return -collapsed.log_posterior(v)


#: The marginal's gradient at each row of an array of noise levels (one compiled call).
_marginal_gradients = eqx.filter_jit(eqx.filter_vmap(jax.grad(_negative_marginal),
                                                     in_axes=(0, None)))


class MarginalSolution(NamedTuple):
    """BFGS's answer from one start: the noise levels (sampling coordinates) and optimistix's
    result."""

    value: jax.Array
    result: optx.RESULTS


#: BFGS's absolute tolerance (:func:`_marginal_bfgs`): a step's size in posterior sds.
MODE_ATOL = 1e-6


@eqx.filter_jit
def _marginal_bfgs(starts, maps, collapsed):
    """BFGS on the collapsed marginal from each row of ``starts``, side by side (vmapped:
    one filter pass per iteration serves every start; run one by one, the starts' passes
    and dispatches were most of a discrepancy search's time), each in the coordinates ``y``
    of ``v = map y`` (:func:`_whitening`; the identity gives the levels' own), compiled
    once per log shape, padded width (:func:`~gyroid.inference._collapsed.padded`) and
    number of starts.

    BFGS stops when a step moves every coordinate of ``y`` by less than ``MODE_ATOL`` plus
    1e-9 of its size and the marginal by less than that plus 1e-9 of its own: whitened,
    ``y`` is in posterior sds, so the step rule asks for a millionth of an sd (at an
    absolute 1e-9 it asked for a billionth, which the filter's rounding barely allows, and
    one start of paper A's bench took 57 steps where 27 reach the same mode to 1e-7 in
    each log level). The coordinates are scaled, not shifted to the start, so the rule's
    relative part keeps its meaning where no Hessian whitens them (the identity)."""
    def one(start, to_levels):
        def objective(y, collapsed):
            return _negative_marginal(to_levels @ y, collapsed)

        solution = optx.minimise(objective, optx.BFGS(rtol=1e-9, atol=MODE_ATOL),
                                 jnp.linalg.solve(to_levels, start), args=collapsed,
                                 max_steps=2000, throw=False)
        value = to_levels @ solution.value
        return value, solution.result, _negative_marginal(value, collapsed)

    return jax.vmap(one)(starts, maps)


#: Central differences' step in the noise levels' sampling coordinates (logs).
_HESSIAN_STEP = 1e-4


def marginal_hessian(collapsed, v: np.ndarray) -> np.ndarray:
    """The marginal's Hessian at the levels ``v`` by central differences of its gradient
    (one compiled call of ``2 k`` gradients) rather than jax.hessian, whose
    forward-over-reverse pass through the filter's scan took 46 s on the demo's log."""
    v = np.asarray(v, dtype=float)
    steps = _HESSIAN_STEP * np.eye(v.size)
    gradients = np.asarray(_marginal_gradients(
        jnp.asarray(np.concatenate([v + steps, v - steps])), collapsed))
    hessian = (gradients[: v.size] - gradients[v.size :]) / (2 * _HESSIAN_STEP)
    return 0.5 * (hessian + hessian.T)


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
                  lanes: int | None = None) -> tuple[MarginalSolution, float]:
    """BFGS on a collapsed problem's marginal from ``noise_u`` and from each level of
    ``correlated`` raised :data:`RAISED_START` times; the best plausible solution (its
    levels within 6 prior sds of each prior's median: far beyond, the filter's arithmetic,
    a walk's variance 1e30 times the data's, is no likelihood) and its log-posterior.
    ``lanes``: run this many starts side by side, repeating ``noise_u`` (a call with fewer
    starts then shares the compiled program of one with more: repeats cost little beside a
    compilation)."""
    collapsed = padded(collapsed)  # one compilation for 1 to 8 coefficients
    start = np.asarray(noise_u, dtype=float)
    starts = [start] + [start + math.log(RAISED_START) * (np.arange(start.size) == i)
                        for i in correlated]
    starts += [start] * max((lanes or 0) - len(starts), 0)
    starts = np.stack(starts)
    values, results, objective = _marginal_bfgs(
        jnp.asarray(starts), jnp.asarray(_whitening(collapsed, starts)), collapsed)
    solutions = [MarginalSolution(values[i], jax.tree.map(lambda x, i=i: x[i], results))
                 for i in range(len(starts))]
    loc, scale = np.asarray(collapsed.noise_loc), np.asarray(collapsed.noise_scale)
    on = np.asarray(collapsed.noise_on) > 0
    objective = [float(f) for f in np.asarray(objective)]
    plausible = [i for i, s in enumerate(solutions) if np.isfinite(objective[i]) and np.all(
        ~on | (np.abs(np.asarray(s.value) - loc) <= 6.0 * scale))]
    best = min(plausible, key=objective.__getitem__) if plausible else 0
    return solutions[best], -objective[best]


def collapsed_mode(collapsed, u_model: np.ndarray, noise_u: np.ndarray,
                   correlated: tuple[int, ...] = (), *, lanes: int | None = None):
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
    and the best of them is the mode (``lanes``: :func:`marginal_mode`'s)."""
    return at_marginal_mode(
        collapsed, marginal_mode(collapsed, noise_u, correlated, lanes=lanes)[0], u_model)


def at_marginal_mode(collapsed, solution, u_model: np.ndarray):
    """The joint point at a marginal mode ``solution`` (:func:`marginal_mode`'s): the
    coefficients' conditional mean (``u_model`` where that is not finite) and the noise
    levels, their covariance, whether it converged and the solver's message."""
    r = collapsed.beta_loc.size
    collapsed = padded(collapsed)
    v = solution.value
    hessian = marginal_hessian(collapsed, np.asarray(v))
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
