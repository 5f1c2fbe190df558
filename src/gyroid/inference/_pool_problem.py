"""The posterior of a lot of runs (or units) of one gyro type: partial pooling.

Run ``r`` has coefficients ``theta_r`` (the drift model's, e.g. w0, wx, wy, wz) drawn from
the population ``N(mu, diag(tau**2))``: ``mu`` is the gyro type's coefficient, ``tau`` the
between-run sd a datasheet calls repeatability. Each run keeps its own white-noise level
``sigma_r`` (or the ``sigma_deg_h`` its log gives).

For a drift model linear in its coefficients, a run's likelihood is Gaussian in
``theta_r`` with the run's sufficient statistics (``A_r = X'WX / sigma_r**2``, its
least-squares solution and residual sum), so ``theta_r`` integrates out exactly:

    log p(y_r | mu, tau, sigma_r) = -n_r/2 log 2 pi - n_r log sigma_r - rss_r / 2 sigma_r**2
        - sum log tau - 1/2 log|P_r| - 1/2 c_r' P_r^-1 (d_r / tau**2)

with ``d_r = theta_hat_r - mu``, ``c_r = A_r d_r`` and ``P_r = A_r + diag(tau**-2)``. (The
last term is ``d_r' (A_r^-1 + T)^-1 d_r`` written without a difference of large numbers
and without inverting ``A_r``, so a run that leaves a coefficient unidentified still
counts for the others.) Given ``tau`` and the ``sigma_r`` this is Gaussian in ``mu`` too,
so ``mu`` integrates out against its normal (or flat) prior as well. The sampler sees
``log tau`` and ``log sigma_r`` only: neither the funnel between ``tau`` and the
``theta_r`` (what a non-centred parameterisation is otherwise needed for) nor the one
between ``tau`` and ``mu`` (which kept emcee at r_hat 1.04 after 30 000 steps on three
runs when ``mu`` was sampled). Per posterior draw, ``mu`` is then drawn from its exact
conditional, each run's coefficients from theirs, ``N(mu + P_r^-1 c_r, P_r^-1)``, and a
new run's from ``N(mu, T)``: exact joint posterior draws, whose uncertainty includes the
population's.

Priors: ``mu`` the single-run fit's (default: scaled to the logs); ``tau`` half-normal with
the scale of ``mu``'s prior (room for runs that do not differ at all); ``sigma_r`` the
single-run fit's log-normal.
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
from gyroid.inference._problem import AbstractDensity, AbstractProblem, PointEstimate
from gyroid.models._inputs import T0_C
from gyroid.models._priors import Flat as FlatPrior
from gyroid.models._priors import HalfNormal, LogNormal, Normal, prior_arrays

_LOG_2PI = math.log(2.0 * math.pi)
#: Prefix of a between-run sd's name (``between_sd_w0``).
SPREAD_PREFIX = "between_sd_"


#: BFGS on the pool's hyper-parameters (logs of the between-run sds and run noise levels).
_FINDER = JointBFGS(rtol=1e-9, atol=1e-9, max_steps=5000)


class PoolDensity(AbstractDensity):
    """The arrays of a pooled posterior (what is jit-compiled): see the module docstring.

    Sampled coordinates ``u = (log tau, log sigma_r of the runs whose log lacks sigma)``;
    ``mu`` is integrated out and drawn afterwards (:meth:`mean_conditional`)."""

    gram: Float[Array, "r p p"]  # X'WX per run (W = 1 / sigma**2 when the log gives sigma)
    offset: Float[Array, "r p"]  # each run's least-squares coefficients minus ``centre``
    centre: Float[Array, " p"]  # a reference point (the runs' mean) that keeps sums small
    rss: Float[Array, " r"]  # each run's (weighted) residual sum of squares at its solution
    n_rows: Float[Array, " r"]
    log_sigma_sum: Float[Array, " r"]  # sum of log sigma of runs whose log gives it, else 0
    noise_index: Float[Array, " r"]  # index into the sampled log sigma (-1: the log gives it)
    mean_loc: Float[Array, " p"]
    mean_scale: Float[Array, " p"]
    mean_on: Float[Array, " p"]  # 0 for a flat prior on mu
    spread_scale: Float[Array, " p"]  # half-normal scale of tau
    noise_loc: Float[Array, " q"]  # log-normal priors of the sampled sigma_r (log median)
    noise_scale: Float[Array, " q"]

    @property
    def n_coefficients(self) -> int:
        return int(self.offset.shape[1])

    def _run_terms(self, u):
        """Per run: A_r, the Cholesky factor of P_r = A_r + T^-1, T^-1, log tau, log sigma."""
        p = self.n_coefficients
        log_tau, log_sigma = u[:p], u[p:]
        # Each run's log sigma: sampled, or 0 (its gram already carries 1 / sigma**2).
        index = self.noise_index.astype(int)
        padded = jnp.concatenate([log_sigma, jnp.zeros(1)])
        log_sd = jnp.where(index >= 0, padded[jnp.clip(index, 0, None)], 0.0)
        precision_prior = jnp.exp(-2.0 * log_tau)
        a = self.gram * jnp.exp(-2.0 * log_sd)[:, None, None]
        factor = jnp.linalg.cholesky(a + jnp.diag(precision_prior))
        return a, factor, precision_prior, log_tau, log_sd

    def _noise_terms(self, log_tau, log_sd, factor):
        """Per run, the parts of its marginal log-likelihood that do not involve mu."""
        log_det = 2.0 * jnp.sum(jnp.log(jnp.diagonal(factor, axis1=1, axis2=2)), axis=1)
        noise = jnp.where(self.noise_index >= 0,
                          self.n_rows * log_sd + 0.5 * self.rss * jnp.exp(-2.0 * log_sd),
                          self.log_sigma_sum + 0.5 * self.rss)
        return -0.5 * self.n_rows * _LOG_2PI - noise - jnp.sum(log_tau) - 0.5 * log_det

    def _mean_information(self, u):
        """The Gaussian in ``nu = mu - centre`` that the runs and mu's prior give:
        precision Q, linear term b and constant c (``-1/2 (nu'Q nu - 2 b'nu + c)``), and
        the mu-free part of the log-likelihood."""
        a, factor, precision_prior, log_tau, log_sd = self._run_terms(u)
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
        base = jnp.sum(self._noise_terms(log_tau, log_sd, factor))
        base += jnp.sum(self.mean_on * (-jnp.log(self.mean_scale) - 0.5 * _LOG_2PI))
        return q, b, c, base

    def log_likelihood_mean_free(self, u: Float[Array, " d"]) -> Float[Array, ""]:
        """log p(all runs | tau, sigma) with mu integrated against its prior."""
        q, b, c, base = self._mean_information(u)
        factor = jnp.linalg.cholesky(q)
        w = jax.scipy.linalg.solve_triangular(factor, b, lower=True)
        log_det = 2.0 * jnp.sum(jnp.log(jnp.diagonal(factor)))
        return base + 0.5 * self.n_coefficients * _LOG_2PI - 0.5 * log_det - 0.5 * (c - w @ w)

    def log_prior(self, u: Float[Array, " d"]) -> Float[Array, ""]:
        p = self.n_coefficients
        log_tau, log_sigma = u[:p], u[p:]
        tau = jnp.exp(log_tau)
        spread = jnp.sum(log_tau - 0.5 * (tau / self.spread_scale) ** 2 + math.log(2.0)
                         - jnp.log(self.spread_scale) - 0.5 * _LOG_2PI)
        zn = (log_sigma - self.noise_loc) / self.noise_scale
        noise = jnp.sum(-0.5 * zn**2 - jnp.log(self.noise_scale) - 0.5 * _LOG_2PI)
        return spread + noise

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
        """Each run's marginal log-likelihood given mu, tau, sigma (its coefficients
        integrated out): conditionally independent across runs, what LOO leaves out."""
        a, factor, precision_prior, log_tau, log_sd = self._run_terms(u)
        return self._noise_terms(log_tau, log_sd, factor) - 0.5 * self.run_consistency(mu, u)

    def run_consistency(self, mu: Float[Array, " p"], u: Float[Array, " d"]
                        ) -> Float[Array, " r"]:
        """Each run's ``d_r' (A_r^-1 + T)^-1 d_r`` (``d_r`` its own estimate minus mu):
        chi-square with (rank of A_r) degrees of freedom when the run belongs to the
        population."""
        a, factor, precision_prior, *_ = self._run_terms(u)
        d = self.offset - (mu - self.centre)
        solve = jax.vmap(lambda f, b: jax.scipy.linalg.solve_triangular(f, b, lower=True))
        c = jnp.einsum("rij,rj->ri", a, d)
        return jnp.sum(solve(factor, c) * solve(factor, d * precision_prior), axis=1)

    def run_coefficients(self, mu: Float[Array, " p"], u: Float[Array, " d"],
                         z: Float[Array, "r p"]) -> Float[Array, "r p"]:
        """A draw of every run's coefficients from their conditional given mu and ``u``
        (``z`` standard normal; 0 gives the conditional means)."""
        a, factor, *_ = self._run_terms(u)
        d = self.offset - (mu - self.centre)
        solve = jax.vmap(lambda f, b: jax.scipy.linalg.cho_solve((f, True), b))
        back = jax.vmap(lambda f, b: jax.scipy.linalg.solve_triangular(f.T, b, lower=False))
        return mu + solve(factor, jnp.einsum("rij,rj->ri", a, d)) + back(factor, z)


class PoolProblem(AbstractProblem):
    """A pooled posterior with its description: parameter names, run labels, priors, and
    (when it pools logs) each run's own problem, whose residuals the checks read."""

    density: PoolDensity
    coefficient_names: tuple[str, ...]
    run_labels: tuple[str, ...]
    noisy_runs: tuple[int, ...]  # runs whose sigma is sampled
    ranks: tuple[int, ...]  # rank of each run's X'WX
    #: Each run's own least-squares coefficients and their sds (R, p; nan where a run does
    #: not identify one), and each population mean's identifiability yardstick (p,).
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
    #: Pooling each run's own fit under correlated noise (``run_noise``, its name): each
    #: run's residual and noise checks from that fit (``runs`` then only describe the logs).
    run_reports: tuple = ()
    run_noise: str = "white"
    #: Those fits' noise estimates (``NoiseEstimate``s, one per run), from which a new
    #: run's noise is drawn up (``pool.json``'s ``run_noise_levels``).
    run_noise_levels: tuple = ()

    @classmethod
    def from_statistics(cls, coefficient_names, run_labels, *, gram, solution, rss, n_rows,
                        log_sigma_sum, sigma_known, mean_priors, spread_scales,
                        noise_priors, **context) -> PoolProblem:
        """Build from each run's sufficient statistics (``gram`` (R, p, p), ``solution`` (R,
        p), ``rss``, ``n_rows``, ``log_sigma_sum`` (R,), ``sigma_known`` (R,) flags) and the
        priors: ``mean_priors`` (Normal or Flat per coefficient), ``spread_scales`` (p,)
        and ``noise_priors`` (a LogNormal per run whose sigma is sampled); ``context``: the
        description fields (``runs``, ``terms``, ``t0_C``, ``segment_means``)."""
        gram = np.asarray(gram, dtype=float)
        solution = np.asarray(solution, dtype=float)
        r = gram.shape[0]
        noisy = tuple(i for i in range(r) if not sigma_known[i])
        index = np.full(r, -1.0)
        index[list(noisy)] = np.arange(len(noisy))
        loc, scale, on = prior_arrays(mean_priors, [False] * len(mean_priors))
        centre = solution.mean(axis=0)
        density = PoolDensity(
            gram=jnp.asarray(gram), offset=jnp.asarray(solution - centre),
            centre=jnp.asarray(centre), rss=jnp.asarray(np.asarray(rss, dtype=float)),
            n_rows=jnp.asarray(np.asarray(n_rows, dtype=float)),
            log_sigma_sum=jnp.asarray(np.asarray(log_sigma_sum, dtype=float)),
            noise_index=jnp.asarray(index),
            mean_loc=jnp.asarray(loc), mean_scale=jnp.asarray(scale), mean_on=jnp.asarray(on),
            spread_scale=jnp.asarray(np.asarray(spread_scales, dtype=float)),
            noise_loc=jnp.asarray([math.log(noise_priors[i].median) for i in noisy]),
            noise_scale=jnp.asarray([noise_priors[i].log_sd for i in noisy]),
        )
        ranks = tuple(int(np.linalg.matrix_rank(g)) for g in gram)
        return cls(density=density, coefficient_names=tuple(coefficient_names),
                   run_labels=tuple(run_labels), noisy_runs=noisy, ranks=ranks, **context)

    @classmethod
    def from_estimates(cls, coefficient_names, run_labels, estimates, covariances, *,
                       mean_priors, spread_scales, **context) -> PoolProblem:
        """Pool published per-run estimates with given covariances (e.g. a paper's table
        with an assumed within-run sd): each run is one Gaussian observation of its
        coefficients."""
        covariances = np.asarray(covariances, dtype=float)
        r = covariances.shape[0]
        return cls.from_statistics(
            coefficient_names, run_labels, gram=np.linalg.inv(covariances),
            solution=estimates, rss=np.zeros(r), n_rows=np.zeros(r),
            log_sigma_sum=np.zeros(r), sigma_known=[True] * r, mean_priors=mean_priors,
            spread_scales=spread_scales, noise_priors=[None] * r, **context)

    def without_run(self, r: int) -> PoolProblem:
        """The same lot and priors with run ``r``'s data taken out: its statistics zeroed
        (no information; its noise level, if sampled, keeps only its prior), so that the
        arrays keep their shapes and the compiled functions are reused."""
        d = self.density
        return eqx.tree_at(
            lambda q: (q.density.gram, q.density.rss, q.density.n_rows,
                       q.density.log_sigma_sum),
            self,
            (d.gram.at[r].set(0.0), d.rss.at[r].set(0.0), d.n_rows.at[r].set(0.0),
             d.log_sigma_sum.at[r].set(0.0)))

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
    def noise_names(self) -> tuple[str, ...]:
        return tuple(f"sigma_deg_h[{self.run_labels[i]}]" for i in self.noisy_runs)

    @property
    def names(self) -> tuple[str, ...]:
        """The sampled parameters: between-run sds, then the runs' noise levels."""
        return self.spread_names + self.noise_names

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
        d = self.density
        spread = tuple(HalfNormal(float(s)) for s in np.asarray(d.spread_scale))
        noise = tuple(LogNormal(float(np.exp(lo)), float(s))
                      for lo, s in zip(np.asarray(d.noise_loc), np.asarray(d.noise_scale),
                                       strict=True))
        return spread + noise

    # ----- what storage (ArviZ) records -----------------------------------------------------
    def observed_data(self) -> dict[str, np.ndarray]:
        return {"run_n_rows": np.asarray(self.density.n_rows)}

    def idata_attrs(self) -> dict[str, str]:
        return {
            "model": "partially pooled runs: theta_run ~ N(population mean, between_sd**2)",
            "coefficients": ",".join(self.coefficient_names),
            "runs": ",".join(self.run_labels),
            "run_noise": (self.run_noise if not self.run_reports else
                          f"{self.run_noise}: each run fitted on its own, its coefficients' "
                          "posterior mean and covariance pooled"),
            "log_likelihood_note": "log_likelihood holds each run's marginal log-likelihood "
                                   "given the population (its coefficients integrated out): "
                                   "LOO leaves out whole runs",
            "draws_note": "the sampler drew the between-run sds and noise levels; population "
                          "means and runs' coefficients are drawn from their exact "
                          "conditionals",
        }

    # ----- fitting ---------------------------------------------------------------------------
    def default_sampler(self) -> Nuts:
        """NUTS: emcee's ensemble moves do not mix this posterior (see
        :mod:`gyroid.inference._nuts`)."""
        return Nuts()

    def start(self) -> np.ndarray:
        """A starting point: the spread of the runs' least-squares coefficients, and each
        run's residual RMS."""
        d = self.density
        scale = np.asarray(d.spread_scale)
        spread = np.asarray(d.offset).std(axis=0, ddof=1) if self.n_runs > 1 else 0.1 * scale
        log_tau = np.log(np.clip(spread, 1e-3 * scale, None))
        dof = np.maximum(np.asarray(d.n_rows) - np.asarray(self.ranks), 1.0)
        log_sigma = 0.5 * np.log(np.maximum(np.asarray(d.rss) / dof, 1e-300))
        noisy = list(self.noisy_runs)
        # A run whose data were taken out (without_run) starts at its prior's median.
        empty = np.asarray(d.n_rows)[noisy] == 0
        return np.concatenate([log_tau, np.where(empty, np.asarray(d.noise_loc),
                                                 log_sigma[noisy])])

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

