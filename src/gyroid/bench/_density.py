"""The JAX part of a bench log's posterior (:class:`BenchDensity`): drift model, noise model
and priors as one pytree of arrays; :class:`~gyroid.bench.BenchProblem` describes it.

Sampling coordinates ``u``: model parameters in their own units, except positive ones
(time constants) as ``log x``; noise levels as logs. The noise model is an object
(:class:`gyroid.noise.NoiseModel`: white, white + Gauss-Markov, IEEE 952's white + flicker
+ rate random walk, or one of the user's own) that gives the likelihood of the residual:
independent rows, or the innovations of its filter. A model reading dT/dt on a log with a
noisy thermometer carries that noise through the dT/dt estimator as one more term of the
noise model (errors in variables, :mod:`gyroid.noise._rate_error_rows`).

For a model linear in its parameters with white noise, the log-likelihood is computed
from sufficient statistics (cost independent of the log's length).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from gyroid._exported import exported
from gyroid.bench._white_rows import SufficientStatistics
from gyroid.inference._problem import AbstractDensity
from gyroid.io._logs import BenchLog
from gyroid.models._derived import RATE_WINDOW_S
from gyroid.models._drift import DriftModel
from gyroid.models._inputs import DriftInputs
from gyroid.models._priors import Flat, LogNormal, Normal, Prior, prior_arrays
from gyroid.noise._model import NoiseModel, noise_model
from gyroid.noise._rate_error_rows import CarriedThermometer
from gyroid.noise._row_filter import RowFilter

#: Length of the blocks whose summed log-likelihood ArviZ's LOO treats as one observation, s.
LOO_BLOCK_S = 60.0
#: At most this many LOO blocks (longer blocks on long logs).
MAX_LOO_BLOCKS = 500
_LOG_2PI = math.log(2.0 * math.pi)


class BenchDensity(AbstractDensity):
    """Everything the posterior of one bench log computes with; built by
    :meth:`from_log` (what :class:`~gyroid.bench.BenchProblem` does)."""

    model: DriftModel
    inputs: DriftInputs
    drift: Float[Array, " n"]
    sigma: Float[Array, " n"] | None  # known per-row white-noise sd, deg/h
    steps_s: Float[Array, " n"]  # time since the previous sample (first: the median step)
    block: Int[Array, " n"]  # LOO block of each row
    # Priors as normal densities on the sampling coordinates (arrays, so that logs of one
    # shape share one compilation whatever their log-scaled priors): ``prior_on`` is 0 for
    # a flat prior.
    prior_loc: Float[Array, " d"]
    prior_scale: Float[Array, " d"]
    prior_on: Float[Array, " d"]
    noise: NoiseModel  # set up for this log (:meth:`NoiseModel.for_log`)
    n_blocks: int = eqx.field(static=True)
    step_s: float = eqx.field(static=True)
    #: An array, not a static field: logs whose chosen windows differ share a compilation.
    rate_window_s: Float[Array, ""] | float = RATE_WINDOW_S
    #: A linear model's white-noise likelihood on its sufficient statistics (None: other
    #: models and noise, held-out rows, or ``fast=False``).
    stats: SufficientStatistics | None = None
    #: Rows the likelihood reads (1) or leaves out (0): held-out stretches of a predictive
    #: check, kept in place so that every fold shares one compilation. None: every row.
    weight: Float[Array, " n"] | None = None
    #: Rows read as means over one step (:meth:`NoiseModel.rows_as_means`): the gap before
    #: each row, s (its span is ``step_s``).
    gap_s: Float[Array, " n"] | None = None
    #: A row's white sd per sample's (1/sqrt(m) for a row that is the mean of m samples):
    #: ``sigma_deg_h`` is always a sample's.
    row_scale: float = eqx.field(static=True, default=1.0)

    @classmethod
    def from_log(
        cls,
        log: BenchLog,
        model: DriftModel,
        priors: tuple[Prior, ...],
        inputs: DriftInputs,
        *,
        noise: str | NoiseModel | None = None,
        rate_window_s: float = RATE_WINDOW_S,
        fast: bool = True,
        rows_per_mean: int = 1,
        thermometer: CarriedThermometer | None = None,
    ) -> BenchDensity:
        """The density of ``model`` on ``log`` (whose model inputs are ``inputs``) with
        ``priors`` (model parameters, then the noise model's, in sampling order).
        ``rows_per_mean``: samples behind each row (a log of block means);
        ``thermometer``: the thermometer's noise through dT/dt at the rows, times wD,
        carried by the noise model (:meth:`~gyroid.noise.NoiseModel.with_rate_error`;
        errors in variables)."""
        noise = noise_model(noise)
        time_s = np.asarray(log.time_s)
        steps = np.diff(time_s)
        step = float(np.median(steps)) if steps.size else 1.0
        sigma = None if log.sigma_deg_h is None else jnp.asarray(log.sigma_deg_h)
        noise_names = noise.names(sigma is not None)
        positive = [p.positive for p in model.parameters] + [True] * len(noise_names)
        loc, scale, on = prior_arrays(priors, positive)
        duration = float(time_s[-1] - time_s[0])
        block_s = max(LOO_BLOCK_S, step, duration / MAX_LOO_BLOCKS * 1.0001)
        block = np.floor((time_s - time_s[0]) / block_s).astype(int)
        _, block = np.unique(block, return_inverse=True)
        noise = noise.for_log(step, duration)
        row_scale = 1.0 / math.sqrt(rows_per_mean)
        # read as block means: each row the mean over one step, after a gap (a pause)
        gap = np.maximum(np.concatenate([[0.0], steps]) - step, 0.0)
        if thermometer is not None:
            d0 = (np.full(time_s.size, row_scale**2) if sigma is None
                  else np.asarray(sigma) ** 2)
            noise = noise.with_rate_error(thermometer, d0=d0, span_s=np.full(gap.size, step),
                                          gap_s=gap, step_s=step)
        gap_s = jnp.asarray(gap) if noise.rows_as_means(rows_per_mean) else None
        problem = cls(
            model=model,
            inputs=inputs,
            drift=jnp.asarray(log.drift_deg_h),
            sigma=sigma,
            steps_s=jnp.asarray(np.concatenate([[step], steps])),
            block=jnp.asarray(block),
            prior_loc=jnp.asarray(loc),
            prior_scale=jnp.asarray(scale),
            prior_on=jnp.asarray(on),
            noise=noise,
            n_blocks=int(block.max()) + 1,
            step_s=step,
            rate_window_s=jnp.asarray(float(rate_window_s)),
            row_scale=row_scale,
            gap_s=gap_s,
        )
        if fast and model.is_linear and not noise.correlated:
            return eqx.tree_at(lambda q: q.stats, problem, problem._sufficient_statistics(),
                               is_leaf=lambda x: x is None)
        return problem

    def _sufficient_statistics(self) -> SufficientStatistics:
        """:class:`SufficientStatistics` of these rows (a linear model, white noise)."""
        y = np.asarray(self.drift)
        w = None if self.sigma is None else 1.0 / np.asarray(self.sigma)

        def weighted_blocks():
            for rows, x in self.model.design_blocks(self.inputs):
                if w is None:
                    yield rows, x, y[rows]
                else:
                    yield rows, x * w[rows, None], y[rows] * w[rows]

        log_sigma = (np.zeros_like(y) if self.sigma is None
                     else np.log(np.asarray(self.sigma)))
        return SufficientStatistics.of(weighted_blocks, self.n_model, np.asarray(self.block),
                                       self.n_blocks, log_sigma)

    def without_rows(self, held_out: np.ndarray) -> BenchDensity:
        """The same density with the rows ``held_out`` (a boolean mask) left out of the
        likelihood: a white row's term is dropped; under white+gm the Kalman filter runs on
        through them without an observation (exact: the marginal likelihood of the rows
        kept). The sufficient statistics, which sum every row, are dropped too."""
        keep = ~np.asarray(held_out, dtype=bool)
        # the rows' exact covariance, if the noise model carries one, is the kept rows'
        return eqx.tree_at(lambda q: (q.weight, q.stats, q.noise), self,
                           (jnp.asarray(keep, dtype=float), None, self.noise.on_rows(keep)),
                           is_leaf=lambda x: x is None)

    # ----- parameter bookkeeping -------------------------------------------------------
    @property
    def n(self) -> int:
        return int(self.drift.shape[0])

    @property
    def n_observed(self) -> int:
        """Rows the likelihood reads."""
        return self.n if self.weight is None else int(np.sum(np.asarray(self.weight)))

    @property
    def noise_names(self) -> tuple[str, ...]:
        return self.noise.names(self.sigma is not None)

    @property
    def row_filter(self) -> RowFilter:
        """The noise model on these rows (what the likelihood and its collapsed form
        filter with). Every row's weight is an array, ones where none is held out, so a
        fit's forms with and without held-out rows (the predictive check's folds) share
        their compiled programs."""
        weight = (jnp.ones_like(self.steps_s) if self.weight is None
                  else jnp.asarray(self.weight))
        return RowFilter(self.noise, self.steps_s, weight, sigma=self.sigma, gap_s=self.gap_s,
                         step_s=jnp.asarray(float(self.step_s)),
                         row_scale=jnp.asarray(float(self.row_scale)))

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names in natural units, in sampling order."""
        return self.model.parameter_names + self.noise_names

    @property
    def positive(self) -> tuple[bool, ...]:
        return tuple(p.positive for p in self.model.parameters) + (True,) * len(self.noise_names)

    @property
    def priors(self) -> tuple[Prior, ...]:
        """The priors in sampling order, as :mod:`gyroid.models._priors` objects."""
        out: list[Prior] = []
        for loc, scale, on, positive in zip(np.asarray(self.prior_loc),
                                            np.asarray(self.prior_scale),
                                            np.asarray(self.prior_on), self.positive,
                                            strict=True):
            if not on:
                out.append(Flat())
            elif positive:
                out.append(LogNormal(float(np.exp(loc)), float(scale)))
            else:
                out.append(Normal(float(loc), float(scale)))
        return tuple(out)

    @property
    def n_model(self) -> int:
        return len(self.model.parameter_names)

    def to_natural(self, u: Float[Array, "... d"]) -> Float[Array, "... d"]:
        """Sampling coordinates to natural units (exp of the log-coordinates)."""
        mask = jnp.asarray(self.positive)
        return jnp.where(mask, jnp.exp(u), u)

    def to_sampling(self, x: Float[Array, "... d"]) -> Float[Array, "... d"]:
        mask = jnp.asarray(self.positive)
        return jnp.where(mask, jnp.log(jnp.where(mask, x, 1.0)), x)

    # ----- densities ---------------------------------------------------------------------
    def predict(self, u: Float[Array, " d"]) -> Float[Array, " n"]:
        """Modelled drift, deg/h."""
        theta = self.to_natural(u)[: self.n_model]
        return self.model.predict(theta, self.inputs)

    def _noise_levels(self, u: Float[Array, " d"]):
        return self.levels_of(u[self.n_model :])

    def levels_of(self, noise_u: Float[Array, " k"]):
        """:meth:`~gyroid.noise.RowFilter.levels_of` on these rows."""
        return self.row_filter.levels_of(noise_u)

    def log_likelihood_rows(self, u: Float[Array, " d"]) -> Float[Array, " n"]:
        """Log-likelihood of each row (a filter's: of its innovation; under the rows' exact
        covariance, given every other row); 0 for a row left out (:meth:`without_rows`)."""
        return self.row_filter.row_log_likelihood(self.drift - self.predict(u),
                                                  *self._noise_levels(u))

    def standardised_residuals(self, u: Float[Array, " d"]) -> Float[Array, " n"]:
        """Residuals over their modelled sd (white) or the noise model's innovations over
        theirs, in time order: independent N(0, 1) when the model and its noise model are
        right."""
        return self.row_filter.standardised(self.drift - self.predict(u),
                                            *self._noise_levels(u))

    def log_likelihood(self, u: Float[Array, " d"]) -> Float[Array, ""]:
        """Total log-likelihood (the sufficient-statistics path where it applies)."""
        if self.stats is not None:
            return self.stats.log_likelihood(u[: self.n_model], self._row_sd(u), self.n)
        return self.row_filter.log_likelihood(self.drift - self.predict(u),
                                              *self._noise_levels(u))

    def sufficient_statistics(self) -> SufficientStatistics:
        """:attr:`stats`, which a linear model under white noise has on every row (a pooled
        run's): ValueError where it has none."""
        if self.stats is None:
            raise ValueError("this density has no sufficient statistics (a linear model "
                             "under white noise, every row read)")
        return self.stats

    def _row_sd(self, u: Float[Array, " d"]) -> Float[Array, ""] | None:
        """A row's white sd at ``u`` (deg/h); None where the log gives each row's."""
        return None if self.sigma is not None else jnp.exp(u[self.n_model]) * self.row_scale

    def log_likelihood_blocks(self, u: Float[Array, " d"]) -> Float[Array, " b"]:
        """Log-likelihood summed over blocks of ``LOO_BLOCK_S`` (what LOO leaves out); from
        the blocks' sufficient statistics where the likelihood is linear-Gaussian."""
        if self.stats is None:
            return jax.ops.segment_sum(self.log_likelihood_rows(u), self.block, self.n_blocks)
        return self.stats.log_likelihood_blocks(u[: self.n_model], self._row_sd(u))

    def prior_residuals(self, u: Float[Array, " d"]) -> Float[Array, " d"]:
        """Standardised prior residuals: ``-0.5 * sum(r**2)`` is the log prior + const."""
        return self.prior_on * (u - self.prior_loc) / self.prior_scale

    def log_prior(self, u: Float[Array, " d"]) -> Float[Array, ""]:
        r = self.prior_residuals(u)
        return jnp.sum(-0.5 * r**2 - self.prior_on * (jnp.log(self.prior_scale)
                                                       + 0.5 * _LOG_2PI))

    def log_posterior(self, u: Float[Array, " d"]) -> Float[Array, ""]:
        value = self.log_likelihood(u) + self.log_prior(u)
        return jnp.where(jnp.isfinite(value), value, -jnp.inf)


@exported
def predicted(density: BenchDensity, u: Float[Array, " d"]) -> Float[Array, " n"]:
    """:meth:`BenchDensity.predict` as one compiled program: called on the host, the
    model's operations are each a program of their own, compiled or loaded one by one."""
    return density.predict(u)
