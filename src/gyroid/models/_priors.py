"""Priors of model parameters, in physical units.

Every parameter is sampled in an unconstrained coordinate ``u``: ``u = x`` for a real
parameter, ``u = log(x)`` for a positive one (a time constant). Priors are densities on
``u``: :class:`Normal` on a real parameter, :class:`LogNormal` (a normal on ``log x``) on a
positive one, :class:`Flat` (improper, for exact linear-Gaussian checks) on either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.errors import GyroidInputError


@dataclass(frozen=True)
class Normal:
    """Normal prior ``N(loc, scale**2)`` on a real parameter, in its own unit."""

    loc: float
    scale: float

    def log_density(self, u: Float[Array, "*shape"]) -> Float[Array, "*shape"]:
        z = (u - self.loc) / self.scale
        return -0.5 * z**2 - math.log(self.scale) - 0.5 * math.log(2.0 * math.pi)

    def describe(self) -> str:
        return f"Normal({self.loc:g}, {self.scale:g})"


@dataclass(frozen=True)
class LogNormal:
    """Log-normal prior on a positive parameter: ``log x ~ N(log median, log_sd**2)``."""

    median: float
    log_sd: float

    def log_density(self, u: Float[Array, "*shape"]) -> Float[Array, "*shape"]:
        z = (u - math.log(self.median)) / self.log_sd
        return -0.5 * z**2 - math.log(self.log_sd) - 0.5 * math.log(2.0 * math.pi)

    def describe(self) -> str:
        return f"LogNormal(median {self.median:g}, log-sd {self.log_sd:g})"


@dataclass(frozen=True)
class Flat:
    """Improper flat prior on the sampling coordinate (for exact checks only)."""

    def log_density(self, u: Float[Array, "*shape"]) -> Float[Array, "*shape"]:
        return jnp.zeros_like(u)

    def describe(self) -> str:
        return "Flat"


@dataclass(frozen=True)
class HalfNormal:
    """Half-normal prior of scale ``scale`` on a positive parameter (a between-run sd),
    sampled as ``u = log x``: unlike a log-normal it leaves room for a value near zero
    (runs that do not differ), which a question about spread must allow."""

    scale: float

    def log_density(self, u: Float[Array, "*shape"]) -> Float[Array, "*shape"]:
        x = jnp.exp(u)
        return (u - 0.5 * (x / self.scale) ** 2 + math.log(2.0) - math.log(self.scale)
                - 0.5 * math.log(2.0 * math.pi))

    @property
    def sd(self) -> float:
        """The prior's sd in natural units."""
        return self.scale * math.sqrt(1.0 - 2.0 / math.pi)

    def describe(self) -> str:
        return f"HalfNormal({self.scale:g})"


Prior = Normal | LogNormal | Flat


def natural_from_sampling(u, positive) -> np.ndarray:
    """Sampling coordinates to natural units on the host (NumPy): ``exp`` of the positive
    parameters' log-coordinates (``positive``: one flag per last-axis entry), the others
    as they are. Only the positive entries are exponentiated (no overflow warnings)."""
    positive = np.asarray(positive, dtype=bool)
    natural = np.array(u, dtype=float)
    natural[..., positive] = np.exp(natural[..., positive])
    return natural


def natural_with_sd(u, covariance, positive) -> tuple[np.ndarray, np.ndarray]:
    """A point in sampling coordinates and its covariance to natural values and standard
    deviations: a positive parameter's sd is ``x * sd(log x)`` (the delta method)."""
    x = natural_from_sampling(u, positive)
    sd_u = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    return x, np.where(positive, x * sd_u, sd_u)


def prior_arrays(priors, positive) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Priors to (loc, scale, on) of normal densities on the sampling coordinates (``on``
    0 for a flat prior); a prior that does not suit its parameter is refused."""
    rows: list[tuple[float, float, float]] = []  # (loc, scale, on) per parameter
    for prior, pos in zip(priors, positive, strict=True):
        if isinstance(prior, Flat):
            rows.append((0.0, 1.0, 0.0))
        elif isinstance(prior, LogNormal):
            if not pos:
                raise GyroidInputError(f"a log-normal prior ({prior.describe()}) needs a "
                                       "positive parameter; use normal(MU,SD)")
            rows.append((math.log(prior.median), prior.log_sd, 1.0))
        else:
            if pos:
                raise GyroidInputError(f"a normal prior ({prior.describe()}) on a positive "
                                       "parameter: use lognormal(MEDIAN,LOG_SD)")
            rows.append((prior.loc, prior.scale, 1.0))
    loc, scale, on = np.asarray(rows, dtype=float).reshape(-1, 3).T
    return loc, scale, on
