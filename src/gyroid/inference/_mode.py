"""Where gyroid finds a posterior's mode: every optimiser the inference runs, each set up
once, behind one entry point (``minimise``, or ``maximise`` for a host search of a
log-likelihood), and what they all share: one answer (:class:`Optimum`), one solver
message, one inverse, the finite-difference Hessians.

The finders, and who uses them:

* :class:`JointBFGS`: optimistix BFGS on a density's whole negative log-posterior,
  compiled per density, its Hessian by ``jax.hessian`` (paper B's roll loop, standardised;
  a pool's hyper-parameters).
* :class:`MarginalBFGS`: optimistix BFGS on a marginal (a bench's noise levels, its
  coefficients integrated out) from several starts side by side, each in coordinates
  whitened by the marginal's Hessian there.
* :class:`BoundedSearch`: a host search of a few positive parameters within bounds
  (Brent's method in one dimension, Nelder-Mead otherwise): a profile's time constants.
* :class:`BoundedGradientSearch`: host L-BFGS-B with an analytic gradient, polished by
  BFGS, from several starts (a static log's noise terms).
* :class:`FisherScoring`: iterated non-negative least squares for a likelihood linear in
  non-negative variances (a static log's noise terms' maximum likelihood).
* :func:`bracketed_root`: Brent's root in a bracket (a term's profile-likelihood bound).

Each returns where it stopped, whether it converged and why not in one line
(:func:`solver_message` for optimistix's results), so a point estimate reports every
finder's verdict alike.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from scipy import optimize

from gyroid._exported import exported


@dataclass(frozen=True, eq=False)
class Optimum:
    """Where a finder stopped: ``value`` (its coordinates), whether it ``converged`` and
    its one-line ``message``, and the minimised ``objective`` there."""

    value: np.ndarray
    converged: bool
    message: str
    objective: float = float("nan")


@dataclass(frozen=True, eq=False)
class CurvedOptimum(Optimum):
    """An :class:`Optimum` with the objective's ``curvature`` there (its Hessian, or
    Gauss-Newton's ``J'J``): a covariance's inverse."""

    curvature: np.ndarray = field(kw_only=True, repr=False)


def solver_message(result) -> tuple[bool, str]:
    """Whether an optimistix solve succeeded, and its message in one line."""
    ok = bool(result == optx.RESULTS.successful)
    text = optx.RESULTS[result].split("\n")[0] if not ok else "converged"
    return ok, text


def safe_inverse(matrix: np.ndarray, *, diagonal_fallback: bool = False) -> np.ndarray:
    """The inverse of a curvature: a covariance. Where the matrix is singular, NaNs (a
    covariance the checks then call singular); with ``diagonal_fallback``, the matrix is
    symmetrised first and, where its inverse is singular or not positive definite, each
    coordinate's inverse curvature alone (a covariance that keeps a sampler's proposal
    usable)."""
    matrix = np.asarray(matrix, dtype=float)
    if diagonal_fallback:
        matrix = 0.5 * (matrix + matrix.T)
    try:
        inverse = np.linalg.inv(matrix)
        if diagonal_fallback and not np.all(np.linalg.eigvalsh(inverse) > 0):
            raise np.linalg.LinAlgError
        return inverse
    except np.linalg.LinAlgError:
        if diagonal_fallback:
            return np.diag(1.0 / np.clip(np.abs(np.diag(matrix)), 1e-12, None))
        return np.full_like(matrix, np.nan)


def value_hessian(values: Callable[[np.ndarray], np.ndarray], x: np.ndarray, step: float
                  ) -> np.ndarray:
    """A function's Hessian at ``x`` by four-point central differences of its values,
    ``values`` evaluating it at each row of an array of points (side by side where it
    can): for functions without a compiled gradient (a host likelihood, a profile)."""
    x = np.asarray(x, dtype=float)
    q = x.size
    steps = step * np.eye(q)
    pairs = [(i, j) for i in range(q) for j in range(i, q)]
    signs = ((1, 1), (1, -1), (-1, 1), (-1, -1))
    points = np.array([x + a * steps[i] + b * steps[j] for i, j in pairs for a, b in signs])
    f = np.asarray(values(points), dtype=float).reshape(len(pairs), 4)
    hessian = np.empty((q, q))
    with np.errstate(invalid="ignore"):  # a side where the function is -inf: no curvature, NaN
        for k, (i, j) in enumerate(pairs):
            hessian[i, j] = hessian[j, i] = ((f[k, 0] - f[k, 1] - f[k, 2] + f[k, 3])
                                             / (4 * step**2))
    return hessian


def gradient_hessian(gradients: Callable[[np.ndarray], np.ndarray], x: np.ndarray,
                     step: float) -> np.ndarray:
    """A function's Hessian at ``x`` by central differences of its gradient, ``gradients``
    evaluating that at each row of an array of points (one compiled call of ``2 k``
    gradients), symmetrised: rather than ``jax.hessian``, whose forward-over-reverse pass
    through a filter's scan took 46 s on the demo's log."""
    x = np.asarray(x, dtype=float)
    steps = step * np.eye(x.size)
    found = np.asarray(gradients(np.concatenate([x + steps, x - steps])))
    hessian = (found[: x.size] - found[x.size :]) / (2 * step)
    return 0.5 * (hessian + hessian.T)


def _negative_log_posterior(u, density):
    return -density.log_posterior(u)


@exported
def _scaled_bfgs(density, start, scale, rtol: float, atol: float, max_steps: int):
    def objective(z, density):
        return _negative_log_posterior(start + scale * z, density)

    solution = optx.minimise(objective, optx.BFGS(rtol=rtol, atol=atol), jnp.zeros_like(start),
                             args=density, max_steps=max_steps, throw=False)
    value = start + scale * solution.value
    return value, solution.result, jax.hessian(_negative_log_posterior)(value, density)


@exported
def _joint_bfgs(density, start, rtol: float, atol: float, max_steps: int):
    solution = optx.minimise(_negative_log_posterior, optx.BFGS(rtol=rtol, atol=atol), start,
                             args=density, max_steps=max_steps, throw=False)
    return (solution.value, solution.result,
            jax.hessian(_negative_log_posterior)(solution.value, density))


_joint_hessian = exported(jax.hessian(_negative_log_posterior), name="joint_hessian")


class JointBFGS(eqx.Module):
    """BFGS (optimistix) on a density's negative log-posterior (``density.log_posterior``
    of sampling coordinates), compiled once per density's shapes; the curvature is its
    Hessian at the optimum (``jax.hessian``)."""

    rtol: float = eqx.field(static=True, default=1e-9)
    atol: float = eqx.field(static=True, default=1e-9)
    max_steps: int = eqx.field(static=True, default=2000)

    def minimise(self, density, start: np.ndarray, scale: np.ndarray | None = None
                 ) -> CurvedOptimum:
        """From ``start``; with ``scale``, in standardised coordinates ``start + scale z``
        (a parameter known to 1e-7 beside others known to 1e-3 stops unscaled step
        tolerances far too early)."""
        if scale is None:
            value, result, hessian = _joint_bfgs(density, jnp.asarray(start), self.rtol,
                                                 self.atol, self.max_steps)
        else:
            value, result, hessian = _scaled_bfgs(density, jnp.asarray(start),
                                                 jnp.asarray(scale), self.rtol, self.atol,
                                                 self.max_steps)
        converged, message = solver_message(result)
        return CurvedOptimum(np.asarray(value), converged, message,
                             curvature=np.asarray(hessian))

    def curvature(self, density, u: np.ndarray) -> np.ndarray:
        """The negative log-posterior's Hessian at ``u`` (one compiled program)."""
        return np.asarray(_joint_hessian(jnp.asarray(u), density))


@exported
def _batched_bfgs(objective, starts, maps, args, rtol: float, atol: float, max_steps: int):
    def one(start, to_levels):
        def whitened(y, args):
            return objective(to_levels @ y, args)

        solution = optx.minimise(whitened, optx.BFGS(rtol=rtol, atol=atol),
                                 jnp.linalg.solve(to_levels, start), args=args,
                                 max_steps=max_steps, throw=False)
        value = to_levels @ solution.value
        return value, solution.result, objective(value, args)

    return jax.vmap(one)(starts, maps)


class MarginalBFGS(eqx.Module):
    """BFGS (optimistix) on ``objective(v, args)`` from each row of ``starts`` side by side
    (vmapped: one evaluation per iteration serves every start; one by one, the starts'
    passes and dispatches were most of a discrepancy search's time), each in the
    coordinates ``y`` of ``v = map y`` (``maps``: per start; the identity gives ``v``'s
    own), compiled once per objective, shapes and number of starts.

    BFGS stops when a step moves every coordinate of ``y`` by less than ``atol`` plus
    ``rtol`` of its size and the objective by less than that plus ``rtol`` of its own:
    whitened by the Hessian, ``y`` is in posterior sds, so ``atol`` 1e-6 asks for a
    millionth of an sd (at an absolute 1e-9 it asked for a billionth, which a filter's
    rounding barely allows, and one start of paper A's bench took 57 steps where 27 reach
    the same mode to 1e-7 in each log level). The coordinates are scaled, not shifted to
    the start, so the rule's relative part keeps its meaning where no Hessian whitens
    them."""

    rtol: float = eqx.field(static=True, default=1e-9)
    atol: float = eqx.field(static=True, default=1e-6)
    max_steps: int = eqx.field(static=True, default=2000)

    def minimise(self, objective: Callable, starts: np.ndarray, maps: np.ndarray, args
                 ) -> list[Optimum]:
        values, results, found = _batched_bfgs(objective, jax.device_put(starts),
                                               jax.device_put(maps), args, self.rtol,
                                               self.atol, self.max_steps)
        # each start's answer read on the host (indexing device arrays compiles programs)
        values, results = np.asarray(values), jax.tree.map(np.asarray, results)
        out = []
        for i, f in enumerate(np.asarray(found)):
            converged, message = solver_message(jax.tree.map(lambda x, i=i: x[i], results))
            out.append(Optimum(values[i], converged, message, float(f)))
        return out


@dataclass(frozen=True)
class BoundedSearch:
    """A host search for the minimum of ``function(x)`` within ``bounds`` (one per
    coordinate): Brent's bounded method in one dimension (between the bounds given: a
    bracket about the best point known), a bounded Nelder-Mead from ``start`` otherwise
    (scipy). Each evaluation may be a filter pass, so the tolerances are loose: a
    ten-thousandth in the coordinates (logs) and the objective."""

    xatol: float = 1e-4
    fatol: float = 1e-4

    def minimise(self, function: Callable[[np.ndarray], float], start: np.ndarray,
                 bounds: Sequence[tuple[float, float]]) -> Optimum:
        if len(bounds) == 1:
            found = optimize.minimize_scalar(lambda x: function(np.array([x])),
                                             bounds=tuple(bounds[0]), method="bounded",
                                             options={"xatol": self.xatol})
            x = np.array([found.x])
        else:
            found = optimize.minimize(function, start, method="Nelder-Mead", bounds=bounds,
                                      options={"xatol": self.xatol, "fatol": self.fatol})
            x = np.asarray(found.x)
        return Optimum(x, bool(found.success), str(found.message), float(found.fun))


@dataclass(frozen=True)
class BoundedGradientSearch:
    """The best of host L-BFGS-B runs (scipy, with an analytic gradient) from several
    starts within bounds, each polished by BFGS and clipped back: L-BFGS-B stops early
    where coordinates' gradients differ by orders of magnitude (a static log's N and a
    small prefilter's F). Converged when the gradient projected on the bounds vanishes
    (below ``gradient_rtol`` of the objective, at least 1)."""

    gtol: float = 1e-8
    ftol: float = 1e-15
    max_steps: int = 5000
    polish_steps: int = 2000
    gradient_rtol: float = 1e-3

    def maximise(self, function: Callable[[np.ndarray], tuple[float, np.ndarray]],
                 starts: Sequence[np.ndarray], bounds: Sequence[tuple[float, float]]
                 ) -> Optimum:
        """The maximum of ``function(x) -> (value, gradient)``; the objective reported is
        the minimised negative value."""
        def negative(u):
            return tuple(-v for v in function(u))

        lo, hi = np.transpose(bounds)
        best = None
        for start in starts:
            found = optimize.minimize(negative, np.clip(start, lo, hi), jac=True,
                                      method="L-BFGS-B", bounds=bounds,
                                      options={"gtol": self.gtol, "ftol": self.ftol,
                                               "maxiter": self.max_steps})
            polished = optimize.minimize(negative, found.x, jac=True, method="BFGS",
                                         options={"gtol": self.gtol,
                                                  "maxiter": self.polish_steps})
            polished.x = np.clip(polished.x, lo, hi)
            polished.fun, polished.jac = negative(polished.x)
            polished.jac = np.asarray(polished.jac)
            for candidate in (found, polished):
                if best is None or candidate.fun < best.fun:
                    best = candidate
        assert best is not None, "BoundedGradientSearch needs a start"
        grad = np.asarray(best.jac)
        free = ~(((best.x <= lo + 1e-9) & (grad > 0)) | ((best.x >= hi - 1e-9) & (grad < 0)))
        converged = bool(np.isfinite(best.fun) and np.max(np.abs(grad * free), initial=0.0)
                         < self.gradient_rtol * max(1.0, abs(best.fun)))
        return Optimum(np.asarray(best.x), converged, str(best.message), float(best.fun))


@dataclass(frozen=True)
class FisherScoring:
    """The maximum of a log-likelihood of data ``observed`` (one value per level, each the
    mean of ``count`` squares) whose expectation is linear in non-negative variances ``x``,
    ``columns @ x + held``: Fisher scoring, which here is iterated non-negative least
    squares, each step fitting ``x >= 0`` to ``observed`` weighted by ``count / (2 V^2)``
    at the current model ``V`` (the first step at the data's), a step halved until the
    likelihood rises and the expectation stays positive. A variance at zero keeps its say
    in every step (a gradient search on log-amplitudes lost terms driven towards zero,
    whose gradient vanishes there)."""

    max_steps: int = 500
    #: The relative rise in log-likelihood that ends the steps.
    tol: float = 1e-12

    def maximise(self, log_likelihood: Callable[[np.ndarray], float], columns: np.ndarray,
                 held: np.ndarray, observed: np.ndarray, count: np.ndarray,
                 start: np.ndarray | None = None) -> np.ndarray:
        """The variances at the maximum of ``log_likelihood(x)`` (``-inf`` where the model
        is not positive), from ``start`` or the data's weights."""
        target = observed - held
        floor = 1e-12 * float(np.max(observed))  # a model variance at or below zero

        def fit(variance: np.ndarray) -> np.ndarray:
            root = np.sqrt(count / 2.0) / np.maximum(variance, floor)
            return optimize.nnls(columns * root[:, None], target * root,
                                 maxiter=50 * len(root))[0]

        x = fit(observed) if start is None else np.maximum(start, 0.0)
        if not np.isfinite(log_likelihood(x)):  # a data-weighted step too deep: no subtraction
            x = np.where(columns.min(axis=0) < 0, 0.0, x)
        value = log_likelihood(x)
        for _ in range(self.max_steps):
            proposal = fit(columns @ x + held)
            step, new, trial = 1.0, -np.inf, x
            while step > 1e-6:
                trial = x + step * (proposal - x)
                new = log_likelihood(trial)
                if new >= value:
                    break
                step *= 0.5
            if not new >= value:
                break
            done = new - value <= self.tol * max(1.0, abs(value))
            x, value = trial, new
            if done:
                break
        return x


def bracketed_root(function: Callable[[float], float], low: float, high: float, *,
                   xtol: float) -> float:
    """The root of ``function`` between ``low`` and ``high``, where it changes sign
    (Brent's method, scipy)."""
    return float(optimize.root_scalar(function, bracket=(low, high), method="brentq",
                                      xtol=xtol).root)
