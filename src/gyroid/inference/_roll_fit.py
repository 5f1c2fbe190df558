"""Fitting paper B's loop parameters to a roll log: the point estimate (BFGS, optimistix),
the posterior (emcee, through :mod:`gyroid.inference._sampling`) and the evidence the
self-checks read.
The model and its likelihood are :mod:`gyroid.inference._roll_problem`."""

from __future__ import annotations

from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from gyroid.inference._checks import CheckReport, FitEvidence, fit_checks
from gyroid.inference._roll_problem import RollDensity, RollProblem
from gyroid.io._roll_log import RollLog
from gyroid.models._paper_b import DEG
from gyroid.models._priors import natural_with_sd, prior_arrays


@dataclass
class RollPoint:
    names: tuple[str, ...]
    u: np.ndarray
    covariance_u: np.ndarray
    value: dict[str, float]
    sd: dict[str, float]
    converged: bool
    message: str


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


def roll_point_estimate(problem: RollProblem) -> RollPoint:
    """Linearised least squares for a start, then BFGS (optimistix) on the log-posterior;
    covariance from the inverse Hessian."""
    t = np.asarray(problem.time_s)
    psi_x = np.cumsum(np.asarray(problem.sins)) * problem.sample_s
    y = np.asarray(problem.gs_angle) - psi_x
    design = np.column_stack([np.ones_like(t), -psi_x, t, np.sin(psi_x * DEG),
                              np.cos(psi_x * DEG)])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    start = dict(psi0=coef[0], D0=0.0, D1=coef[1], D0gs=coef[2], D1gs=0.0, enc_a=coef[3],
                 enc_b=coef[4], D2=0.0, sigma_gs_deg=0.01, sigma_sins_deg_s=0.02,
                 sigma_m_deg_s=0.01)
    if problem.ideal_gs:
        start["D0gs"] = float(np.median(np.asarray(problem.gs_rate)))
        start["D0"] = start["D0gs"] - coef[2]
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
    return RollPoint(problem.names, u, cov, dict(zip(problem.names, x.tolist(), strict=True)),
                     dict(zip(problem.names, sd.tolist(), strict=True)), ok, message)


CONFOUNDING_THRESHOLD = 0.9


@dataclass
class RollFit:
    problem: RollProblem
    point: RollPoint
    posterior: object
    summary: dict = field(default_factory=dict)
    checks: CheckReport = field(default_factory=lambda: CheckReport(()))
    notes: tuple[str, ...] = ()

    @property
    def trustworthy(self) -> bool:
        return self.checks.trustworthy

    def to_json(self) -> dict:
        from gyroid.inference._sampling import interval_summary

        post = self.posterior
        flat = post.draws.reshape(-1, len(self.problem.names))
        derived = {}
        if "enc_a" in self.problem.names:
            a = flat[:, self.problem.names.index("enc_a")]
            b = flat[:, self.problem.names.index("enc_b")]
            derived = {"Denc": np.hypot(a, b), "encoder_phase_rad": np.arctan2(b, a)}
        summary = {k: dict(v) for k, v in post.summary.items()}
        for name, values in derived.items():
            summary[name] = interval_summary(values) | {"derived_from": ["enc_a", "enc_b"]}
        loop_names = [n for n in ("D0", "D1", "D0gs", "D1gs", "D2") if n in self.problem.names]
        corr = np.corrcoef(flat[:, [self.problem.names.index(n) for n in loop_names]],
                           rowvar=False)
        confounded = []
        advice = {
            ("D0", "D0gs"): "log the stabiliser's MEMS output (gs_rate_deg_s) while it holds "
                            "the platform (ideal stabiliser): it measures D0gs alone",
            ("D1", "D1gs"): "vary the roll rate while the stabiliser stays unsaturated, or "
                            "hold it ideal for part of the flight: D1 then acts alone",
            ("D0", "D1"): "vary the roll rate (a ramp or a reversal): D1 scales with it, D0 "
                          "does not",
        }
        pairs = {(a_name, loop_names[j]): float(corr[i, j])
                 for i, a_name in enumerate(loop_names) for j in range(i + 1, len(loop_names))
                 if abs(corr[i, j]) > CONFOUNDING_THRESHOLD}
        # A pair without advice of its own is usually a consequence of advised pairs that
        # share a parameter with it (D0 ~ D0gs and D1 ~ D1gs make D0gs ~ D1gs): say so.
        advised = [pair for pair in pairs if pair in advice]
        for pair, r in pairs.items():
            item = {"parameters": list(pair), "correlation": r,
                    "identified": "only their combination"}
            if pair in advice:
                item["suggestion"] = advice[pair]
            else:
                causes = [p for p in advised if set(p) & set(pair)]
                item["follows_from"] = [list(p) for p in causes]
                item["suggestion"] = (
                    "separates once " + " and ".join(f"{a} and {b}" for a, b in causes)
                    + " are separated" if causes else
                    "no manoeuvre in gyroid's catalogue separates them: report their "
                    "combination")
            confounded.append(item)
        return {
            "terms": list(self.problem.terms),
            "parameters": {n: summary[n] for n in (*loop_names, *(["Denc"] if derived else []))},
            "point": {n: self.point.value[n] for n in self.problem.names},
            "point_sd": {n: self.point.sd[n] for n in self.problem.names},
            "posterior": summary,
            "confounded": confounded,
            "ideal_stabiliser_assumed": not self.problem.use_gs_rate,
            "gs_rate_used": bool(self.problem.gs_rate is not None
                                 and (self.problem.use_gs_rate or self.problem.ideal_gs)),
            "n_samples": int(self.problem.time_s.shape[0]),
            "convergence": {"point_estimate": self.point.message,
                            "sampler_steps": post.n_steps, "sampler_move": post.move,
                            "converged": post.converged},
            "units": {"D0": "deg/s", "D1": "relative", "D0gs": "deg/s", "D1gs": "relative",
                      "Denc": "deg", "psi0": "deg", "sigma_gs_deg": "deg",
                      "sigma_sins_deg_s": "deg/s"},
            "notes": list(self.notes),
            **self.checks.to_json(),
        }


def fit_roll_log(log: RollLog, *, seed: int = 0, settings=None) -> RollFit:
    from gyroid.inference._sampling import sample_posterior

    problem = RollProblem.from_log(log)
    point = roll_point_estimate(problem)
    posterior = sample_posterior(problem, point, seed=seed, settings=settings)
    fit = RollFit(problem, point, posterior, notes=log.notes)
    fit.checks = fit_checks(roll_evidence(fit))
    return fit


_ROLL_HINTS = {
    "D1": "D1 needs a flight whose roll angle advances further (a longer or faster roll)",
    "D0": "D0 needs the stabiliser's MEMS output (gs_rate_deg_s) from an ideal stabiliser",
    "D0gs": "D0gs is told apart from D0 only by the stabiliser's MEMS output "
            "(gs_rate_deg_s) logged while the stabiliser holds the platform",
    "D1gs": "D1gs needs a stabiliser that is overloaded for part of the flight",
    "enc_a": "the encoder error needs whole turns of roll", "enc_b": "the encoder error "
    "needs whole turns of roll",
}


def roll_evidence(fit: RollFit) -> FitEvidence:
    """What the self-checks need from a roll fit (its priors are physical, so they are also
    the identifiability yardstick)."""
    problem, point, post = fit.problem, fit.point, fit.posterior
    n_model = sum(not n.startswith("sigma_") for n in problem.names)
    draws_u = np.asarray(problem.to_sampling(jnp.asarray(post.draws)))
    prior_sd = prior_arrays(problem.priors, problem.positive)[1]
    reference = dict(zip(problem.names, prior_sd.tolist(), strict=True))
    residuals = np.asarray(problem.density.standardised_residuals(jnp.asarray(point.u)))
    return FitEvidence(
        names=problem.names, n_model=n_model, point_u=np.asarray(point.u),
        point_converged=point.converged, point_message=point.message,
        priors=problem.priors, reference_sd=reference, residuals=residuals,
        sigma_given=False, noise="white", draws_u=draws_u, summary=post.summary,
        hints=_ROLL_HINTS,
    )


# ----- the discrepancy workflow on roll logs ------------------------------------------------

