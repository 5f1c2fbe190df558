"""Pooling repeated runs (or units) of one gyro type: the population's coefficients, the
run-to-run spread (repeatability), each run's shrunk coefficients and what to expect from
the next run. The model is :mod:`gyroid.pool._problem`; the result
:mod:`gyroid.pool._result`; the checks :mod:`gyroid.pool._checks`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np

from gyroid.bench._fit import fit_log
from gyroid.bench._options import BenchOptions
from gyroid.bench._problem import BenchProblem
from gyroid.bench._result import BenchFit
from gyroid.errors import GyroidInputError
from gyroid.inference._check_report import CheckReport
from gyroid.inference._fit import fit
from gyroid.inference._problem import AbstractSampler
from gyroid.io._logs import BenchLog
from gyroid.models._drift import DriftModel
from gyroid.models._prior_scales import reference_sd
from gyroid.models._priors import Flat, Normal, Prior
from gyroid.pool._problem import PoolProblem
from gyroid.pool._result import PoolFit


def pool_priors(problems: Sequence[BenchProblem],
                overrides: Mapping[str, Prior] | None = None
                ) -> tuple[list[Prior], np.ndarray, np.ndarray]:
    """Priors of the population means (the widest of the runs' single-fit priors, centred
    where they are), the half-normal scales of the between-run sds (the same width) and the
    identifiability yardstick of each mean (the runs' widest reference sd)."""
    model = problems[0].model
    names = model.parameter_names
    p = len(names)
    references = np.array([[reference_sd(model, q.inputs, np.asarray(q.log.drift_deg_h))[n]
                            for n in names] for q in problems])
    reference = references.max(axis=0)
    priors: list[Prior] = []
    scales = np.empty(p)
    for k in range(p):
        normal = [pr for q in problems if isinstance(pr := q.priors[k], Normal)]
        if len(normal) == len(problems):
            widest = max(normal, key=lambda pr: pr.scale)
            priors.append(Normal(widest.loc, widest.scale))
            scales[k] = widest.scale
        else:
            priors.append(Flat())
            scales[k] = reference[k]
    for name, prior in (overrides or {}).items():  # checked by _check_options
        priors[names.index(name)] = prior
        if isinstance(prior, Normal):
            scales[names.index(name)] = prior.scale
    return priors, scales, reference


def pool_problem(
    logs: Sequence[BenchLog],
    labels: Sequence[str],
    terms: str | tuple[str, ...] | DriftModel,
    options: BenchOptions | None = None,
    *,
    priors: Mapping[str, Prior] | None = None,
    spread_scales: Mapping[str, float] | None = None,
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
) -> PoolProblem:
    """The pooled problem of ``logs`` (one per run or unit, named by ``labels``) under one
    drift model, each run fitted on its own under ``options`` (:class:`BenchOptions`, a single
    fit's; None: every default) by :func:`~gyroid.bench.fit_log`, seeds ``seed``,
    ``seed + 1``, ... ``priors`` overrides the population means' priors by name,
    ``spread_scales`` the half-normal scales of between-run sds (default: the mean's prior
    scale). With the options' ``segment_means`` burst logs are pooled on one row per burst
    (as a single fit does), the samples still checked for spikes.

    Each run's coefficients' posterior mean and covariance are one Gaussian observation of
    them (:func:`pooled_fits`): the run-to-run test then weighs each run by what its own
    noise leaves known. Under the default noise model (``auto``, IEEE 952's white + flicker
    + rate random walk) that includes the flicker and walk a run's whiteness check cannot
    see at hours; ``white`` is right only where each run's noise is white at the scales
    that decide its coefficients: of 10 lots of three 10 h FOG runs with identical
    coefficients it trusted 5, each saying the runs differ at p < 0.01
    (``experiments/pool_fog_lots.py``). ``progress`` hears of each run fitted."""
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
    names = model.parameter_names
    _check_options(names, priors, spread_scales)  # before any run is fitted
    options = options or BenchOptions()
    fits = tuple(_run_fits(logs, labels, model, options, seed=seed, progress=progress))
    mean_priors, scales, reference = pool_priors([f.problem for f in fits], priors)
    for name, scale in (spread_scales or {}).items():
        scales[names.index(name)] = scale
    return pooled_fits(fits, labels, model, options, mean_priors=mean_priors,
                       spread_scales=scales, reference=reference)


def _check_options(names: tuple[str, ...], priors: Mapping[str, Prior] | None,
                   spread_scales: Mapping[str, float] | None) -> None:
    """One clear error for a population mean's prior or a between-run sd scale given for a
    coefficient the model does not have, a scale that is not positive, or a mean's prior
    that is neither normal nor flat."""
    for name, scale in (spread_scales or {}).items():
        if name not in names or not scale > 0:
            raise GyroidInputError(f"between-run sd scale of {name!r}: give a positive "
                                   f"scale for one of {', '.join(names)}")
    unknown = sorted(set(priors or {}) - set(names))
    if unknown:
        raise GyroidInputError(f"--prior: no coefficient named {unknown[0]!r} in this model "
                               f"(it has {', '.join(names)})")
    for name, prior in (priors or {}).items():
        if not isinstance(prior, Normal | Flat):
            raise GyroidInputError(f"--prior {name}: a population mean takes normal(MU,SD) "
                                   "or flat()")


def fit_pool(logs: Sequence[BenchLog], labels: Sequence[str],
             terms: str | tuple[str, ...] | DriftModel, options: BenchOptions | None = None,
             *, priors: Mapping[str, Prior] | None = None,
             spread_scales: Mapping[str, float] | None = None, seed: int = 0,
             sampler: AbstractSampler | None = None,
             progress: Callable[[str], None] | None = None) -> PoolFit:
    """Pool ``logs`` (:func:`pool_problem`: each run fitted under ``options``, the
    population means' ``priors``, the between-run sds' ``spread_scales``) and fit them: the
    mode, NUTS (or ``sampler``), derived draws, the checks."""
    problem = pool_problem(logs, labels, terms, options, priors=priors,
                           spread_scales=spread_scales, seed=seed, progress=progress)
    return fit(problem, sampler=sampler, seed=seed)


#: A run's own checks that a pooled fit of the runs' posteriors keeps: those of its
#: residuals and noise (a single run need not identify every coefficient the lot does), and
#: how far its intervals rest on the noise levels' priors (the pool's rest on them too).
RUN_RESIDUAL_CHECKS = frozenset({"goodness_of_fit", "residual_whiteness", "outliers",
                                 "predictive", "outliers_within_segments",
                                 "noise_prior_dependence"})


def _run_fits(logs: Sequence[BenchLog], labels: Sequence[str], model: DriftModel,
              options: BenchOptions, *, seed: int,
              progress: Callable[[str], None] | None):
    """Each log fitted on its own under ``options`` (seeds ``seed``, ``seed + 1``, ...)."""
    for k, log in enumerate(logs):
        single = fit_log(log, model, options, seed=seed + k, progress=False)
        if progress is not None:
            progress(f"  {labels[k]} fitted ({k + 1} of {len(logs)})")
        yield single


def pooled_fits(fits: Sequence[BenchFit], labels: Sequence[str], model: DriftModel,
                options: BenchOptions, *, mean_priors, spread_scales: np.ndarray,
                reference: np.ndarray) -> PoolProblem:
    """Each run's own fit under ``options`` (:func:`_run_fits`): its coefficients'
    posterior mean and covariance taken as one Gaussian observation of its run's
    coefficients (their weakly informative single-fit priors counted once more:
    negligible where the run identifies a coefficient; under white noise the Gaussian
    stands for a Student t of as many degrees of freedom as rows, less the coefficients),
    pooled by
    :meth:`PoolProblem.from_estimates`; each run's residual and noise checks kept, and its
    fitted problem as the run's description."""
    p = len(model.parameter_names)
    noise = options.noise_model
    means, covariances, reports, levels = [], [], [], []
    for single in fits:
        posterior = single.posterior
        if posterior is None:
            raise ValueError(f"{single.problem.log.source}: a run's fit under {noise.name} "
                             "gave no posterior")
        draws = posterior.draws.reshape(-1, len(posterior.names))[:, :p]
        means.append(draws.mean(axis=0))
        covariances.append(np.atleast_2d(np.cov(draws.T)))
        reports.append(CheckReport(tuple(c for c in single.checks.checks
                                         if c.name in RUN_RESIDUAL_CHECKS)))
        levels.append(single.noise_estimate())
    means, covariances = np.array(means), np.array(covariances)
    sds = np.sqrt(np.diagonal(covariances, axis1=1, axis2=2))
    return PoolProblem.from_estimates(
        model.parameter_names, tuple(labels), means, covariances, mean_priors=mean_priors,
        spread_scales=spread_scales, terms=tuple(model.terms), t0_C=options.t0_C,
        own_mean=means, own_sd=sds, reference=reference,
        runs=tuple(f.problem for f in fits), run_reports=tuple(reports),
        run_noise=noise.name, run_noise_levels=tuple(levels),
        segment_means=options.segment_means)


def pool_estimates(names: tuple[str, ...], labels: tuple[str, ...], estimates: np.ndarray,
                   sds: np.ndarray, *, mean_priors: Sequence[Prior],
                   spread_scales: np.ndarray, seed: int = 0,
                   sampler: AbstractSampler | None = None) -> PoolFit:
    """Pool published per-run estimates (R, p) with independent per-coefficient sds (R, p),
    e.g. a paper's table with an assumed within-run sd; the residual checks do not apply."""
    sds = np.asarray(sds, dtype=float)
    estimates = np.asarray(estimates, dtype=float)
    covariances = np.stack([np.diag(s**2) for s in sds])
    problem = PoolProblem.from_estimates(
        names, labels, estimates, covariances, mean_priors=mean_priors,
        spread_scales=spread_scales, own_mean=estimates, own_sd=sds,
        reference=np.asarray(spread_scales, dtype=float))
    return fit(problem, sampler=sampler, seed=seed)
