"""Pooling repeated runs (or units) of one gyro type: the population's coefficients, the
run-to-run spread (repeatability), each run's shrunk coefficients and what to expect from
the next run (:mod:`gyroid.inference._pool_problem` for the model).

The result's type and Cochran's Q: :mod:`gyroid.inference._pool_result`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import jax
import jax.numpy as jnp
import numpy as np
from scipy import stats

from gyroid.errors import GyroidInputError
from gyroid.inference._bench_fit import input_ranges, spikes_within_segments
from gyroid.inference._bench_problem import BenchProblem
from gyroid.inference._check_report import CheckReport, FitEvidence
from gyroid.inference._checks import (
    convergence,
    goodness_of_fit,
    identifiability,
    outliers,
    point_vs_posterior,
    prior_data_conflict,
    residual_whiteness,
)
from gyroid.inference._nuts import NutsSettings, sample_nuts
from gyroid.inference._pool_checks import (
    between_run_sd_identified,
    combine_runs,
    population_identified,
    population_prior_conflict,
    run_consistency,
)
from gyroid.inference._pool_problem import PoolProblem
from gyroid.inference._pool_result import PoolResult, heterogeneity
from gyroid.inference._rate_window import choose_rate_window, reads_rate
from gyroid.inference._sampling import Posterior, summarise_draws
from gyroid.io._logs import BenchLog, contiguous_segments
from gyroid.io._logs import segment_means as segment_means_of
from gyroid.models._drift import DriftModel
from gyroid.models._inputs import T0_C
from gyroid.models._prior_scales import reference_sd
from gyroid.models._priors import Flat, Normal, Prior

#: What to do when a run's residuals are correlated: pooling models white noise only.
WHITE_NOISE_REMEDY = ("pooling assumes white noise: fit such runs one by one with 'gyroid "
                      "fit --noise white+gm' (or --segment-means for burst logs), or look "
                      "for a missing effect with gyroid discrepancy")


def pool_priors(problems: Sequence[BenchProblem], logs: Sequence[BenchLog],
                overrides: Mapping[str, Prior] | None = None
                ) -> tuple[list[Prior], np.ndarray, np.ndarray]:
    """Priors of the population means (the widest of the runs' single-fit priors, centred
    where they are), the half-normal scales of the between-run sds (the same width) and the
    identifiability yardstick of each mean (the runs' widest reference sd)."""
    model = problems[0].model
    names = model.parameter_names
    p = len(names)
    references = np.array([[reference_sd(model, q.inputs, np.asarray(log.drift_deg_h))[n]
                            for n in names] for q, log in zip(problems, logs, strict=True)])
    reference = references.max(axis=0)
    priors: list[Prior] = []
    scales = np.empty(p)
    for k in range(p):
        run_priors = [q.priors[k] for q in problems]
        if all(isinstance(pr, Normal) for pr in run_priors):
            widest = max(run_priors, key=lambda pr: pr.scale)
            priors.append(Normal(widest.loc, widest.scale))
            scales[k] = widest.scale
        else:
            priors.append(Flat())
            scales[k] = reference[k]
    for name, prior in (overrides or {}).items():
        if name not in names:
            raise GyroidInputError(f"--prior: no coefficient named {name!r} in this model (it "
                                   f"has {', '.join(names)})")
        if not isinstance(prior, Normal | Flat):
            raise GyroidInputError(f"--prior {name}: a population mean takes normal(MU,SD) "
                                   "or flat()")
        priors[names.index(name)] = prior
        if isinstance(prior, Normal):
            scales[names.index(name)] = prior.scale
    return priors, scales, reference


def _own_estimates(problems: Sequence[BenchProblem]) -> tuple[np.ndarray, np.ndarray]:
    """Each run's least-squares coefficients and their sds (sigma from its residuals when
    the log does not give it); nan sd where the run does not identify a coefficient."""
    means, sds = [], []
    for q in problems:
        gram = np.asarray(q.gram)
        p = gram.shape[0]
        scale = 1.0 if q.sigma is not None else float(q.rss_min) / max(q.n - p, 1)
        if np.linalg.matrix_rank(gram) < p:
            inverse = np.linalg.pinv(gram)
            unidentified = np.abs(np.diag(gram @ inverse) - 1.0) > 1e-6
        else:
            inverse, unidentified = np.linalg.inv(gram), np.zeros(p, bool)
        sd = np.sqrt(np.clip(np.diag(inverse) * scale, 0.0, None))
        means.append(np.where(unidentified, np.nan, np.asarray(q.solution)))
        sds.append(np.where(unidentified, np.nan, sd))
    return np.array(means), np.array(sds)


def fit_pool(
    logs: Sequence[BenchLog],
    labels: Sequence[str],
    terms: str | tuple[str, ...] | DriftModel,
    *,
    seed: int = 0,
    prior_set: str = "default",
    priors: Mapping[str, Prior] | None = None,
    spread_scales: Mapping[str, float] | None = None,
    t0_C: float = T0_C,
    settings: NutsSettings | None = None,
    segment_means: bool = False,
) -> PoolResult:
    """Pool ``logs`` (one per run or unit, named by ``labels``) under one drift model.
    ``priors`` overrides population means' priors by name, ``spread_scales`` the
    half-normal scales of between-run sds (default: the mean's prior scale).
    ``segment_means=True`` pools burst logs on one row per burst (as ``fit_log`` does), the
    samples still checked for spikes."""
    if len(logs) < 2:
        raise GyroidInputError("pooling needs at least two logs (runs or units of one gyro "
                               "type); for one log use 'gyroid fit'")
    if len(set(labels)) != len(labels):
        raise GyroidInputError("two runs have the same name; give logs with distinct names")
    model = terms if isinstance(terms, DriftModel) else DriftModel.from_terms(terms)
    if not model.is_linear:
        nonlinear = [e.name for e in model.effects if not e.linear]
        raise GyroidInputError(
            f"pooling takes effects linear in their coefficients; {', '.join(nonlinear)} "
            "has a time constant or time of its own: fit those runs one by one with "
            "'gyroid fit', or pool without it")
    samples = list(logs)
    spikes: list[tuple[np.ndarray, float] | None] = [None] * len(logs)
    if segment_means:
        logs = list(logs)
        for i, log in enumerate(samples):
            logs[i], deviations, within = segment_means_of(
                log, contiguous_segments(np.asarray(log.time_s)))
            spikes[i] = (deviations, within)
    problems, windows = [], []
    for log in logs:
        window = choose_rate_window(log, model, t0_C=t0_C)[0] if reads_rate(model) else None
        problem = BenchProblem.from_log(log, model, noise="white", prior_set=prior_set,
                                        t0_C=t0_C, **({} if window is None else
                                                      {"rate_window_s": window}))
        problems.append(problem)
        windows.append(float(problem.rate_window_s))
    mean_priors, scales, reference = pool_priors(problems, logs, priors)
    for name, scale in (spread_scales or {}).items():
        if name not in model.parameter_names or not scale > 0:
            raise GyroidInputError(f"between-run sd scale of {name!r}: give a positive "
                                   f"scale for one of {', '.join(model.parameter_names)}")
        scales[model.parameter_names.index(name)] = scale
    p = len(model.parameter_names)
    problem = PoolProblem.from_statistics(
        model.parameter_names, tuple(labels),
        gram=np.stack([np.asarray(q.gram) for q in problems]),
        solution=np.stack([np.asarray(q.solution) for q in problems]),
        rss=[float(q.rss_min) for q in problems], n_rows=[q.n for q in problems],
        log_sigma_sum=[float(q.log_sigma_sum) for q in problems],
        sigma_known=[q.sigma is not None for q in problems],
        mean_priors=mean_priors, spread_scales=scales,
        noise_priors=[q.priors[p] if q.sigma is None else None for q in problems])
    own_mean, own_sd = _own_estimates(problems)
    ranges = [input_ranges(q.inputs, model) for q in problems]
    result = _sample_pool(problem, own_mean, own_sd, terms=tuple(model.terms), seed=seed,
                          settings=settings)
    result.n_samples = tuple(q.n for q in problems)
    result.t0_C = t0_C
    result.rate_window_s = tuple(windows)
    result.input_ranges = {k: [min(r[k][0] for r in ranges), max(r[k][1] for r in ranges)]
                           for k in ranges[0]}
    result.checks = pool_checks(result, reference, problems, logs)
    if segment_means:
        result.checks = result.checks + combine_runs({
            label: CheckReport((spikes_within_segments(
                sample, deviations, within, n_means=q.n,
                sigma_of_means=math.sqrt(float(q.rss_min) / max(q.n - q.n_model, 1))),))
            for label, sample, q, (deviations, within) in zip(labels, samples, problems,
                                                               spikes, strict=True)})
    result.segment_means = segment_means
    return result


def pool_estimates(names: tuple[str, ...], labels: tuple[str, ...], estimates: np.ndarray,
                   sds: np.ndarray, *, mean_priors: Sequence[Prior],
                   spread_scales: np.ndarray, seed: int = 0,
                   settings: NutsSettings | None = None) -> PoolResult:
    """Pool published per-run estimates (R, p) with independent per-coefficient sds (R, p),
    e.g. a paper's table with an assumed within-run sd; the residual checks do not apply."""
    sds = np.asarray(sds, dtype=float)
    covariances = np.stack([np.diag(s**2) for s in sds])
    problem = PoolProblem.from_estimates(names, labels, np.asarray(estimates, dtype=float),
                                         covariances, mean_priors=mean_priors,
                                         spread_scales=spread_scales)
    result = _sample_pool(problem, np.asarray(estimates, dtype=float), sds, terms=(),
                          seed=seed, settings=settings)
    result.n_samples = (0,) * len(labels)
    result.rate_window_s = (float("nan"),) * len(labels)
    result.checks = pool_checks(result, np.asarray(spread_scales, dtype=float))
    return result


def _sample_pool(problem: PoolProblem, own_mean: np.ndarray, own_sd: np.ndarray, *,
                 terms: tuple[str, ...], seed: int, settings: NutsSettings | None
                 ) -> PoolResult:
    """Mode, NUTS posterior of the between-run sds and noise levels, and derived draws."""
    point = problem.mode()
    posterior = sample_nuts(problem, point, seed=seed, settings=settings)
    mean_draws, run_draws, new_draws, run_log_lik = derived_draws(problem, posterior,
                                                                  seed=seed)
    names = problem.coefficient_names
    return PoolResult(
        problem=problem, point=point, posterior=posterior, terms=terms,
        own_mean=own_mean, own_sd=own_sd, mean_draws=mean_draws, run_draws=run_draws,
        new_run_draws=new_draws, run_log_likelihood=run_log_lik,
        summary=summarise_draws(mean_draws, names) | posterior.summary,
        heterogeneity=heterogeneity(names, own_mean, own_sd), seed=seed)


def derived_draws(problem: PoolProblem, posterior: Posterior, *, seed: int):
    """Per posterior draw of the between-run sds and noise levels: the population means
    from their exact conditional, every run's coefficients from theirs, a new run's from
    the population, and each run's log-likelihood. Returns (chains, draws, p), (M, R, p),
    (M, p), (chains, draws, R)."""
    chains, draws, d = posterior.draws.shape
    u = np.log(posterior.draws.reshape(-1, d))
    rng = np.random.default_rng([seed, 1])
    p, r = problem.n_model, problem.n_runs
    z_mean = rng.standard_normal((u.shape[0], p))
    z_runs = rng.standard_normal((u.shape[0], r, p))
    z_new = rng.standard_normal((u.shape[0], p))
    mean, runs, log_lik, _ = _conditional_draws(problem.density, jnp.asarray(u),
                                                jnp.asarray(z_mean), jnp.asarray(z_runs))
    mean = np.asarray(mean)
    new = mean + np.exp(u[:, :p]) * z_new
    return (mean.reshape(chains, draws, p), np.asarray(runs), new,
            np.asarray(log_lik).reshape(chains, draws, r))


@jax.jit
def _conditional_draws(density, u, z_mean, z_runs):
    # A loop over draws (lax.map), each batched over runs only: the same draws vmapped over
    # thousands of draws at once sometimes never returned on XLA's CPU runtime (jax 0.10.2;
    # idle threads, a lost wake-up; 30 runs x 1000 draws hung where 30 x 2000 did not).
    def one(args):
        u, z_mean, z_runs = args
        mu = density.mean_conditional(u, z_mean)
        return (mu, density.run_coefficients(mu, u, z_runs), density.run_log_likelihood(mu, u),
                density.run_consistency(mu, u))

    return jax.lax.map(one, (u, z_mean, z_runs))


def leave_one_run_out(result: PoolResult) -> np.ndarray:
    """Per run, the probability that a run of the population fitted WITHOUT it lies as far
    from that population's mean as it does: ``d' (A_r^-1 + T + C)^-1 d`` against chi-square
    (rank of A_r degrees of freedom), ``d`` the run's own estimate minus the others' mean,
    ``C`` that mean's covariance, ``T`` the others' between-run variances at their mode
    widened by one sd of log tau (so that the few runs of a small lot, whose spread is
    uncertain, do not raise false alarms). Left in, an outlying run inflates the spread
    and hides: a run 50 spreads away scored p = 0.51 against the full posterior."""
    problem = result.problem
    p = problem.n_model
    own = np.asarray(problem.density.offset) + np.asarray(problem.density.centre)
    p_values = []
    for r in range(problem.n_runs):
        others = problem.without_run(r)
        mode = others.mode()
        q, b, *_ = others.density._mean_information(jnp.asarray(mode.u))
        q = np.asarray(q)
        mean = np.asarray(others.density.centre) + np.linalg.solve(q, np.asarray(b))
        sd_log_tau = np.sqrt(np.clip(np.diag(mode.covariance_u)[:p], 0.0, None))
        tau = np.exp(mode.u[:p] + sd_log_tau)
        gram = np.asarray(problem.density.gram[r])
        if r in problem.noisy_runs:
            sigma2 = float(problem.density.rss[r]) / max(
                float(problem.density.n_rows[r]) - problem.ranks[r], 1.0)
            gram = gram / sigma2
        a_inverse = np.linalg.pinv(gram)
        d = own[r] - mean
        cov = a_inverse + np.diag(tau**2) + np.linalg.inv(q)
        statistic = float(d @ np.linalg.solve(cov, d))
        p_values.append(float(stats.chi2.sf(statistic, max(problem.ranks[r], 1))))
    return np.array(p_values)


def pool_checks(result: PoolResult, reference: np.ndarray,
                problems: Sequence[BenchProblem] = (), logs: Sequence[BenchLog] = ()
                ) -> CheckReport:
    """The population's checks, every run's residual checks (when the runs' logs are
    given), and the lot's own two. ``reference``: each population mean's yardstick for
    identifiability."""
    problem, posterior = result.problem, result.posterior
    p = problem.n_model
    names = problem.coefficient_names + problem.names
    sampled_u = np.log(posterior.draws)
    draws_u = np.concatenate([result.mean_draws, sampled_u], axis=-1)
    mean_at_mode = np.asarray(problem.density.mean_conditional(
        jnp.asarray(result.point.u), jnp.zeros(p)))
    evidence = FitEvidence(
        names=names, n_model=p, point_u=np.concatenate([mean_at_mode, result.point.u]),
        point_converged=result.point.converged, point_message=result.point.message,
        priors=problem.mean_priors + problem.priors,
        reference_sd=dict(zip(problem.coefficient_names, map(float, reference), strict=True)),
        residuals=None, sigma_given=False, noise="white", draws_u=draws_u,
        summary=result.summary)
    population = CheckReport((convergence(evidence), point_vs_posterior(evidence),
                              population_prior_conflict(
                                  prior_data_conflict(evidence), problem.coefficient_names,
                                  result.mean_draws.reshape(-1, p).mean(axis=0),
                                  problem.mean_priors),
                              population_identified(identifiability(evidence), {
                                  n: float(np.nanmedian(result.own_sd[:, k]) / reference[k])
                                  if np.isfinite(result.own_sd[:, k]).any() else np.inf
                                  for k, n in enumerate(problem.coefficient_names)})))
    u_mean = sampled_u.reshape(-1, len(problem.names)).mean(axis=0)
    pooled_mean = result.run_draws.mean(axis=0)
    per_run = {}
    for r, (q, log) in enumerate(zip(problems, logs, strict=True)):
        label = problem.run_labels[r]
        noise = []
        if r in problem.noisy_runs:
            noise = [u_mean[p + problem.noisy_runs.index(r)]]
        u_run = jnp.asarray(np.concatenate([pooled_mean[r], noise]))
        z = np.asarray(q.standardised_residuals(u_run))
        segments = tuple(contiguous_segments(np.asarray(log.time_s)))
        run_evidence = FitEvidence(names=q.names, n_model=q.n_model,
                                   point_u=np.asarray(u_run), point_converged=True,
                                   point_message="", priors=q.priors, reference_sd={},
                                   residuals=z, sigma_given=q.sigma is not None, noise="white")
        per_run[label] = CheckReport((
            goodness_of_fit(run_evidence),
            residual_whiteness(z, segments=segments, remedy=WHITE_NOISE_REMEDY),
            outliers(z, where=log.where)))
    tau = posterior.draws.reshape(-1, len(problem.names))[:, :p]
    lot = CheckReport((
        run_consistency(leave_one_run_out(result), problem.run_labels),
        between_run_sd_identified(problem.coefficient_names, tau, problem.n_runs),
    ))
    return population + combine_runs(per_run) + lot
