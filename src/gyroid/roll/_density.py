"""Paper B's loop on a roll log as JAX densities: :class:`RollDensity` over every roll-side
parameter (:data:`ALL_PARAMETERS`) and a model's view of it (:class:`ModelDensity`). The
model and its likelihood are described in :mod:`gyroid.roll._problem`."""


from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.inference._problem import AbstractDensity
from gyroid.io._roll_log import RollLog
from gyroid.models._priors import prior_arrays
from gyroid.models._roll import encoder_error_deg, sins_scale
from gyroid.noise._kalman import random_walk_innovations

_LOG_2PI = math.log(2.0 * math.pi)

#: The stabiliser angle enters the likelihood at about this many rows (see RollProblem).
MAX_OBSERVED_ROWS = 1000


#: Every roll-side parameter in one fixed order. The likelihood reads a model's parameters
#: into this vector through an index array, so every model of one log (the discrepancy
#: workflow's candidates) shares one compilation.
ALL_PARAMETERS = ("psi0", "D0", "D1", "D0gs", "D1gs", "enc_a", "enc_b", "D2", "sigma_gs_deg",
                  "sigma_sins_deg_s", "sigma_m_deg_s")
#: Values of the parameters a model leaves out: absent effects are 0; ``sigma_m_deg_s`` only
#: enters for an ideal stabiliser (its term is switched off otherwise), 1 keeps it finite.
_ABSENT = np.array([0.0] * 8 + [1.0, 1.0, 1.0])


class RollDensity(eqx.Module):
    """The JAX part of a roll problem on a vector ``v`` over all of ``ALL_PARAMETERS`` (in
    sampling coordinates); the entries outside the model (``active == 0``) are ignored.
    Arrays only, plus the block count and whether ``D2`` is in the model: every model of
    one log (the discrepancy workflow's candidates) has the same shapes and shares one
    compilation of the optimiser. Priors are normal on the sampling coordinate
    (``prior_loc``, ``prior_scale``).

    The likelihood costs O(observed rows), not O(samples): every per-sample sum it needs is
    a fixed sum of the data times a parameter, precomputed once (``cum_sins``,
    ``cum_gs_rate``, and per observed row the count, mean and spread of the MEMS samples).
    Only ``D2`` (a scale factor varying with |w|) needs the per-sample cumulative sum.
    """

    time_s: jax.Array  # elapsed time of every sample, s
    sins: jax.Array
    gs_angle: jax.Array
    gs_rate: jax.Array  # zeros when the log has none (then D1gs is never in the model)
    cum_sins: jax.Array  # int w_x dt, deg
    cum_gs_rate: jax.Array  # int m dt, deg
    block: jax.Array
    observed: jax.Array  # indices of the rows whose stabiliser angle enters the likelihood
    m_count: jax.Array  # MEMS samples owned by each observed row (ideal stabiliser)
    m_mean: jax.Array  # their mean, deg/s
    m_spread: jax.Array  # their sum of squares about that mean, (deg/s)^2
    sample_s: jax.Array
    ideal_gs: jax.Array  # 1.0: m ~ N(D0gs, sigma_m) is also an observation; else 0.0
    active: jax.Array
    positive: jax.Array
    prior_loc: jax.Array
    prior_scale: jax.Array
    #: Observed rows the likelihood learns from (1) or predicts through (0: a held-out
    #: stretch of the predictive check).
    weight: jax.Array
    n_blocks: int = eqx.field(static=True)
    has_d2: bool = eqx.field(static=True)

    def parameters(self, v) -> dict:
        """Every parameter of ``ALL_PARAMETERS`` in natural units (absent ones at rest)."""
        natural = jnp.where(self.positive, jnp.exp(v), v)
        return dict(zip(ALL_PARAMETERS, jnp.where(self.active > 0, natural, _ABSENT),
                        strict=True))

    def _predict_rows(self, v, rows):
        """The stabiliser's angle at ``rows`` (indices, or a slice), deg."""
        p = self.parameters(v)
        t = self.time_s[rows]
        if self.has_d2:
            # The simulator's scale factor, read at the measured rate (|w_x| for |w|).
            scale = sins_scale(p["D1"], p["D2"], self.sins)
            psi = (jnp.cumsum((self.sins - p["D0"]) / scale) * self.sample_s)[rows]
        else:  # int (w_x - D0) / (1 + D1) dt
            psi = (self.cum_sins[rows] - p["D0"] * t) / (1.0 + p["D1"])
        # int (D1gs m + D0gs) / (1 + D1gs) dt; with D1gs = 0 (absent) this is D0gs t.
        platform = (p["D1gs"] * self.cum_gs_rate[rows] + p["D0gs"] * t) / (1.0 + p["D1gs"])
        encoder = encoder_error_deg(psi, p["enc_a"], p["enc_b"])
        return p["psi0"] + psi + platform + encoder

    def predict(self, v):
        """The stabiliser's angle at every sample, deg."""
        return self._predict_rows(v, slice(None))

    def innovations(self, v):
        """Kalman innovations of the stabiliser angle at the observed rows and their
        variances, deg and deg^2."""
        p = self.parameters(v)
        residual = self.gs_angle[self.observed] - self._predict_rows(v, self.observed)
        steps = jnp.diff(self.observed, prepend=-1)  # rows since the previous observation
        return random_walk_innovations(residual, steps, p["sigma_sins_deg_s"] * self.sample_s,
                                       p["sigma_gs_deg"], self.weight)

    def without_rows(self, held_out: np.ndarray) -> RollDensity:
        """The same density with the observed rows ``held_out`` (a boolean mask over
        ``observed``) left out of the likelihood: the filter predicts through them."""
        weight = jnp.asarray(~np.asarray(held_out, dtype=bool), dtype=float)
        return eqx.tree_at(lambda d: d.weight, self, weight)

    def log_likelihood_rows(self, v):
        p = self.parameters(v)
        innovation, total = self.innovations(v)
        rows = -0.5 * (innovation**2 / total + jnp.log(total) + _LOG_2PI)
        # Ideal stabiliser: every MEMS sample observes D0gs, m ~ N(D0gs, sigma_m); the
        # samples' log-densities summed onto the observed row that owns them.
        sigma_m = p["sigma_m_deg_s"]
        squares = self.m_spread + self.m_count * (self.m_mean - p["D0gs"]) ** 2
        m_rows = -0.5 * squares / sigma_m**2 - self.m_count * (0.5 * _LOG_2PI
                                                                + jnp.log(sigma_m))
        return self.weight * (rows + self.ideal_gs * m_rows)

    def log_likelihood_blocks(self, v):
        return jax.ops.segment_sum(self.log_likelihood_rows(v), self.block, self.n_blocks)

    def log_prior(self, v):
        z = (v - self.prior_loc) / self.prior_scale
        return jnp.sum(self.active * (-0.5 * z**2 - jnp.log(self.prior_scale) - 0.5 * _LOG_2PI))

    def log_posterior(self, v):
        value = jnp.sum(self.log_likelihood_rows(v)) + self.log_prior(v)
        return jnp.where(jnp.isfinite(value), value, -jnp.inf)


class ModelDensity(AbstractDensity):
    """A model's densities on its own sampling coordinates ``u``: ``u[i]`` is entry
    ``slot[i]`` of the full vector of ``RollDensity`` (what the sampler sees)."""

    full: RollDensity
    slot: jax.Array

    def spread(self, u):
        """The model's coordinates placed in a vector over ``ALL_PARAMETERS``."""
        return jnp.zeros(len(ALL_PARAMETERS)).at[self.slot].set(u)

    def to_natural(self, u):
        return jnp.where(self.full.positive[self.slot], jnp.exp(u), u)

    def predict(self, u):
        return self.full.predict(self.spread(u))

    def log_likelihood_rows(self, u):
        return self.full.log_likelihood_rows(self.spread(u))

    def standardised_residuals(self, u):
        """Innovations over their sd: independent N(0, 1) when the model is right."""
        innovation, total = self.full.innovations(self.spread(u))
        return innovation / jnp.sqrt(total)

    def log_likelihood_blocks(self, u):
        return self.full.log_likelihood_blocks(self.spread(u))

    def log_prior(self, u):
        return self.full.log_prior(self.spread(u))

    def log_posterior(self, u: Float[Array, " d"]) -> Float[Array, ""]:
        return self.full.log_posterior(self.spread(u))


def _density_of(log: RollLog, names, priors, positive, *, sample_s: float, ideal: bool,
                has_rate: bool) -> RollDensity:
    """The roll log's arrays and the model's priors over all of ``ALL_PARAMETERS``.

    The angle comparison is informative on slow time scales: the likelihood uses every
    stride-th row (exact for this noise model: the random walk's increments over a stride
    add up), with an odd stride so the encoder phase keeps moving."""
    stride = max(1, log.n // MAX_OBSERVED_ROWS)
    stride += 1 - stride % 2
    observed = np.arange(stride - 1, log.n, stride)
    t_obs = log.time_s[observed]
    block = np.floor((t_obs - t_obs[0]) / max(1.0, (t_obs[-1] - t_obs[0]) / 500.0))
    _, block = np.unique(block.astype(int), return_inverse=True)
    slot = [ALL_PARAMETERS.index(n) for n in names]
    loc, scale = np.zeros(len(ALL_PARAMETERS)), np.ones(len(ALL_PARAMETERS))
    loc[slot], scale[slot], _ = prior_arrays(priors, positive)
    active = np.zeros(len(ALL_PARAMETERS))
    active[slot] = 1.0
    positive_all = np.zeros(len(ALL_PARAMETERS), dtype=bool)
    positive_all[slot] = positive
    gs_rate = np.asarray(log.gs_rate_deg_s if has_rate else np.zeros(log.n), dtype=float)
    # Each MEMS sample belongs to the first observed row at or after it (the samples after
    # the last observed row to the last).
    owner = np.minimum(np.searchsorted(observed, np.arange(log.n)), observed.size - 1)
    m_count = np.bincount(owner, minlength=observed.size).astype(float)
    m_mean = np.bincount(owner, gs_rate, observed.size) / np.maximum(m_count, 1.0)
    m_spread = np.bincount(owner, (gs_rate - m_mean[owner]) ** 2, observed.size)
    return RollDensity(
        time_s=jnp.asarray(log.time_s - log.time_s[0] + sample_s),
        sins=jnp.asarray(log.roll_rate_deg_s),
        gs_angle=jnp.asarray(log.gs_angle_deg),
        gs_rate=jnp.asarray(gs_rate),
        cum_sins=jnp.asarray(np.cumsum(log.roll_rate_deg_s) * sample_s),
        cum_gs_rate=jnp.asarray(np.cumsum(gs_rate) * sample_s),
        block=jnp.asarray(block),
        observed=jnp.asarray(observed),
        m_count=jnp.asarray(m_count),
        m_mean=jnp.asarray(m_mean),
        m_spread=jnp.asarray(m_spread),
        sample_s=jnp.asarray(sample_s),
        ideal_gs=jnp.asarray(float(ideal)),
        active=jnp.asarray(active),
        positive=jnp.asarray(positive_all),
        prior_loc=jnp.asarray(loc),
        prior_scale=jnp.asarray(scale),
        weight=jnp.ones(observed.size),
        n_blocks=int(block.max()) + 1,
        has_d2="D2" in names,
    )
