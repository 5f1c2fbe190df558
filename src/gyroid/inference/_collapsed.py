"""A linear drift model with its coefficients integrated out: the bench posterior as one
marginal, over the noise levels, with two implementations.

Given the noise levels ``v`` (sampling coordinates: the logs of the noise model's levels),
the likelihood is Gaussian in the coefficients ``beta``: whitened data ``a`` and design
``A`` (``-0.5 |a - A beta|^2`` plus the rows' log-variances), and with the coefficients'
normal (or flat) priors, precision ``L0`` about ``m0``,

    P = A'A + L0,  beta_hat = P^-1 (A'a + L0 m0),
    log p(v | data) = log p(v) - 0.5 sum log(2 pi var) - 0.5 (a'a + m0'L0 m0 - b'beta_hat)
                      - 0.5 log|P| + const,

and ``beta | v, data ~ N(beta_hat, P^-1)``. Both are exact: sampling ``v`` from its
marginal (three dimensions for IEEE 952 noise, one for white noise's unknown level,
instead of those plus the coefficients) and then ``beta`` given each draw gives draws of
the same posterior as sampling them jointly.

* :class:`CollapsedCoefficients`: correlated noise, one Kalman pass over the data and every
  column of the design giving ``a`` and ``A`` (O(n p) an evaluation; a carried thermometer's
  beside it as one more process), or, for white noise beside a carried thermometer's, the
  rows' coordinates in their covariance's eigenbasis (O(n^2 p):
  :mod:`gyroid.noise._rate_error_eigenbasis`);
* :class:`SufficientCoefficients`: white rows, ``A'A`` and ``A'a`` from the R factor of the
  rows' weighted design and drift (O(p^2) an evaluation, whatever the log's length).
"""

from __future__ import annotations

import abc
import math
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid._exported import exported
from gyroid.noise._row_filter import RowFilter

_LOG_2PI = math.log(2.0 * math.pi)
#: ``A'A``, ``A'a``, the whitened residual's sum of squares at given coefficients, and the
#: rows' log normalising constant (:meth:`AbstractMarginal._normal_equations`).
NormalEquations = tuple[Array, Array, Callable[[Array], Array], Array]


class AbstractMarginal(eqx.Module):
    """The marginal posterior of a bench density's noise levels and the conditional
    posterior of its coefficients (module docstring); built by :func:`collapse`. An
    implementation gives the whitened normal equations at the noise levels."""

    beta_loc: Float[Array, " p"]
    beta_precision: Float[Array, " p"]  # 1/scale^2 of a normal prior, 0 for a flat one
    beta_log_norm: Float[Array, ""]  # the normal priors' log normalising constant
    noise_loc: Float[Array, " k"]  # the noise levels' priors (sampling coordinates)
    noise_scale: Float[Array, " k"]
    noise_on: Float[Array, " k"]

    @abc.abstractmethod
    def _normal_equations(self, v: Float[Array, " k"]) -> NormalEquations:
        """At the noise levels ``v``: ``A'A`` (p, p), ``A'a`` (p,), the whitened residual's
        sum of squares at given coefficients (a function, summed without cancellation) and
        the rows' log normalising constant ``-0.5 sum (log var + log 2 pi)``."""

    def _solve(self, v: Float[Array, " k"]):
        gram, right, residual_sq, log_norm = self._normal_equations(v)
        precision = gram + jnp.diag(self.beta_precision)
        b = right + self.beta_precision * self.beta_loc
        factor = jnp.linalg.cholesky(precision)
        mean = jax.scipy.linalg.cho_solve((factor, True), b)
        log_det = 2.0 * jnp.sum(jnp.log(jnp.diag(factor)))
        # a'a + m0'L0 m0 - b'beta_hat, summed as the residuals' squares: the same number,
        # without the cancellation that made it thousands below zero where a whitened row is
        # huge (a random walk's mean constrained with variance 3e-17, far in the tails);
        # an inexact solution can then only lower the likelihood
        quadratic = residual_sq(mean) + jnp.sum(self.beta_precision
                                                * (mean - self.beta_loc) ** 2)
        log_lik = (log_norm - 0.5 * quadratic - 0.5 * log_det
                   + 0.5 * mean.size * _LOG_2PI + self.beta_log_norm)
        return mean, factor, log_lik

    def log_posterior(self, v: Float[Array, " k"]) -> Float[Array, ""]:
        """The noise levels' marginal log-posterior (coefficients integrated out)."""
        r = self.noise_on * (v - self.noise_loc) / self.noise_scale
        log_prior = jnp.sum(-0.5 * r**2 - self.noise_on * (jnp.log(self.noise_scale)
                                                           + 0.5 * _LOG_2PI))
        value = self._solve(v)[2] + log_prior
        return jnp.where(jnp.isfinite(value), value, -jnp.inf)

    def solved(self, v: Float[Array, " k"]) -> Float[Array, " 1+p+p*p"]:
        """The marginal log-posterior at ``v``, then the coefficients' conditional mean and
        the Cholesky factor of their precision (row by row): all a draw of the joint
        posterior needs (:func:`conditional_draws`), from one evaluation."""
        mean, factor, _ = self._solve(v)
        return jnp.concatenate([self.log_posterior(v)[None], mean, factor.ravel()])

    def conditional(self, vz: Float[Array, " k_plus_p"]) -> Float[Array, " p"]:
        """A draw of the coefficients given the noise levels ``vz[:k]``, from standard
        normal deviates ``vz[k:]``: ``beta_hat + P^(-1/2) z``."""
        k = self.noise_loc.size
        mean, factor, _ = self._solve(vz[:k])
        return mean + jax.scipy.linalg.solve_triangular(factor.T, vz[k:], lower=False)


class CollapsedCoefficients(AbstractMarginal):
    """The marginal under the density's noise model: the drift and the design filtered by
    it (under white noise, a model's columns at given positive parameters: the rows are
    their own innovations)."""

    columns: Float[Array, "n 1+p"]  # the drift, then the design's columns
    #: The density's noise model on its rows (no drift model: candidates' fits on one log's
    #: rows with as many coefficients share every compiled program).
    row_filter: RowFilter

    def _innovations(self, v: Float[Array, " k"]) -> tuple[Array, Array]:
        """Every column filtered by the density's own noise model at the levels ``v``: the
        innovations and their variances (independent rows: the rows themselves)."""
        white, values = self.row_filter.levels_of(v)
        filtered = self.row_filter.innovations(self.columns, white, values)
        if filtered is None:
            return self.columns, jnp.broadcast_to(white**2, self.row_filter.weight.shape)
        return filtered

    def _normal_equations(self, v: Float[Array, " k"]) -> NormalEquations:
        white, values = self.row_filter.levels_of(v)
        filtered = self.row_filter.filtered(self.columns, white, values)
        if filtered is None:
            innovation = self.columns
            variance = jnp.broadcast_to(white**2, self.row_filter.weight.shape)
            ends = None
        else:
            innovation, variance, ends = filtered
        # a held-out row's weight 0 outside the root: sqrt(0 / variance) has no gradient
        weight = self.row_filter.weight
        scale = jnp.sqrt(weight) * jnp.sqrt(1.0 / variance)
        a, design = innovation[:, 0] * scale, innovation[:, 1:] * scale[:, None]
        log_norm = -0.5 * jnp.sum(weight * (jnp.log(variance) + _LOG_2PI))
        carried = self.row_filter.noise.carried_process
        if ends is None or carried is None or carried.ends is None:
            def residual_sq(beta):
                residual = a - design @ beta
                return residual @ residual

            return design.T @ design, design.T @ a, residual_sq, log_norm
        # a carried rate error's one-sided rows: the filter's covariance plus a low-rank
        # correction, by Woodbury's identity on the filter's whitened columns
        products, inner, log_det = carried.ends.whitened_products(
            jnp.column_stack([a, design]), ends * scale[:, None])
        on_a, on_design = products[:, 0], products[:, 1:]

        def corrected_sq(beta):
            residual, on = a - design @ beta, on_a - on_design @ beta
            return residual @ residual - on @ inner @ on

        return (design.T @ design - on_design.T @ inner @ on_design,
                design.T @ a - on_design.T @ inner @ on_a, corrected_sq,
                log_norm - 0.5 * log_det)

    def with_columns(self, columns: Float[Array, "n 1+r"]) -> CollapsedCoefficients:
        """This form on other columns (the drift less the model at zero real coefficients,
        then the model's derivatives in them: a model's positive parameters moved), zero
        columns appended to its width (a padded form, :func:`padded`); traceable."""
        extra = self.columns.shape[1] - columns.shape[1]
        columns = jnp.concatenate([columns, jnp.zeros((columns.shape[0], extra))], axis=1)
        return eqx.tree_at(lambda t: t.columns, self, columns)

    def log_likelihood(self, u: Float[Array, " p_plus_k"]) -> Float[Array, ""]:
        """The log-likelihood at sampling coordinates ``u`` (coefficients, then noise
        levels): the density's, from this form's filter."""
        p = self.beta_loc.size
        innovation, variance = self._innovations(u[p:])
        residual = innovation[:, 0] - innovation[:, 1:] @ u[:p]
        weight = self.row_filter.weight
        return -0.5 * jnp.sum(weight * (residual**2 / variance + jnp.log(variance) + _LOG_2PI))

    def filtered(self, v: Float[Array, " k"]) -> Float[Array, "n 2+p"]:
        """Every column's innovations at the levels ``v``, then their variances: the
        innovations of any coefficients' residual follow without another filter pass (the
        filter is linear in what it filters: the drift's less the design's times them)."""
        innovation, variance = self._innovations(v)
        return jnp.column_stack([innovation, variance])


class SufficientCoefficients(AbstractMarginal):
    """The marginal under white noise, on the R factor of the rows' weighted ``[X, y]``
    (their sufficient statistics: ``|y - X beta|^2 = |R (beta, -1)|^2``, O(p^2) an
    evaluation, whatever the log's length). The noise level, when the log does not give
    each row's sd, is a sample's log sd; a row's is that times ``row_scale``. (Rebuilt on a
    model's columns at each draw's time constants it cost a warm white warm-up fit 2.4x its
    whole posterior's weighing, 0.74 s against 0.31 s, and more compilations: a white
    model with time constants is weighed whole.)"""

    factor: Float[Array, "1+p 1+p"]
    n: Float[Array, ""]  # the rows the likelihood reads
    log_sigma_sum: Float[Array, ""]  # the rows' sum of log sd where the log gives them
    row_scale: float = eqx.field(static=True, default=1.0)

    @staticmethod
    def factor_of(columns: Float[Array, "n 1+p"], row_weight: Float[Array, " n"]
                  ) -> Float[Array, "1+p 1+p"]:
        """The R factor of the weighted ``[X, y]`` from ``columns`` (``y`` first), as the
        Cholesky factor of their cross-products (in float64 the residual sum loses some
        ``1e-16 |y|^2 / rss`` of itself; a QR factor, batched, deadlocked when two threads
        ran it: jaxlib 0.10.2's LAPACK call on the CPU)."""
        weighted = columns * row_weight[:, None]
        stacked = jnp.column_stack([weighted[:, 1:], weighted[:, 0]])
        return jnp.linalg.cholesky(stacked.T @ stacked).T

    def _normal_equations(self, v: Float[Array, " k"]) -> NormalEquations:
        if self.noise_loc.size:  # the level sampled: a row's variance s^2
            log_sd = v[0] + math.log(self.row_scale)
            inverse = jnp.exp(-2.0 * log_sd)
            log_norm = -self.n * (log_sd + 0.5 * _LOG_2PI)
        else:  # each row's sd given, in the rows' weights
            inverse = jnp.ones(())
            log_norm = -self.log_sigma_sum - 0.5 * self.n * _LOG_2PI
        design, data = self.factor[:, :-1], self.factor[:, -1]

        def residual_sq(beta):
            residual = design @ beta - data
            return (residual @ residual) * inverse

        return design.T @ design * inverse, design.T @ data * inverse, residual_sq, log_norm


#: A collapsed form's columns are padded to a multiple of this where its mode is found
#: (zero columns with unit normal priors change no value): models of 1 to 8 coefficients
#: on one log's rows (a discrepancy search's candidates) then share every compiled program.
PAD_COLUMNS = 8


def padded(collapsed: CollapsedCoefficients) -> CollapsedCoefficients:
    """``collapsed`` with zero columns to a multiple of :data:`PAD_COLUMNS` coefficients,
    each with a standard normal prior: every marginal value, and the first coefficients'
    conditional mean and covariance, are the same (a zero column's coefficient is its
    prior, independent of the rest, and its normal constant cancels)."""
    r = collapsed.beta_loc.size
    extra = -(-max(r, 1) // PAD_COLUMNS) * PAD_COLUMNS - r
    if extra == 0:
        return collapsed
    rows = collapsed.columns.shape[0]
    return eqx.tree_at(
        lambda c: (c.columns, c.beta_loc, c.beta_precision, c.beta_log_norm), collapsed,
        _on_device(
            np.concatenate([np.asarray(collapsed.columns), np.zeros((rows, extra))], axis=1),
            np.concatenate([np.asarray(collapsed.beta_loc), np.zeros(extra)]),
            np.concatenate([np.asarray(collapsed.beta_precision), np.ones(extra)]),
            np.asarray(np.asarray(collapsed.beta_log_norm) - 0.5 * extra * _LOG_2PI)))


@exported
def conditional_solution(collapsed: CollapsedCoefficients, v: Float[Array, " k"]):
    """The coefficients' conditional mean and the Cholesky factor of their precision given
    the noise levels ``v``, compiled once per log shape (called outside jit, the filter's
    scan was traced and compiled anew on every call: 0.2 s each)."""
    mean, factor, _ = collapsed._solve(v)
    return mean, factor


def conditional_draws(solved: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients drawn given noise levels whose :meth:`CollapsedCoefficients.solved`
    rows are ``solved`` (m, 1+p+p^2), from standard normal deviates ``z`` (m, p):
    ``beta_hat + P^(-1/2) z``, and the joint log-posterior of each draw, the marginal's plus
    the conditional Gaussian's log-density (the joint's factorisation; no further filter
    pass)."""
    m, p = z.shape
    mean = solved[:, 1:1 + p]
    factor = solved[:, 1 + p:].reshape(m, p, p)
    beta = mean + np.linalg.solve(np.swapaxes(factor, 1, 2), z[..., None])[..., 0]
    log_conditional = (-0.5 * np.sum(z**2, axis=1)
                       + np.sum(np.log(np.diagonal(factor, axis1=1, axis2=2)), axis=1)
                       - 0.5 * p * _LOG_2PI)
    return beta, solved[:, 0] + log_conditional


@exported
def log_posteriors_at(template: CollapsedCoefficients, columns: Float[Array, "m n 1+r"],
                      v: Float[Array, " k"]) -> Float[Array, " m"]:
    """The marginal log-posterior at noise levels ``v`` of ``template`` with its columns
    replaced by each of ``columns`` (:meth:`~CollapsedCoefficients.with_columns`): a model's
    profile over its positive parameters, compiled once per log shape, padded width and
    batch, whatever the model."""
    return jax.vmap(lambda c: template.with_columns(c).log_posterior(v))(columns)


def collapse(density) -> AbstractMarginal | None:
    """The marginal (module docstring) of a :class:`~gyroid.bench._density.
    BenchDensity` whose model is linear: filtered under correlated noise
    (:func:`filtered_form`), on the rows' sufficient statistics under white noise (the
    density's own where it holds them: O(p^2) an evaluation, whatever the log's length;
    else from its rows, held-out ones weighing 0). None for a model with positive
    parameters (under correlated noise :func:`filtered_form` at given ones; under white
    noise the whole posterior is weighed, :class:`SufficientCoefficients`)."""
    if not density.model.is_linear or any(q.positive for q in density.model.parameters):
        return None
    filtered = filtered_form(density)
    if filtered is not None:
        return filtered
    p = density.n_model
    beta_loc, precision, log_norm = _coefficient_priors(density, np.arange(p))
    loc_k, scale_k, on_k = _on_device(*(a[p:] for a in _prior_arrays(density)))
    stats = density.stats
    if stats is not None:  # the statistics hold all a whole log's marginal reads
        factor, n, log_sigma_sum = stats.factor, jnp.asarray(float(density.n)), stats.log_sigma_sum
    else:
        kept = (jnp.ones_like(density.drift) if density.weight is None
                else jnp.asarray(density.weight))
        log_sd = 0.0 if density.sigma is None else jnp.log(density.sigma)
        columns = jnp.column_stack([density.drift, density.model.design(density.inputs)])
        factor = SufficientCoefficients.factor_of(columns, jnp.sqrt(kept) * jnp.exp(-log_sd))
        n, log_sigma_sum = jnp.sum(kept), jnp.sum(kept * log_sd)
    return SufficientCoefficients(
        factor=factor, n=n, log_sigma_sum=log_sigma_sum,
        beta_loc=beta_loc, beta_precision=precision, beta_log_norm=log_norm,
        noise_loc=loc_k, noise_scale=scale_k, noise_on=on_k, row_scale=density.row_scale)


def _prior_arrays(density):
    """The density's priors (host arrays: a form is set up in NumPy, not op by op in JAX,
    each of whose operations is a program of its own to compile or load)."""
    return tuple(np.asarray(a, dtype=float) for a in (
        density.prior_loc, density.prior_scale, density.prior_on))


def _on_device(*arrays: np.ndarray) -> tuple[Array, ...]:
    """Host arrays as JAX arrays (a transfer: ``jnp.asarray`` of a 0-d array compiles a
    program)."""
    return tuple(jax.device_put(a) for a in arrays)


def _coefficient_priors(density, real: np.ndarray):
    """The real coefficients' priors: their locations, precisions (0 for a flat prior) and
    the normal priors' log normalising constant."""
    loc, scale, on = _prior_arrays(density)
    normal = on[real] > 0
    safe = np.where(normal, scale[real], 1.0)
    precision = np.where(normal, 1.0 / safe**2, 0.0)
    log_norm = -np.sum(np.where(normal, np.log(safe) + 0.5 * _LOG_2PI, 0.0))
    return _on_device(loc[real], precision, np.asarray(log_norm))


def filtered_form(density, columns: Float[Array, "n 1+r"] | None = None,
                  real: np.ndarray | None = None) -> CollapsedCoefficients | None:
    """The filtered marginal of a :class:`~gyroid.bench._density.BenchDensity`: a
    linear model (every coefficient real) under a correlated noise model; None
    otherwise (under white noise the marginal is :func:`collapse`'s, on sufficient
    statistics). With ``columns`` and ``real``, :func:`collapsed_form`'s at given positive
    parameters."""
    if not density.noise.correlated:
        return None
    if columns is None and (not density.model.is_linear
                            or any(q.positive for q in density.model.parameters)):
        return None
    return collapsed_form(density, columns, real)


def collapsed_form(density, columns: Float[Array, "n 1+r"] | None = None,
                   real: np.ndarray | None = None) -> CollapsedCoefficients:
    """The marginal of a :class:`~gyroid.bench._density.BenchDensity` under its
    noise model, filtered (white rows their own innovations). With ``columns`` (the drift
    less the model at zero real coefficients, then the model's derivatives in them) and
    ``real`` (their indices among the model's parameters), the form for given positive
    parameters of any model linear in its real ones (built on the host, its columns then
    replaced inside compiled code: :meth:`CollapsedCoefficients.with_columns`,
    :mod:`gyroid.bench._point_profiled`); without them, a linear model's own."""
    if columns is None:
        columns = jnp.column_stack([density.drift, density.model.design(density.inputs)])
        real = np.arange(density.n_model)
    p = density.n_model
    beta_loc, precision, log_norm = _coefficient_priors(density, np.asarray(real))
    loc_k, scale_k, on_k = _on_device(*(a[p:] for a in _prior_arrays(density)))
    return CollapsedCoefficients(
        columns=columns,
        row_filter=density.row_filter,
        beta_loc=beta_loc, beta_precision=precision,
        beta_log_norm=log_norm, noise_loc=loc_k, noise_scale=scale_k, noise_on=on_k)
