"""A noise model set on a log's rows (:class:`RowFilter`): each row's white sd and the levels
by name from their sampling coordinates, and the rows' log-likelihood (each row's, and
joint) and standardised residuals, whatever the terms: independent rows, a filter's
innovations, or the rows' exact covariance where a carried thermometer's stands beside
white noise alone."""

from __future__ import annotations

import math
from collections.abc import Mapping

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from gyroid.noise._base import RowClock
from gyroid.noise._model import NoiseModel
from gyroid.noise._terms import ExactRateError

_LOG_2PI = math.log(2.0 * math.pi)


class RowFilter(eqx.Module):
    """A noise model set on a log's rows: from its levels' sampling coordinates (logs) to
    each row's white sd and the levels by name, and the innovations of what it filters.
    It holds no drift model, so fits of different models to the same rows (a discrepancy
    search's candidates) share its compiled programs."""

    noise: NoiseModel
    steps_s: Float[Array, " n"]
    #: 1 for a row learnt from, 0 for one predicted through (held out).
    weight: Float[Array, " n"]
    sigma: Float[Array, " n"] | None = None  # the log's own sd of each row, deg/h
    gap_s: Float[Array, " n"] | None = None
    #: The rows' median step (s) and a row's white sd per sample's (1/sqrt(m) for the mean
    #: of m samples): arrays, so that logs of one shape share the compiled programs of
    #: their marginal whatever their step.
    step_s: Float[Array, ""] | float = 1.0
    row_scale: Float[Array, ""] | float = 1.0

    @property
    def names(self) -> tuple[str, ...]:
        """The sampled levels' names."""
        return self.noise.names(self.sigma is not None)

    @property
    def clock(self) -> RowClock:
        return RowClock(self.steps_s, self.step_s, self.gap_s, self.weight)

    def levels_of(self, noise_u: Float[Array, " k"]) -> tuple[Array, dict[str, Array]]:
        """The white sd a row's likelihood uses (deg/h; per row or one) and every level by
        name (natural units), from the levels' sampling coordinates ``noise_u``."""
        values = dict(zip(self.names, jnp.exp(noise_u), strict=True))
        if self.sigma is not None:
            return self.sigma, values
        return self.noise.row_white_sd(values, step_s=self.step_s,
                                       row_scale=self.row_scale), values

    def innovations(self, observed, white, values: Mapping):
        """:meth:`NoiseModel.innovations` on these rows (None for independent rows)."""
        return self.noise.innovations(observed, white, values, self.clock)

    def filtered(self, observed, white, values: Mapping):
        """:meth:`NoiseModel.filtered` on these rows (None for independent rows)."""
        return self.noise.filtered(observed, white, values, self.clock)

    def row_log_likelihood(self, residual, white, values: Mapping) -> Array:
        """Each row's log-likelihood (0 for a row held out): independent rows', else
        :meth:`rows_of` its residual's innovations."""
        filtered = self.innovations(residual, white, values)
        if filtered is None:
            rows = -0.5 * (residual / white) ** 2 - jnp.log(white) - 0.5 * _LOG_2PI
            return rows * self.weight
        return self.rows_of(*filtered)

    def rows_of(self, innovation, variance) -> Array:
        """Each row's log-likelihood from the innovations of its residual and their
        variances (:meth:`innovations`; 0 for a row held out): each innovation's given the
        rows before it, or, under the rows' exact covariance (a carried thermometer's
        beside white noise), each row's given every other row."""
        if isinstance(carried := self.noise.carried, ExactRateError):
            rows = carried.rows.leave_one_out_rows(innovation, variance)
        else:
            rows = -0.5 * innovation**2 / variance - 0.5 * jnp.log(variance) - 0.5 * _LOG_2PI
        return rows * self.weight

    def log_likelihood(self, residual, white, values: Mapping) -> Array:
        """The rows' joint log-likelihood (the rows held out left out)."""
        carried = self.noise.carried
        if not isinstance(carried, ExactRateError):  # independent rows, or innovations
            return jnp.sum(self.row_log_likelihood(residual, white, values))
        innovation, variance = carried.rows.innovations(residual, white)
        rows = innovation**2 / variance + jnp.log(variance) + _LOG_2PI
        return -0.5 * jnp.sum(rows * self.weight)

    def standardised(self, residual, white, values: Mapping) -> Array:
        """The residual over its modelled sd, in time order: independent N(0, 1) where the
        model and the noise model are right (a filter's innovations; under the rows'
        exact covariance, its Cholesky factor's)."""
        if isinstance(carried := self.noise.carried, ExactRateError):
            return carried.rows.standardised(residual, white)
        filtered = self.innovations(residual, white, values)
        return residual / white if filtered is None else filtered[0] / jnp.sqrt(filtered[1])
