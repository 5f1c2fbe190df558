"""The posterior of paper B's loop parameters given a roll log (docs/formats.md section 4).

The SINS output ``w_x`` is inverted for the true rate, ``w = (w_x - D0) / (1 + D1)``, and
integrated into the roll angle; the stabiliser's angle is then predicted as
``psi0 + psi + platform error + encoder error`` with

* platform error ``int (D1gs m + D0gs) / (1 + D1gs) dt`` when the log has the stabiliser's
  MEMS output ``m`` (``gs_rate_deg_s``: then ``w_H = (m - D0gs) / (1 + D1gs)``), else
  ``D0gs t`` (an ideal stabiliser);
* encoder error ``a sin(psi) + b cos(psi)``: ``Denc = hypot(a, b)``, phase ``atan2(b, a)``.

The residual is the encoder's read-out noise (white, ``sigma_gs_deg``) plus the SINS gyro's
noise integrated into the angle (a random walk, ``sigma_sins_deg_s`` per sample); the exact
Gaussian likelihood comes from a Kalman filter. When the stabiliser is ideal (``m`` near
zero) its MEMS output is also an observation of ``D0gs`` (``m ~ N(D0gs, sigma_m)``): that is
what separates ``D0gs`` from the SINS bias ``D0``, which otherwise enter only through their
difference.
"""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from gyroid.inference._batching import problem_batcher
from gyroid.inference._emcee import Emcee
from gyroid.inference._importance import Importance
from gyroid.inference._marginal_target import MarginalTarget, whole_posterior
from gyroid.inference._mode import JointBFGS, safe_inverse
from gyroid.inference._posterior import Posterior
from gyroid.inference._problem import AbstractProblem, PointEstimate
from gyroid.io._roll_log import RollLog
from gyroid.models._paper_b import DEG
from gyroid.models._priors import LogNormal, Prior, natural_with_sd, prior_arrays
from gyroid.models._roll_effects import ROLL_EFFECTS, ROLL_NUISANCE, resolve_roll_terms
from gyroid.roll._density import (
    ALL_PARAMETERS,
    ModelDensity,
    _density_of,
)
from gyroid.roll._result import RollFit, roll_result

#: The mode: BFGS in standardised coordinates (v = v0 + scale z) over all of
#: ``ALL_PARAMETERS``, so that every model of a log shares one compilation: the entries
#: outside the model have no gradient, so BFGS never moves them. Standardised because D1 is
#: known to 1e-7 while the offsets are known to 1e-3: unscaled step tolerances would stop
#: far too early.
_FINDER = JointBFGS(rtol=1e-10, atol=1e-10, max_steps=5000)


class RollProblem(AbstractProblem[RollFit]):
    """Posterior of the roll-loop parameters given a roll log: the model's description
    (terms, parameter names, priors) around its ``density`` (the JAX part)."""

    density: ModelDensity
    log: RollLog
    has_gs_rate: bool
    use_gs_rate: bool  # the platform error integrates m (gs_rate_leak is in the model)
    ideal_gs: bool  # m ~ D0gs: also an observation of D0gs
    terms: tuple[str, ...]
    parameter_names: tuple[str, ...]
    parameter_priors: tuple[Prior, ...]
    parameter_positive: tuple[bool, ...]

    @classmethod
    def from_log(cls, log: RollLog, terms: str | tuple[str, ...] = "loop") -> RollProblem:
        sample_s = float(np.median(np.diff(log.time_s)))
        rate = log.gs_rate_deg_s
        has_rate = rate is not None
        # Ideal: the platform is never left turning (the MEMS reads only its bias and noise).
        ideal = bool(rate is not None and np.percentile(np.abs(rate), 99) < 1.0)
        terms = resolve_roll_terms(terms)
        if "gs_rate_leak" in terms and (not has_rate or ideal):
            # Without m, or with m ~ D0gs (an ideal stabiliser), D1gs cannot be seen.
            terms = tuple(t for t in terms if t != "gs_rate_leak")
        noise = ("sigma_gs_deg", "sigma_sins_deg_s", *(("sigma_m_deg_s",) if ideal else ()))
        spec = [ROLL_NUISANCE["psi0"],
                *(p for term in terms for p in ROLL_EFFECTS[term].parameters),
                *(ROLL_NUISANCE[name] for name in noise)]
        names = tuple(p.name for p in spec)
        priors = tuple(p.prior for p in spec)
        positive = tuple(p.positive for p in spec)
        full = _density_of(log, names, priors, positive, sample_s=sample_s, ideal=ideal,
                           has_rate=has_rate)
        density = ModelDensity(full, jnp.asarray([ALL_PARAMETERS.index(n) for n in names]))
        return cls(density=density, log=log, has_gs_rate=has_rate,
                   use_gs_rate="gs_rate_leak" in terms, ideal_gs=ideal, terms=terms,
                   parameter_names=names, parameter_priors=priors,
                   parameter_positive=positive)

    # ----- description -------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        return self.parameter_names

    @property
    def priors(self) -> tuple[Prior, ...]:
        return self.parameter_priors

    @property
    def positive(self) -> tuple[bool, ...]:
        return self.parameter_positive

    @property
    def n_model(self) -> int:
        """The loop's parameters (psi0 and the effects'), before the noise levels."""
        return sum(not n.startswith("sigma_") for n in self.names)

    # ----- the log, as the fit sees it -------------------------------------------------------
    @property
    def time_s(self):
        return self.density.full.time_s

    @property
    def sins(self):
        return self.density.full.sins

    @property
    def gs_angle(self):
        return self.density.full.gs_angle

    @property
    def gs_rate(self):
        return self.density.full.gs_rate if self.has_gs_rate else None

    @property
    def observed(self):
        return self.density.full.observed

    @property
    def sample_s(self) -> float:
        return float(self.density.full.sample_s)

    def values(self, u) -> dict:
        return dict(zip(self.names, self.to_natural(u), strict=True))

    def predict(self, u):
        return self.density.predict(u)

    # ----- fitting ----------------------------------------------------------------------------
    def result(self, point: PointEstimate, posterior: Posterior | None, *,
               seed: int) -> RollFit:
        """The fit's frozen :class:`~gyroid.roll.RollFit`, its self-checks first."""
        return roll_result(self, point, posterior, seed=seed)

    def mode(self) -> PointEstimate:
        """Linearised least squares for a start (:meth:`start`), then BFGS on the
        log-posterior (:data:`_FINDER`); the covariance from the inverse Hessian."""
        start = self.start()
        x0 = np.array([start[n] for n in self.names])
        slot = np.asarray(self.density.slot)
        v0 = np.asarray(self.density.spread(self.to_sampling(jnp.asarray(x0))))
        # Scales from the curvature at the start (diagonal of the Hessian), floored for
        # safety; 1 for the parameters outside the model (they have no curvature).
        curvature = np.abs(np.diag(_FINDER.curvature(self.density.full, v0)))
        scale = 1.0 / np.sqrt(np.where(np.isfinite(curvature) & (curvature > 0), curvature,
                                       1.0))
        found = _FINDER.minimise(self.density.full, v0, scale)
        cov = safe_inverse(found.curvature[np.ix_(slot, slot)])
        u = found.value[slot]
        x, sd = natural_with_sd(u, cov, self.positive)
        return PointEstimate(self.names, u, cov,
                             dict(zip(self.names, x.tolist(), strict=True)),
                             dict(zip(self.names, sd.tolist(), strict=True)),
                             found.converged, found.message)

    def start(self) -> dict[str, float]:
        """Where the mode starts: the loop's offsets, D1 and the encoder terms from a
        linearised least squares of the stabiliser angle on the integrated SINS rate; the
        noise levels at their priors' medians; everything else zero."""
        t = np.asarray(self.time_s)
        psi_x = np.cumsum(np.asarray(self.sins)) * self.sample_s
        y = np.asarray(self.gs_angle) - psi_x
        design = np.column_stack([np.ones_like(t), -psi_x, t, np.sin(psi_x * DEG),
                                  np.cos(psi_x * DEG)])
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        start = {name: (prior.median if isinstance(prior, LogNormal) else 0.0)
                 for name, prior in zip(self.names, self.priors, strict=True)}
        start |= dict(psi0=coef[0], D1=coef[1], D0gs=coef[2], enc_a=coef[3], enc_b=coef[4])
        if self.ideal_gs:
            start["D0gs"] = float(np.median(np.asarray(self.gs_rate)))
            start["D0"] = start["D0gs"] - coef[2]
        return start

    def marginal_target(self) -> MarginalTarget:
        """Every parameter drawn by importance sampling (none integrates out: the loop is
        nonlinear in D1 and the encoder's phase), the noise levels' log-normal priors as
        the tails the posterior may keep."""
        return whole_posterior(problem_batcher(self.density.log_posterior), self.positive,
                               *prior_arrays(self.priors, self.positive),
                               "loop's parameters and noise levels")

    def default_sampler(self) -> Importance:
        return Importance(fallback=Emcee())

    # ----- ArviZ hooks -----------------------------------------------------------------------
    def observed_data(self):
        return {"gs_angle_deg": np.asarray(self.gs_angle)[np.asarray(self.observed)]}

    def constant_data(self):
        return {"time_s": np.asarray(self.time_s)[np.asarray(self.observed)],
                "loo_block": np.asarray(self.density.full.block)}

    def idata_attrs(self):
        return {"model": "paper B roll-correction loop", "ideal_stabiliser": str(self.ideal_gs)}
