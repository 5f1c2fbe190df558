"""Fitting paper B's loop parameters to a roll log: the mode (BFGS, optimistix), the result
(:class:`RollFit`, with its self-checks and the confounded parameter pairs) and
:func:`fit_roll_log`. The model and its likelihood are :mod:`gyroid.inference._roll_problem`."""

from __future__ import annotations

from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from gyroid.inference._check_report import CheckReport, FitEvidence
from gyroid.inference._checks import fit_checks
from gyroid.inference._fit import fit
from gyroid.inference._posterior import (
    AbstractSampler,
    Posterior,
    inference_data,
    interval_summary,
)
from gyroid.inference._problem import PointEstimate
from gyroid.inference._result import FitResult
from gyroid.inference._roll_predictive import roll_predictive
from gyroid.inference._roll_problem import RollDensity, RollProblem
from gyroid.io._roll_log import RollLog
from gyroid.models._paper_b import DEG
from gyroid.models._priors import LogNormal, natural_with_sd, prior_arrays
from gyroid.models._roll_effects import ROLL_CONFOUNDED, roll_parameter

#: The loop's parameters whose correlations are examined, in report order.
LOOP_PARAMETERS = ("D0", "D1", "D0gs", "D1gs", "D2")
#: |correlation| above which two loop parameters are reported as confounded.
CONFOUNDING_THRESHOLD = 0.9


def _nlp_full(v, density: RollDensity):
    return -density.log_posterior(v)


_nlp_hessian = eqx.filter_jit(jax.hessian(_nlp_full))


@eqx.filter_jit
def _minimise(density: RollDensity, v0, scale):
    """BFGS in standardised coordinates (v = v0 + scale z) over all of ``ALL_PARAMETERS``,
    so that every model of a log shares one compilation: the entries outside the model have
    no gradient, so BFGS never moves them. Standardised because D1 is known to 1e-7 while
    the offsets are known to 1e-3: unscaled step tolerances would stop far too early."""

    def objective(z, args):
        return _nlp_full(v0 + scale * z, args)

    solution = optx.minimise(objective, optx.BFGS(rtol=1e-10, atol=1e-10), jnp.zeros_like(v0),
                             args=density, max_steps=5000, throw=False)
    v = v0 + scale * solution.value
    return v, solution.result, jax.hessian(_nlp_full)(v, density)


def _start(problem: RollProblem) -> dict[str, float]:
    """Starting values: the loop's offsets, D1 and the encoder terms from a linearised least
    squares of the stabiliser angle on the integrated SINS rate; the noise levels at their
    priors' medians; everything else zero."""
    t = np.asarray(problem.time_s)
    psi_x = np.cumsum(np.asarray(problem.sins)) * problem.sample_s
    y = np.asarray(problem.gs_angle) - psi_x
    design = np.column_stack([np.ones_like(t), -psi_x, t, np.sin(psi_x * DEG),
                              np.cos(psi_x * DEG)])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    start = {name: (prior.median if isinstance(prior, LogNormal) else 0.0)
             for name, prior in zip(problem.names, problem.priors, strict=True)}
    start |= dict(psi0=coef[0], D1=coef[1], D0gs=coef[2], enc_a=coef[3], enc_b=coef[4])
    if problem.ideal_gs:
        start["D0gs"] = float(np.median(np.asarray(problem.gs_rate)))
        start["D0"] = start["D0gs"] - coef[2]
    return start


def roll_point_estimate(problem: RollProblem) -> PointEstimate:
    """Linearised least squares for a start, then BFGS (optimistix) on the log-posterior;
    covariance from the inverse Hessian."""
    start = _start(problem)
    x0 = np.array([start[n] for n in problem.names])
    slot = np.asarray(problem.density.slot)
    v0 = np.asarray(problem.density.spread(problem.to_sampling(jnp.asarray(x0))))
    # Scales from the curvature at the start (diagonal of the Hessian), floored for safety;
    # 1 for the parameters outside the model (they have no curvature).
    curvature = np.abs(np.diag(np.asarray(_nlp_hessian(jnp.asarray(v0), problem.density.full))))
    scale = 1.0 / np.sqrt(np.where(np.isfinite(curvature) & (curvature > 0), curvature, 1.0))
    value, result, hessian = _minimise(problem.density.full, jnp.asarray(v0), jnp.asarray(scale))
    ok = bool(result == optx.RESULTS.successful)
    message = "converged" if ok else optx.RESULTS[result].split("\n")[0]
    hessian = np.asarray(hessian)[np.ix_(slot, slot)]
    try:
        cov = np.linalg.inv(hessian)
    except np.linalg.LinAlgError:
        cov = np.full_like(hessian, np.nan)
    u = np.asarray(value)[slot]
    x, sd = natural_with_sd(u, cov, problem.positive)
    return PointEstimate(problem.names, u, cov, dict(zip(problem.names, x.tolist(), strict=True)),
                         dict(zip(problem.names, sd.tolist(), strict=True)), ok, message)


@dataclass(frozen=True)
class Confounded:
    """Two loop parameters the flight does not tell apart (|correlation| above
    ``CONFOUNDING_THRESHOLD``), with what would separate them."""

    parameters: tuple[str, str]
    correlation: float
    suggestion: str
    follows_from: tuple[tuple[str, str], ...] | None = None  # pairs that cause this one

    def to_json(self) -> dict:
        out = {"parameters": list(self.parameters), "correlation": self.correlation,
               "identified": "only their combination", "suggestion": self.suggestion}
        if self.follows_from is not None:
            out["follows_from"] = [list(pair) for pair in self.follows_from]
        return out


def confounded_pairs(names: tuple[str, ...], draws: np.ndarray) -> tuple[Confounded, ...]:
    """The loop parameters' confounded pairs, from posterior draws (M, d). A pair without
    advice of its own in the registry is usually a consequence of advised pairs that share
    a parameter with it (D0 ~ D0gs and D1 ~ D1gs make D0gs ~ D1gs): it says so."""
    loop = [n for n in LOOP_PARAMETERS if n in names]
    corr = np.corrcoef(draws[:, [names.index(n) for n in loop]], rowvar=False)
    pairs = {(a, loop[j]): float(corr[i, j]) for i, a in enumerate(loop)
             for j in range(i + 1, len(loop)) if abs(corr[i, j]) > CONFOUNDING_THRESHOLD}
    advised = [pair for pair in pairs if pair in ROLL_CONFOUNDED]
    out = []
    for pair, r in pairs.items():
        if pair in ROLL_CONFOUNDED:
            out.append(Confounded(pair, r, ROLL_CONFOUNDED[pair]))
            continue
        causes = tuple(p for p in advised if set(p) & set(pair))
        suggestion = ("separates once " + " and ".join(f"{a} and {b}" for a, b in causes)
                      + " are separated" if causes else
                      "no manoeuvre in gyroid's catalogue separates them: report their "
                      "combination")
        out.append(Confounded(pair, r, suggestion, follows_from=causes))
    return tuple(out)


@dataclass(frozen=True, eq=False)
class RollFit(FitResult):
    """A fitted roll log: problem, mode, posterior, the encoder error's amplitude and phase,
    the confounded pairs and the self-checks."""

    problem: RollProblem = field(repr=False)
    point: PointEstimate = field(repr=False)
    posterior: Posterior = field(repr=False)
    seed: int
    derived: dict[str, dict] = field(repr=False)  # Denc, encoder_phase_rad summaries
    confounded: tuple[Confounded, ...] = field(repr=False)
    checks: CheckReport = field(repr=False)

    def __repr__(self) -> str:
        verdict = "trustworthy" if self.trustworthy else "NOT trustworthy"
        return (f"RollFit(terms={','.join(self.problem.terms)!r}, "
                f"n_samples={self.problem.log.n}, {verdict})")

    @property
    def loop_names(self) -> tuple[str, ...]:
        return tuple(n for n in LOOP_PARAMETERS if n in self.problem.names)

    def summary(self) -> str:
        """The loop's parameters, the confounded pairs and the failed self-checks."""
        record = self.to_json()
        lines = [f"roll loop {','.join(self.problem.terms)} on {self.problem.log.n} rows:"]
        lines += [f"  {name:>5s} = {s['mean']:.6g} +/- {s['sd']:.2g}"
                  for name, s in record["parameters"].items()]
        lines += [f"  confounded: {' and '.join(c.parameters)} (r = {c.correlation:.3f})"
                  for c in self.confounded]
        lines += [f"  {line}" for line in self.checks.lines()]
        return "\n".join([*lines, f"  {self.checks.verdict()}"])

    def inference_data(self):
        return inference_data(self.problem, self.posterior)

    def to_json(self) -> dict:
        """``roll_fit.json``."""
        problem, post = self.problem, self.posterior
        summary = {k: dict(v) for k, v in post.summary.items()} | self.derived
        shown = (*self.loop_names, *(["Denc"] if self.derived else []))
        return {
            "terms": list(problem.terms),
            "parameters": {n: summary[n] for n in shown},
            "point": {n: self.point.value[n] for n in problem.names},
            "point_sd": {n: self.point.sd[n] for n in problem.names},
            "posterior": summary,
            "confounded": [c.to_json() for c in self.confounded],
            "ideal_stabiliser_assumed": not problem.use_gs_rate,
            "gs_rate_used": bool(problem.gs_rate is not None
                                 and (problem.use_gs_rate or problem.ideal_gs)),
            "n_samples": problem.log.n,
            "convergence": {"point_estimate": self.point.message,
                            "sampler_steps": post.n_steps, "sampler_move": post.move,
                            "sampler": post.method,
                            "converged": post.converged},
            "units": {n: roll_parameter(n).unit for n in problem.names}
                     | ({"Denc": "deg", "encoder_phase_rad": "rad"} if self.derived else {}),
            "notes": list(problem.log.notes),
            **self.checks.to_json(),
        }


def roll_evidence(problem: RollProblem, point: PointEstimate, posterior: Posterior | None
                  ) -> FitEvidence:
    """What the self-checks need from a roll fit (its priors are physical, so they are also
    the identifiability yardstick)."""
    prior_sd = prior_arrays(problem.priors, problem.positive)[1]
    residuals = np.asarray(problem.density.standardised_residuals(jnp.asarray(point.u)))
    return FitEvidence(
        names=problem.names, n_model=problem.n_model, point_u=np.asarray(point.u),
        point_converged=point.converged, point_message=point.message,
        priors=problem.priors, reference_sd=dict(zip(problem.names, prior_sd.tolist(),
                                                     strict=True)),
        residuals=residuals, sigma_given=False, correlated_noise=False,
        draws_u=None if posterior is None else problem.to_sampling_host(posterior.draws),
        summary=None if posterior is None else posterior.summary,
        hints={n: roll_parameter(n).hint for n in problem.names if roll_parameter(n).hint},
        remedies=frozenset({"discrepancy"}),
    )


def roll_result(problem: RollProblem, point: PointEstimate, posterior: Posterior | None, *,
                seed: int) -> RollFit:
    """The :class:`RollFit` of a roll problem (its checks, derived quantities and confounded
    pairs computed first)."""
    if posterior is None:
        raise ValueError("a roll fit needs its posterior (the confounding analysis reads it)")
    flat = posterior.draws.reshape(-1, len(problem.names))
    derived = {}
    if "enc_a" in problem.names:
        a = flat[:, problem.names.index("enc_a")]
        b = flat[:, problem.names.index("enc_b")]
        derived = {name: interval_summary(values) | {"derived_from": ["enc_a", "enc_b"]}
                   for name, values in (("Denc", np.hypot(a, b)),
                                        ("encoder_phase_rad", np.arctan2(b, a)))}
    return RollFit(problem=problem, point=point, posterior=posterior, seed=seed,
                   derived=derived, confounded=confounded_pairs(problem.names, flat),
                   checks=fit_checks(roll_evidence(problem, point, posterior))
                   + CheckReport((roll_predictive(problem, point),)))


def fit_roll_log(log: RollLog, *, terms="loop", seed: int = 0,
                 sampler: AbstractSampler | None = None) -> RollFit:
    """Fit paper B's loop (``terms``, default ``loop``) to a roll log: the mode, the emcee
    posterior (or ``sampler``'s), the self-checks."""
    return fit(RollProblem.from_log(log, terms), sampler=sampler, seed=seed)
