"""The one abstraction every fit is an instance of.

A problem is a posterior over *sampling coordinates* ``u`` (a positive parameter, such as a
time constant or a noise level, as its log) with a description: parameter names and
priors. It keeps its JAX part apart, as ``density`` (an equinox module of arrays whose
methods are jit-compiled and vmapped over draws: ``log_posterior``,
``log_likelihood_blocks``, ...), so that problems differing only in their description
share one compilation.

Final subclasses: :class:`~gyroid.bench.BenchProblem` (a bench log's drift model),
:class:`~gyroid.roll.RollProblem` (paper B's loop on a roll log) and
:class:`~gyroid.pool.PoolProblem` (a lot of runs, partially pooled).
:func:`~gyroid.inference.fit` fits any of them: the mode (:meth:`AbstractProblem.mode`), a
posterior (any :class:`~gyroid.inference.AbstractSampler`), then the result with its
self-checks, built once and frozen by the problem's own :meth:`AbstractProblem.result`
(each kind's package, which generic inference never imports, holds its result module; that
module names its problem for the type checker only).

Where a new model goes: its own package with a final subclass (its density, ``mode`` and
``result``) and a result module; a new self-check: :mod:`gyroid.inference._checks`, read
from the :class:`FitEvidence` every problem builds.
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Generic, TypeVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.inference._posterior import Posterior
from gyroid.models._priors import Prior, natural_from_sampling

if TYPE_CHECKING:
    from gyroid.inference._result import FitResult

#: The result a kind of problem builds (:meth:`AbstractProblem.result`), for the type checker:
#: :func:`~gyroid.inference.fit` of a ``BenchProblem`` is a ``BenchFit``.
R = TypeVar("R", bound="FitResult", covariant=True)


@dataclass(frozen=True, eq=False)
class PointEstimate:
    """Posterior mode in natural units, with standard deviations and the solver's verdict."""

    names: tuple[str, ...]
    u: np.ndarray = field(repr=False)  # sampling coordinates
    covariance_u: np.ndarray = field(repr=False)  # in sampling coordinates
    value: dict[str, float]
    sd: dict[str, float]
    converged: bool
    message: str
    n_starts: int = 1
    rms_residual: float = float("nan")  # in the data's unit (deg/h for a bench log)

    def summary(self) -> str:
        rows = [f"  {n:>16s} = {self.value[n]: .6g} +/- {self.sd[n]:.3g}" for n in self.names]
        status = "converged" if self.converged else f"NOT converged: {self.message}"
        return "\n".join([f"point estimate ({status}, {self.n_starts} start(s))", *rows])


class AbstractDensity(eqx.Module):
    """A problem's JAX part: arrays, and methods jit-compiled and vmapped over draws (a
    sampler reads :meth:`log_posterior`). Subclasses are final."""

    @abc.abstractmethod
    def log_posterior(self, u: Float[Array, " d"]) -> Float[Array, ""]:
        """The log-posterior at sampling coordinates ``u``; -inf where it is not finite."""


class AbstractProblem(eqx.Module, Generic[R]):
    """A posterior to fit (see the module docstring). Subclasses are final."""

    density: eqx.AbstractVar[AbstractDensity]

    def __repr__(self) -> str:
        return f"{type(self).__name__}(parameters={', '.join(self.names)})"

    # ----- description ----------------------------------------------------------------------
    @property
    @abc.abstractmethod
    def names(self) -> tuple[str, ...]:
        """Every sampled parameter, in sampling order."""

    @property
    @abc.abstractmethod
    def positive(self) -> tuple[bool, ...]:
        """Per sampled parameter: sampled as its log."""

    @property
    @abc.abstractmethod
    def priors(self) -> tuple[Prior, ...]:
        """The sampled parameters' priors, in order."""

    # ----- coordinates ----------------------------------------------------------------------
    def to_natural(self, u):
        """Sampling coordinates to natural units (JAX)."""
        return jnp.where(jnp.asarray(self.positive), jnp.exp(u), u)

    def to_sampling(self, x):
        """Natural units to sampling coordinates (JAX)."""
        mask = jnp.asarray(self.positive)
        return jnp.where(mask, jnp.log(jnp.where(mask, x, 1.0)), x)

    def to_natural_host(self, u: np.ndarray) -> np.ndarray:
        """:meth:`to_natural` in NumPy, for draws on the host."""
        return natural_from_sampling(u, self.positive)

    def to_sampling_host(self, x: np.ndarray) -> np.ndarray:
        """:meth:`to_sampling` in NumPy."""
        positive = np.asarray(self.positive, dtype=bool)
        u = np.array(x, dtype=float)
        u[..., positive] = np.log(u[..., positive])
        return u

    # ----- fitting --------------------------------------------------------------------------
    @abc.abstractmethod
    def mode(self) -> PointEstimate:
        """The posterior mode and its Gaussian covariance (the sampler starts there)."""

    @abc.abstractmethod
    def default_sampler(self) -> AbstractSampler:
        """The sampler :func:`~gyroid.inference.fit` uses unless given one (importance
        sampling, emcee where its weights fail, for bench, roll and static-noise logs;
        NUTS for a pooled lot)."""

    @abc.abstractmethod
    def result(self, point: PointEstimate, posterior: Posterior | None, *,
               seed: int) -> R:
        """The fit's frozen result, of this problem's kind, its self-checks computed first
        (``seed``: the sampler's, for any draws the checks make)."""

    def collapsed(self):
        """The problem with its linear coefficients integrated out, where that is exact and
        cheaper to sample (:mod:`gyroid.inference._collapsed`); None otherwise."""
        return None

    def marginal_target(self):
        """What importance sampling integrates numerically where the problem's coefficients
        integrate out exactly (:mod:`gyroid.inference._marginal_target`); None otherwise."""
        return None

    def host_log_posterior(self) -> Callable[[np.ndarray], np.ndarray] | None:
        """A NumPy log-posterior of many points at once, ``u (w, d) -> (w,)``, where one
        is cheaper than a call into JAX (emcee then calls it every step); None otherwise."""
        return None

    # ----- storage (ArviZ) ------------------------------------------------------------------
    @abc.abstractmethod
    def observed_data(self) -> dict[str, np.ndarray]:
        """What the fit observed, for InferenceData."""

    def constant_data(self) -> dict[str, np.ndarray]:
        return {}

    @abc.abstractmethod
    def idata_attrs(self) -> dict[str, str]:
        """Attributes stored with the posterior."""


class AbstractSampler(abc.ABC):
    """A way to sample a problem's posterior, started from its mode: :class:`~gyroid.
    inference.Emcee` or :class:`~gyroid.inference.Nuts`."""

    @abc.abstractmethod
    def sample(self, problem: AbstractProblem, point: PointEstimate, *, seed: int = 0,
               progress: Callable[[str], None] | None = None) -> Posterior:
        """Posterior draws of ``problem`` (natural units), from ``point``."""
