"""Fitting a bench log: point estimate (optimistix), posterior (emcee), summary (ArviZ)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import jax.numpy as jnp
import numpy as np

from gyroid.inference._batching import problem_batcher
from gyroid.inference._bench_problem import NOISE_UNITS, BenchProblem
from gyroid.inference._checks import Check, CheckReport, FitEvidence, fit_checks, outliers
from gyroid.inference._point import PointEstimate, point_estimate
from gyroid.inference._rate_window import choose_rate_window, reads_rate
from gyroid.inference._sampling import Posterior, SamplerSettings, sample_posterior
from gyroid.io._logs import BenchLog, contiguous_segments
from gyroid.io._logs import segment_means as segment_means_of
from gyroid.models._design import rows_of
from gyroid.models._drift import DriftModel
from gyroid.models._effects import parameter
from gyroid.models._inputs import T0_C
from gyroid.models._prior_scales import (
    PriorBasis,
    default_priors,
    identifiability_hints,
    reference_sd,
)
from gyroid.models._priors import Flat, LogNormal, Normal, Prior


@dataclass
class FitResult:
    """A fitted bench log: the problem, its point estimate and (optionally) its posterior."""

    problem: BenchProblem
    point: PointEstimate
    posterior: Posterior | None
    seed: int
    t0_C: float
    prior_set: str = "default"
    prior_basis: PriorBasis | None = None
    rate_window_choice: str = "given"
    checks: CheckReport = field(default_factory=lambda: CheckReport(()))
    #: When the log's bursts were averaged first: {"segments": K, "rows": n}.
    segment_means: dict | None = None
    #: The log the model was fitted to (the segment means when they were fitted).
    fitted_log: BenchLog | None = field(default=None, repr=False)

    @property
    def trustworthy(self) -> bool:
        return self.checks.trustworthy

    @property
    def model_names(self) -> tuple[str, ...]:
        return self.problem.model.parameter_names

    def predict_draws(self, n_draws: int = 200, seed: int = 0, every: int = 1) -> np.ndarray:
        """Modelled drift (deg/h) for ``n_draws`` posterior draws at every ``every``-th row:
        (n_draws, ceil(n / every)). A linear model is its design matrix's rows times the
        draws at the rows kept; otherwise the model runs over the whole log for a few draws at a
        time (memory O(n))."""
        if self.posterior is None:
            return np.asarray(self.problem.predict(jnp.asarray(self.point.u)))[None, ::every]
        flat = self.posterior.draws.reshape(-1, len(self.problem.names))
        rng = np.random.default_rng(seed)
        pick = rng.choice(flat.shape[0], size=min(n_draws, flat.shape[0]), replace=False)
        model = self.problem.model
        if model.is_linear:
            design = np.asarray(model.design(rows_of(self.problem.inputs, slice(None, None,
                                                                          every))))
            return flat[pick, : self.problem.n_model] @ design.T
        u = np.asarray(self.problem.to_sampling(jnp.asarray(flat[pick])))
        predict = problem_batcher(self.problem, "predict")
        chunk = int(np.clip(2e6 // max(self.problem.n, 1), 1, 64))
        return np.concatenate([np.asarray(predict(u[start:start + chunk]))[:, ::every]
                               for start in range(0, u.shape[0], chunk)])

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
            "units": {k: parameter(k).unit for k in names},
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
            "prior_set": self.prior_set,
            "prior_basis": None if self.prior_basis is None else self.prior_basis.to_json(),
            "rate_window_s": self.problem.rate_window_s,
            "rate_window_choice": self.rate_window_choice,
            "segment_means": self.segment_means,
            "convergence": {
                "point_estimate": self.point.message,
                "point_converged": self.point.converged,
                "starts": self.point.n_starts,
            },
            **self.checks.to_json(),
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
    from gyroid.models._inputs import FIELD_COLUMNS, H0_UT

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
    prior_set: str = "default",
    flat_prior: bool = False,
    t0_C: float = T0_C,
    rate_window_s: float | None = None,
    sample: bool = True,
    settings: SamplerSettings | None = None,
    segment_means: bool = False,
) -> FitResult:
    """Fit a bench log: point estimate, then (``sample=True``) the emcee posterior, then
    the self-checks. ``rate_window_s=None`` chooses the rate estimator's window from the
    data (:mod:`gyroid.inference._rate_window`). ``segment_means=True`` fits one row per contiguous
    segment of a burst-sampled log (its mean), so that the bias's wander between bursts is
    the noise the model estimates rather than a correlation it ignores; the samples are
    still checked for spikes, which the means would hide."""
    samples = log
    if segment_means:
        log, deviations, within_sd = segment_means_of(
            log, contiguous_segments(np.asarray(log.time_s)))
    model = terms if isinstance(terms, DriftModel) else DriftModel.from_terms(terms)
    if rate_window_s is None:
        rate_window_s, _ = choose_rate_window(log, model, t0_C=t0_C)
        window_choice = "auto" if reads_rate(model) else "default (the model reads no dT/dt)"
    else:
        window_choice = "given"
    chosen_set = "flat" if flat_prior else prior_set
    problem = BenchProblem.from_log(log, model, noise=noise, priors=priors, prior_set=chosen_set,
                                    t0_C=t0_C, rate_window_s=rate_window_s)
    point = point_estimate(problem)
    posterior = sample_posterior(problem, point, seed=seed, settings=settings) if sample else None
    _, basis = default_priors(model, problem.inputs, np.asarray(log.drift_deg_h))
    result = FitResult(problem=problem, point=point, posterior=posterior, seed=seed, t0_C=t0_C,
                       prior_set=chosen_set, prior_basis=basis,
                       rate_window_choice=window_choice,
                       segment_means={"segments": log.n, "rows": samples.n}
                       if segment_means else None, fitted_log=log)
    result.checks = fit_checks(bench_evidence(result, log))
    if segment_means:
        sigma = result.point.value.get("sigma_deg_h", within_sd)
        result.checks = result.checks + CheckReport((spikes_within_segments(
            samples, deviations, within_sd, sigma_of_means=sigma, n_means=log.n),))
    return result


def spikes_within_segments(samples: BenchLog, deviations: np.ndarray, within_sd: float, *,
                           sigma_of_means: float, n_means: int) -> Check:
    """The spike check of a fit of segment means, on the samples about their segment's
    mean (``deviations``, over ``within_sd``). A spike shifts the bias by its deviation / n;
    that is judged against the fit's sd of the bias (about ``sigma_of_means / sqrt(K)`` of
    the K means), not the samples' ``s / sqrt(n)``."""
    ratio = (sigma_of_means / math.sqrt(n_means)) / (within_sd / math.sqrt(samples.n))
    return outliers(deviations, where=samples.where, name="outliers_within_segments",
                    bias_sd_ratio=max(ratio, 1e-12))


def bench_evidence(result: FitResult, log: BenchLog) -> FitEvidence:
    """What the self-checks need from a bench fit."""
    problem, point, post = result.problem, result.point, result.posterior
    model, inputs = problem.model, problem.inputs
    draws_u = None
    if post is not None:
        draws_u = np.asarray(problem.to_sampling(jnp.asarray(post.draws)))
    return FitEvidence(
        names=problem.names,
        n_model=problem.n_model,
        point_u=np.asarray(point.u),
        point_converged=point.converged,
        point_message=point.message,
        priors=problem.priors,
        reference_sd=reference_sd(model, inputs, np.asarray(log.drift_deg_h)),
        residuals=np.asarray(problem.standardised_residuals(jnp.asarray(point.u))),
        sigma_given=problem.sigma is not None,
        noise=problem.noise,
        draws_u=draws_u,
        summary=None if post is None else post.summary,
        hints=identifiability_hints(model, inputs),
        segments=tuple(contiguous_segments(np.asarray(log.time_s))),
        where=log.where,
    )
