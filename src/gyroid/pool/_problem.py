"""The posterior of a lot of runs (or units) of one gyro type: partial pooling.

Run ``r`` has coefficients ``theta_r`` (the drift model's, e.g. w0, wx, wy, wz) drawn from
the population ``N(mu, diag(tau**2))``: ``mu`` is the gyro type's coefficient, ``tau`` the
between-run sd a datasheet calls repeatability.

Each run is one Gaussian observation of its coefficients: its estimate ``theta_hat_r`` with
precision ``A_r`` (a run's own fit under its noise model, its posterior mean and the inverse
of its covariance; or a paper's published estimate and its assumed sd), so ``theta_r``
integrates out exactly:

    log p(theta_hat_r | mu, tau) = -p/2 log 2 pi + 1/2 log|A_r| - sum log tau
        - 1/2 log|P_r| - 1/2 c_r' P_r^-1 (d_r / tau**2)

with ``d_r = theta_hat_r - mu``, ``c_r = A_r d_r`` and ``P_r = A_r + diag(tau**-2)``: the
Gaussian ``N(theta_hat_r; mu, A_r^-1 + T)`` written without a difference of large numbers
and without inverting ``A_r``. Given ``tau`` this is Gaussian in ``mu`` too, so ``mu``
integrates out against its normal (or flat) prior as well. The sampler sees ``log tau``
only: neither the funnel between ``tau`` and the ``theta_r`` (what a non-centred
parameterisation is otherwise needed for) nor the one between ``tau`` and ``mu`` (which kept
emcee at r_hat 1.04 after 30 000 steps on three runs when ``mu`` was sampled). Per
posterior draw, ``mu`` is then drawn from its exact conditional, each run's coefficients
from theirs, ``N(mu + P_r^-1 c_r, P_r^-1)``, and a new run's from ``N(mu, T)``: exact joint
posterior draws, whose uncertainty includes the population's.

Priors: ``mu`` the single-run fit's (default: scaled to the logs); ``tau`` half-normal with
the scale of ``mu``'s prior (room for runs that do not differ at all).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.inference._mode import JointBFGS, safe_inverse
from gyroid.inference._nuts import Nuts
from gyroid.inference._posterior import Posterior
from gyroid.inference._problem import AbstractDensity, AbstractProblem, PointEstimate
from gyroid.models._inputs import T0_C
from gyroid.models._priors import Flat as FlatPrior
from gyroid.models._priors import HalfNormal, Normal, prior_arrays
from gyroid.pool._result import PoolFit, pool_result

_LOG_2PI = math.log(2.0 * math.pi)
#: Prefix of a between-run sd's name (``between_sd_w0``).
SPREAD_PREFIX = "between_sd_"


#: BFGS on the pool's hyper-parameters (the logs of the between-run sds).
_FINDER = JointBFGS(rtol=1e-9, atol=1e-9, max_steps=5000)


class PoolDensity(AbstractDensity):
    """The arrays of a pooled posterior (what is jit-compiled): see the module docstring.

    Sampled coordinates ``u = log tau``; ``mu`` is integrated out and drawn afterwards
    (:meth:`mean_conditional`)."""

    gram: Float[Array, "r p p"]  # A_r: the precision of each run's estimate
    offset: Float[Array, "r p"]  # each run's estimate minus ``centre``
    centre: Float[Array, " p"]  # a reference point (the runs' mean) that keeps sums small
    log_norm: Float[Array, " r"]  # 1/2 log|A_r| - p/2 log 2 pi (0 for a run taken out)
    mean_loc: Float[Array, " p"]
    mean_scale: Float[Array, " p"]
    mean_on: Float[Array, " p"]  # 0 for a flat prior on mu
    spread_scale: Float[Array, " p"]  # half-normal scale of tau

    @property
    def n_coefficients(self) -> int:
        return int(self.offset.shape[1])

    def _run_terms(self, u):
        """Per run: the Cholesky factor of P_r = A_r + T^-1, and T^-1."""
        precision_prior = jnp.exp(-2.0 * u)
        factor = jnp.linalg.cholesky(self.gram + jnp.diag(precision_prior))
        return factor, precision_prior

    def _mean_free_terms(self, u, factor):
        """Per run, the parts of its log-likelihood that do not involve mu."""
        log_det = 2.0 * jnp.sum(jnp.log(jnp.diagonal(factor, axis1=1, axis2=2)), axis=1)
        return self.log_norm - jnp.sum(u) - 0.5 * log_det

    def _mean_information(self, u):
        """The Gaussian in ``nu = mu - centre`` that the runs and mu's prior give:
        precision Q, linear term b and constant c (``-1/2 (nu'Q nu - 2 b'nu + c)``), and
        the mu-free part of the log-likelihood."""
        factor, precision_prior = self._run_terms(u)
        a = self.gram
        # M_r = (A_r^-1 + T)^-1 = A_r P_r^-1 T^-1, without inverting A_r.
        cho = jax.vmap(lambda f, b: jax.scipy.linalg.cho_solve((f, True), b))
        m = a @ cho(factor, jnp.broadcast_to(jnp.diag(precision_prior), a.shape))
        m = 0.5 * (m + jnp.swapaxes(m, 1, 2))
        md = jnp.einsum("rij,rj->ri", m, self.offset)
        prior_precision = self.mean_on / self.mean_scale**2
        e = self.mean_loc - self.centre
        q = jnp.sum(m, axis=0) + jnp.diag(prior_precision)
        b = jnp.sum(md, axis=0) + prior_precision * e
        c = jnp.sum(md * self.offset) + jnp.sum(prior_precision * e**2)
        base = jnp.sum(self._mean_free_terms(u, factor))
        base += jnp.sum(self.mean_on * (-jnp.log(self.mean_scale) - 0.5 * _LOG_2PI))
        return q, b, c, base

    def log_likelihood_mean_free(self, u: Float[Array, " d"]) -> Float[Array, ""]:
        """log p(all runs | tau) with mu integrated against its prior."""
        q, b, c, base = self._mean_information(u)
        factor = jnp.linalg.cholesky(q)
        w = jax.scipy.linalg.solve_triangular(factor, b, lower=True)
        log_det = 2.0 * jnp.sum(jnp.log(jnp.diagonal(factor)))
        return base + 0.5 * self.n_coefficients * _LOG_2PI - 0.5 * log_det - 0.5 * (c - w @ w)

    def log_prior(self, u: Float[Array, " d"]) -> Float[Array, ""]:
        tau = jnp.exp(u)
        return jnp.sum(u - 0.5 * (tau / self.spread_scale) ** 2 + math.log(2.0)
                       - jnp.log(self.spread_scale) - 0.5 * _LOG_2PI)

    def log_posterior(self, u: Float[Array, " d"]) -> Float[Array, ""]:
        value = self.log_likelihood_mean_free(u) + self.log_prior(u)
        return jnp.where(jnp.isfinite(value), value, -jnp.inf)

    def mean_conditional(self, u: Float[Array, " d"], z: Float[Array, " p"]
                         ) -> Float[Array, " p"]:
        """A draw of mu given ``u`` (``z`` standard normal; 0 gives the conditional mean)."""
        q, b, *_ = self._mean_information(u)
        factor = jnp.linalg.cholesky(q)
        mean = jax.scipy.linalg.cho_solve((factor, True), b)
        return self.centre + mean + jax.scipy.linalg.solve_triangular(factor.T, z, lower=False)

    def run_log_likelihood(self, mu: Float[Array, " p"], u: Float[Array, " d"]
                           ) -> Float[Array, " r"]:
        """Each run's log-likelihood given mu and tau (its coefficients integrated out):
        conditionally independent across runs, what LOO leaves out."""
        factor, _ = self._run_terms(u)
        return self._mean_free_terms(u, factor) - 0.5 * self.run_consistency(mu, u)

    def run_consistency(self, mu: Float[Array, " p"], u: Float[Array, " d"]
                        ) -> Float[Array, " r"]:
        """Each run's ``d_r' (A_r^-1 + T)^-1 d_r`` (``d_r`` its own estimate minus mu):
        chi-square with (rank of A_r) degrees of freedom when the run belongs to the
        population."""
        factor, precision_prior = self._run_terms(u)
        d = self.offset - (mu - self.centre)
        solve = jax.vmap(lambda f, b: jax.scipy.linalg.solve_triangular(f, b, lower=True))
        c = jnp.einsum("rij,rj->ri", self.gram, d)
        return jnp.sum(solve(factor, c) * solve(factor, d * precision_prior), axis=1)

    def run_coefficients(self, mu: Float[Array, " p"], u: Float[Array, " d"],
                         z: Float[Array, "r p"]) -> Float[Array, "r p"]:
        """A draw of every run's coefficients from their conditional given mu and ``u``
        (``z`` standard normal; 0 gives the conditional means)."""
        factor, _ = self._run_terms(u)
        d = self.offset - (mu - self.centre)
        solve = jax.vmap(lambda f, b: jax.scipy.linalg.cho_solve((f, True), b))
        back = jax.vmap(lambda f, b: jax.scipy.linalg.solve_triangular(f.T, b, lower=False))
        return mu + solve(factor, jnp.einsum("rij,rj->ri", self.gram, d)) + back(factor, z)


class PoolProblem(AbstractProblem[PoolFit]):
    """A pooled posterior with its description: parameter names, run labels, priors, and
    (when it pools logs) each run's own fit's problem and checks."""

    density: PoolDensity
    coefficient_names: tuple[str, ...]
    run_labels: tuple[str, ...]
    ranks: tuple[int, ...]  # rank of each run's precision A_r
    #: Each run's own estimates and their sds (R, p: its own fit's posterior means and sds,
    #: or a paper's), and each population mean's identifiability yardstick (p,).
    own_mean: np.ndarray
    own_sd: np.ndarray
    reference: np.ndarray
    #: Pooling logs: each run's single-fit problem (its log, inputs, priors), the drift
    #: model's terms, t0 and whether burst logs were pooled on their segment means. Empty
    #: when a paper's published estimates are pooled.
    runs: tuple = ()
    terms: tuple[str, ...] = ()
    t0_C: float = T0_C
    segment_means: bool = False
    #: Each run's residual and noise checks from its own fit (empty for published
    #: estimates), the noise model the runs were fitted under, and their noise estimates
    #: (``NoiseEstimate``s, one per run), from which a new run's noise is drawn up
    #: (``pool.json``'s ``run_noise_levels``).
    run_reports: tuple = ()
    run_noise: str = ""
    run_noise_levels: tuple = ()

    @classmethod
    def from_estimates(cls, coefficient_names, run_labels, estimates, covariances, *,
                       mean_priors, spread_scales, **context) -> PoolProblem:
        """Build from each run's estimate (R, p) and its covariance (R, p, p), one Gaussian
        observation of its coefficients, and the priors: ``mean_priors`` (Normal or Flat
        per coefficient) and ``spread_scales`` (p,); ``context``: the description fields
        (``own_mean``, ``own_sd``, ``reference``, ``runs``, ...)."""
        estimates = np.asarray(estimates, dtype=float)
        gram = np.linalg.inv(np.asarray(covariances, dtype=float))
        gram = 0.5 * (gram + np.swapaxes(gram, 1, 2))
        loc, scale, on = prior_arrays(mean_priors, [False] * len(mean_priors))
        centre = estimates.mean(axis=0)
        density = PoolDensity(
            gram=jnp.asarray(gram), offset=jnp.asarray(estimates - centre),
            centre=jnp.asarray(centre), log_norm=jnp.asarray(_log_norm(gram)),
            mean_loc=jnp.asarray(loc), mean_scale=jnp.asarray(scale), mean_on=jnp.asarray(on),
            spread_scale=jnp.asarray(np.asarray(spread_scales, dtype=float)))
        ranks = tuple(int(np.linalg.matrix_rank(g)) for g in gram)
        return cls(density=density, coefficient_names=tuple(coefficient_names),
                   run_labels=tuple(run_labels), ranks=ranks, **context)

    def without_run(self, r: int) -> PoolProblem:
        """The same lot and priors with run ``r`` taken out (its precision zeroed: no
        information), so that the arrays keep their shapes and the compiled functions are
        reused."""
        gram, log_norm = np.array(self.density.gram), np.array(self.density.log_norm)
        gram[r], log_norm[r] = 0.0, 0.0  # in NumPy: one run's change is no program to compile
        return eqx.tree_at(lambda q: (q.density.gram, q.density.log_norm), self,
                           (jnp.asarray(gram), jnp.asarray(log_norm)))

    # ----- bookkeeping -------------------------------------------------------------------
    @property
    def n_runs(self) -> int:
        return len(self.run_labels)

    @property
    def n_model(self) -> int:
        return len(self.coefficient_names)

    @property
    def spread_names(self) -> tuple[str, ...]:
        return tuple(SPREAD_PREFIX + n for n in self.coefficient_names)

    @property
    def names(self) -> tuple[str, ...]:
        """The sampled parameters: the between-run sds."""
        return self.spread_names

    @property
    def positive(self) -> tuple[bool, ...]:
        return (True,) * len(self.names)

    @property
    def mean_priors(self) -> tuple:
        d = self.density
        return tuple(Normal(float(lo), float(s)) if on else FlatPrior()
                     for lo, s, on in zip(np.asarray(d.mean_loc), np.asarray(d.mean_scale),
                                          np.asarray(d.mean_on), strict=True))

    @property
    def priors(self) -> tuple:
        """Priors of the sampled parameters, in order."""
        return tuple(HalfNormal(float(s)) for s in np.asarray(self.density.spread_scale))

    # ----- what storage (ArviZ) records -----------------------------------------------------
    def observed_data(self) -> dict[str, np.ndarray]:
        """Each run's estimate of its coefficients (R, p): what the pool reads of it."""
        d = self.density
        return {"run_estimate": np.asarray(d.offset) + np.asarray(d.centre)}

    def idata_attrs(self) -> dict[str, str]:
        return {
            "model": "partially pooled runs: theta_run ~ N(population mean, between_sd**2)",
            "coefficients": ",".join(self.coefficient_names),
            "runs": ",".join(self.run_labels),
            "run_noise": (f"{self.run_noise}: each run fitted on its own, its coefficients' "
                          "posterior mean and covariance pooled" if self.run_noise else
                          "published estimates with their stated sds"),
            "log_likelihood_note": "log_likelihood holds each run's log-likelihood given the "
                                   "population (its coefficients integrated out): LOO leaves "
                                   "out whole runs",
            "draws_note": "the sampler drew the between-run sds; population means and runs' "
                          "coefficients are drawn from their exact conditionals",
        }

    # ----- fitting ---------------------------------------------------------------------------
    def default_sampler(self) -> Nuts:
        """NUTS: emcee's ensemble moves do not mix this posterior (see
        :mod:`gyroid.inference._nuts`)."""
        return Nuts()

    def start(self) -> np.ndarray:
        """A starting point: the logs of the spread of the runs' estimates."""
        d = self.density
        scale = np.asarray(d.spread_scale)
        spread = np.asarray(d.offset).std(axis=0, ddof=1) if self.n_runs > 1 else 0.1 * scale
        return np.log(np.clip(spread, 1e-3 * scale, None))

    def result(self, point: PointEstimate, posterior: Posterior | None, *,
               seed: int) -> PoolFit:
        """The fit's frozen :class:`~gyroid.pool.PoolFit`, its self-checks first."""
        return pool_result(self, point, posterior, seed=seed)

    def mode(self) -> PointEstimate:
        """Posterior mode of the sampled parameters (:class:`~gyroid.inference._mode.
        JointBFGS`) and the inverse Hessian there (each parameter's own inverse curvature
        where that is not positive definite)."""
        found = _FINDER.minimise(self.density, self.start())
        covariance = safe_inverse(found.curvature, diagonal_fallback=True)
        natural = np.exp(found.value)
        sd = natural * np.sqrt(np.diag(covariance))
        return PointEstimate(
            names=self.names, u=found.value, covariance_u=covariance,
            value=dict(zip(self.names, map(float, natural), strict=True)),
            sd=dict(zip(self.names, map(float, sd), strict=True)),
            converged=found.converged, message=found.message, n_starts=1)



def _log_norm(gram: np.ndarray) -> np.ndarray:
    """Each run's ``1/2 log|A_r| - p/2 log 2 pi``: the normalising part of its Gaussian that
    does not depend on the population (0 where ``A_r`` is singular: a constant either way)."""
    sign, log_det = np.linalg.slogdet(gram)
    return np.where(sign > 0, 0.5 * log_det - 0.5 * gram.shape[-1] * _LOG_2PI, 0.0)
