"""Fitting a bench log: point estimate (optimistix), posterior (emcee), summary (ArviZ)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from gyroid.drift import DriftModel
from gyroid.effects import PARAMETERS
from gyroid.inputs import T0_C
from gyroid.likelihood import NOISE_UNITS, BenchProblem
from gyroid.logs import BenchLog
from gyroid.point import PointEstimate, point_estimate
from gyroid.priors import Flat, LogNormal, Normal, Prior
from gyroid.sampling import Posterior, SamplerSettings, sample_posterior


@dataclass
class FitResult:
    """A fitted bench log: the problem, its point estimate and (optionally) its posterior."""

    problem: BenchProblem
    point: PointEstimate
    posterior: Posterior | None
    seed: int
    t0_C: float
    warnings: list[str] = field(default_factory=list)

    @property
    def model_names(self) -> tuple[str, ...]:
        return self.problem.model.parameter_names

    def predict_draws(self, n_draws: int = 200, seed: int = 0) -> np.ndarray:
        """Modelled drift (deg/h) for ``n_draws`` posterior draws: (n_draws, n)."""
        if self.posterior is None:
            return np.asarray(self.problem.predict(jnp.asarray(self.point.u)))[None]
        flat = self.posterior.draws.reshape(-1, len(self.problem.names))
        rng = np.random.default_rng(seed)
        pick = rng.choice(flat.shape[0], size=min(n_draws, flat.shape[0]), replace=False)
        u = self.problem.to_sampling(jnp.asarray(flat[pick]))
        return np.asarray(jax.vmap(self.problem.predict)(u))

    def to_json(self) -> dict:
        """The contract's ``fit.json`` (plus noise, units and convergence sections)."""
        names = self.model_names
        noise_names = self.problem.noise_names
        out: dict = {
            "terms": list(self.problem.model.terms),
            "n_samples": self.problem.n,
            "point": {k: self.point.value[k] for k in names},
            "point_sd": {k: self.point.sd[k] for k in names},
            "posterior": {},
            "rms_residual_deg_h": self.point.rms_residual_deg_h,
            "units": {k: PARAMETERS[k].unit for k in names},
            "t0_C": self.t0_C,
            "seed": self.seed,
            "noise": {
                "model": self.problem.noise,
                "sigma_from_log": self.problem.sigma is not None,
                "point": {k: self.point.value[k] for k in noise_names},
                "point_sd": {k: self.point.sd[k] for k in noise_names},
                "posterior": {},
                "units": {k: NOISE_UNITS[k] for k in noise_names},
            },
            "priors": {k: _describe(p) for k, p in zip(self.problem.names, self.problem.priors,
                                                         strict=True)},
            "convergence": {
                "point_estimate": self.point.message,
                "point_converged": self.point.converged,
                "starts": self.point.n_starts,
            },
            "warnings": list(self.warnings),
            "input_ranges": input_ranges(self.problem.inputs, self.problem.model),
        }
        if self.posterior is not None:
            post = self.posterior
            out["posterior"] = {k: post.summary[k] for k in names}
            out["noise"]["posterior"] = {k: post.summary[k] for k in noise_names}
            flat = post.draws.reshape(-1, len(self.problem.names))[:, : len(names)]
            corr = np.corrcoef(flat, rowvar=False) if len(names) > 1 else np.ones((1, 1))
            out["posterior_correlation"] = {
                a: {b: float(corr[i, j]) for j, b in enumerate(names)}
                for i, a in enumerate(names)
            }
            out["convergence"]["sampler"] = {
                "move": post.move,
                "walkers": int(post.draws.shape[0]),
                "steps": post.n_steps,
                "burn": post.burn,
                "thin": post.thin,
                "draws_kept": int(post.draws.shape[0] * post.draws.shape[1]),
                "tau_steps": {k: float(t) for k, t in zip(self.problem.names, post.tau_steps,
                                                          strict=True)},
                "acceptance": post.acceptance,
                "converged": post.converged,
            }
        return out


def input_ranges(inputs, model: DriftModel) -> dict[str, list[float]]:
    """The range of every input the model reads, as seen in the fitted log."""
    from gyroid.inputs import FIELD_COLUMNS, H0_UT

    out = {}
    if "temperature_C" in model.columns:
        t = np.asarray(inputs.temperature_C)
        r = np.asarray(inputs.rate_C_h)
        out["temperature_C"] = [float(t.min()), float(t.max())]
        out["dT_dt_C_h"] = [float(r.min()), float(r.max())]
    for k, name in enumerate(FIELD_COLUMNS):
        if name in model.columns:
            h = np.asarray(inputs.field_rel[:, k]) * H0_UT
            out[name] = [float(h.min()), float(h.max())]
    time_h = np.asarray(inputs.time_h)
    out["elapsed_h"] = [float(time_h.min()), float(time_h.max())]
    return out


def _describe(prior: Prior) -> str:
    if isinstance(prior, Normal | LogNormal | Flat):
        return prior.describe()
    return str(prior)


def fit_log(
    log: BenchLog,
    terms: str | tuple[str, ...] | DriftModel,
    *,
    noise: str = "white",
    seed: int = 0,
    priors: Mapping[str, Prior] | None = None,
    flat_prior: bool = False,
    t0_C: float = T0_C,
    sample: bool = True,
    settings: SamplerSettings | None = None,
) -> FitResult:
    """Fit a bench log: point estimate, then (``sample=True``) the emcee posterior."""
    problem = BenchProblem.from_log(
        log, terms, noise=noise, priors=priors, flat_prior=flat_prior, t0_C=t0_C
    )
    point = point_estimate(problem)
    posterior = sample_posterior(problem, point, seed=seed, settings=settings) if sample else None
    result = FitResult(problem=problem, point=point, posterior=posterior, seed=seed, t0_C=t0_C)
    result.warnings.extend(_warnings(result))
    return result


def _warnings(result: FitResult) -> list[str]:
    notes = []
    if not result.point.converged:
        notes.append(f"the point estimate did not converge: {result.point.message}")
    post = result.posterior
    if post is not None:
        for name, s in post.summary.items():
            if s["r_hat"] > 1.01 or s["ess_bulk"] < 400:
                notes.append(
                    f"{name}: r_hat {s['r_hat']:.3f}, ess_bulk {s['ess_bulk']:.0f} "
                    "(wanted <= 1.01 and >= 400): treat its posterior with care"
                )
        for i, prior in enumerate(result.problem.priors[: result.problem.n_model]):
            name = result.problem.names[i]
            if isinstance(prior, Normal):
                ratio = post.summary[name]["sd"] / prior.scale
                if ratio > 0.5:
                    notes.append(
                        f"{name} is barely constrained by this log: its posterior sd is "
                        f"{100 * ratio:.0f} % of the prior's ({prior.describe()})"
                    )
    return notes
