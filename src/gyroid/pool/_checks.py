"""Self-checks of a pooled fit: the single-fit checks (:mod:`gyroid.inference._checks`)
applied to the population and to every run, and two that only a lot has.

* Every run's residual and noise checks are its own fit's (goodness of fit, whiteness,
  outliers, the predictive check, how far its intervals rest on its noise levels' priors);
  a kind of check fails when any run fails it, and its message names the runs
  (:func:`combine_runs`).
* ``run_consistency``: run r's own estimate against the population fitted without it:
  ``d' (A_r^-1 + T)^-1 d`` (``d`` its own estimate minus the population mean)
  is chi-square with (rank of A_r) degrees of freedom when the run belongs to the
  population (the others' mode, their spread widened by one sd of its log:
  :func:`leave_one_run_out`). Left in, an outlying run inflates
  the spread and hides (seen: a run 50 spreads away scored p = 0.51 against the full
  posterior). A p-value below
  ``RUN_CONSISTENCY_P`` / (number of runs) is an error: a unit or test that does not belong
  to the lot (a different type, a broken setup) distorts the population mean and spread,
  so name it and refit without it.
* ``between_run_sd_identified``: a between-run sd whose log has a posterior sd above
  ``LOG_SPREAD_SD`` is known no better than a factor 2.7 either way: a warning (the
  intervals carry that uncertainty honestly, but more runs would narrow them).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import jax.numpy as jnp
import numpy as np
from scipy import stats

from gyroid._exported import exported
from gyroid.inference._check_report import Check, CheckReport, FitEvidence
from gyroid.inference._checks import (
    PRIOR_TAIL_SD,
    convergence,
    identifiability,
    point_vs_posterior,
    prior_data_conflict,
)
from gyroid.inference._posterior import Posterior
from gyroid.inference._problem import PointEstimate
from gyroid.models._priors import Normal

if TYPE_CHECKING:
    from gyroid.pool._problem import PoolProblem

#: Family-wise false-alarm rate of the run-consistency check under the population model.
RUN_CONSISTENCY_P = 1e-3
#: Posterior sd of log(between-run sd) above which the runs do not pin it down.
LOG_SPREAD_SD = 0.5
#: At most this many runs named in one message.
NAMED_RUNS = 3


def combine_runs(per_run: Mapping[str, CheckReport]) -> CheckReport:
    """One check per kind across runs: failed when any run failed it (the worst severity
    and value), its message naming the runs that failed, with their remedies."""
    kinds: dict[str, list[tuple[str, Check]]] = {}
    for label, report in per_run.items():
        for check in report.checks:
            kinds.setdefault(check.name, []).append((label, check))
    combined = []
    for name, items in kinds.items():
        failed = [(label, c) for label, c in items if not c.passed]
        values = [c.value for _, c in (failed or items) if c.value is not None]
        value = float(max(values, key=abs)) if values else None
        threshold = items[0][1].threshold
        if not failed:
            combined.append(Check(name, True, items[0][1].severity, value, threshold,
                                  f"every run: {items[0][1].message}" if len(items) == 1 else
                                  f"passed in all {len(items)} runs"))
            continue
        severity = "error" if any(c.severity == "error" for _, c in failed) else "warning"
        named = "; ".join(f"run {label}: {c.message}" for label, c in failed[:NAMED_RUNS])
        more = f"; and {len(failed) - NAMED_RUNS} more run(s)" if len(failed) > NAMED_RUNS else ""
        remedies = tuple(dict.fromkeys(code for _, c in failed for code in c.remedies))
        combined.append(Check(name, False, severity, value, threshold,
                              f"{len(failed)} of {len(items)} runs fail: {named}{more}",
                              remedies))
    return CheckReport(tuple(combined))


def population_identified(check: Check, run_sd_ratio: dict[str, float]) -> Check:
    """The identifiability check read for a lot: a population mean that the runs do not
    pin down is an error when the runs themselves do not identify the coefficient (their
    median own sd above half the reference scale: no run exercises it), else a warning
    (the runs scatter widely for their number; its interval says so honestly)."""
    if check.passed or check.value is None:
        return check
    unexercised = [n for n, r in run_sd_ratio.items() if not np.isfinite(r) or r > 0.5]
    if unexercised:
        return Check(check.name, False, "error", check.value, check.threshold,
                     f"no run identifies {', '.join(unexercised)} on its own (its regressor "
                     "hardly varies in them): use runs that exercise it, or drop its term")
    return Check(check.name, False, "warning", check.value, check.threshold,
                 f"the runs do not pin down a population mean (posterior sd up to "
                 f"{100 * check.value:.0f} % of its reference scale): they scatter widely "
                 "for their number; pool more runs to narrow it")


def population_prior_conflict(check: Check, names: tuple[str, ...], mean: np.ndarray,
                              priors: tuple) -> Check:
    """The prior-conflict check read for a lot. With few runs a population mean's prior
    legitimately informs it (the runs' spread leaves its posterior wide), so a prior that
    pulls the posterior is a warning; it is an error only when the posterior sits more than
    ``PRIOR_TAIL_SD`` prior sds from the prior's centre (the lot contradicts the prior). In
    the calibration study (truth drawn from the priors) the single-fit reading had called
    4 of 40 lots of three runs untrustworthy."""
    if check.passed or check.severity == "warning":
        return check
    tails = {n: abs(m - pr.loc) / pr.scale for n, m, pr in zip(names, mean, priors,
                                                                strict=True)
             if isinstance(pr, Normal)}
    far = [n for n, t in tails.items() if t > PRIOR_TAIL_SD]
    if far:
        return Check(check.name, False, "error", check.value, check.threshold,
                     f"the population mean of {', '.join(far)} sits more than "
                     f"{PRIOR_TAIL_SD:g} prior sd from its prior's centre: {check.message}")
    return Check(check.name, False, "warning", check.value, check.threshold,
                 f"the priors inform the population means, as with few runs they must "
                 f"(largest pull {check.value:.1f} posterior sd); widen them with --prior "
                 "NAME=normal(MU,SD) where that is not meant")


def run_consistency(p_values: np.ndarray, labels: tuple[str, ...]) -> Check:
    """Each run against the population fitted without it (see the module docstring)."""
    p_values = np.asarray(p_values, dtype=float)
    threshold = RUN_CONSISTENCY_P / len(labels)
    worst = int(np.argmin(p_values))
    outliers = [labels[i] for i in np.flatnonzero(p_values < threshold)]
    if not outliers:
        return Check("run_consistency", True, "error", float(p_values[worst]), threshold,
                     f"every run is consistent with the population of the others (smallest "
                     f"p = {p_values[worst]:.2g}, run {labels[worst]})")
    return Check("run_consistency", False, "error", float(p_values[worst]), threshold,
                 f"run(s) {', '.join(outliers[:NAMED_RUNS])} do not belong to the population "
                 f"of the others (p = {p_values[worst]:.1e}): a different unit type or a faulty "
                 "test moves the population mean and spread; inspect them and pool without "
                 "them")


def between_run_sd_identified(names: tuple[str, ...], tau_draws: np.ndarray,
                              n_runs: int) -> Check:
    """Whether the runs pin down each between-run sd: the posterior sd of its log above
    ``LOG_SPREAD_SD`` means it is known no better than a factor exp(2 x 0.5) = 2.7 either
    way (about what three runs give: the sd of log s from R normal draws is near
    1 / sqrt(2 (R - 1)))."""
    tau = np.asarray(tau_draws, dtype=float)
    sd_log = np.log(tau).std(axis=0, ddof=1)
    worst = int(np.argmax(sd_log))
    lo, hi = np.percentile(tau[:, worst], [2.5, 97.5])
    poor = [n for n, v in zip(names, sd_log, strict=True) if v > LOG_SPREAD_SD]
    if not poor:
        return Check("between_run_sd_identified", True, "warning", float(sd_log[worst]),
                     LOG_SPREAD_SD,
                     f"{n_runs} runs pin down every between-run sd (loosest: {names[worst]}, "
                     f"95 % within {lo:.3g} ... {hi:.3g})")
    return Check("between_run_sd_identified", False, "warning", float(sd_log[worst]),
                 LOG_SPREAD_SD,
                 f"{n_runs} runs hardly pin down the between-run sd of {', '.join(poor)} "
                 f"({names[worst]}: 95 % within {lo:.3g} ... {hi:.3g}): the new-run "
                 "predictive is correspondingly wide; pool more runs to narrow it")


@exported
def _mean_information(density, u):
    """The population mean's precision and linear term at the between-run sds ``u`` (one
    compiled program, not some 15 operations compiled or loaded one by one)."""
    q, b, *_ = density._mean_information(u)
    return q, b


@exported
def _mean_conditional(density, u, z):
    return density.mean_conditional(u, z)


def leave_one_run_out(problem: PoolProblem) -> np.ndarray:
    """Per run, the probability that a run of the population fitted WITHOUT it lies as far
    from that population's mean as it does: ``d' (A_r^-1 + T + C)^-1 d`` against chi-square
    (rank of A_r degrees of freedom), ``d`` the run's own estimate minus the others' mean,
    ``C`` that mean's covariance, ``T`` the others' between-run variances at their mode
    widened by one sd of log tau (so that the few runs of a small lot, whose spread is
    uncertain, do not raise false alarms). Left in, an outlying run inflates the spread
    and hides: a run 50 spreads away scored p = 0.51 against the full posterior."""
    p = problem.n_model
    own = np.asarray(problem.density.offset) + np.asarray(problem.density.centre)
    p_values = []
    for r in range(problem.n_runs):
        others = problem.without_run(r)
        mode = others.mode()
        q, b = _mean_information(others.density, jnp.asarray(mode.u))
        q = np.asarray(q)
        mean = np.asarray(others.density.centre) + np.linalg.solve(q, np.asarray(b))
        sd_log_tau = np.sqrt(np.clip(np.diag(mode.covariance_u)[:p], 0.0, None))
        tau = np.exp(mode.u[:p] + sd_log_tau)
        a_inverse = np.linalg.pinv(np.asarray(problem.density.gram[r]))
        d = own[r] - mean
        cov = a_inverse + np.diag(tau**2) + np.linalg.inv(q)
        statistic = float(d @ np.linalg.solve(cov, d))
        p_values.append(float(stats.chi2.sf(statistic, max(problem.ranks[r], 1))))
    return np.array(p_values)


def pool_checks(problem: PoolProblem, point: PointEstimate, posterior: Posterior,
                mean_draws: np.ndarray, summary: dict) -> CheckReport:
    """The population's checks, every run's residual checks (when logs were pooled), and
    the lot's own two."""
    p = problem.n_model
    reference = problem.reference
    names = problem.coefficient_names + problem.names
    sampled_u = np.log(posterior.draws)
    mean_at_mode = np.asarray(_mean_conditional(problem.density, jnp.asarray(point.u),
                                                jnp.zeros(p)))
    evidence = FitEvidence(
        names=names, n_model=p, point_u=np.concatenate([mean_at_mode, point.u]),
        point_converged=point.converged, point_message=point.message,
        priors=problem.mean_priors + problem.priors,
        reference_sd=dict(zip(problem.coefficient_names, map(float, reference), strict=True)),
        residuals=None, sigma_given=False, correlated_noise=False,
        draws_u=np.concatenate([mean_draws, sampled_u], axis=-1), summary=summary)
    own_sd = problem.own_sd
    population = CheckReport((
        convergence(evidence), point_vs_posterior(evidence),
        population_prior_conflict(prior_data_conflict(evidence), problem.coefficient_names,
                                  mean_draws.reshape(-1, p).mean(axis=0), problem.mean_priors),
        population_identified(identifiability(evidence), {
            n: float(np.nanmedian(own_sd[:, k]) / reference[k])
            if np.isfinite(own_sd[:, k]).any() else np.inf
            for k, n in enumerate(problem.coefficient_names)})))
    per_run = combine_runs(dict(zip(problem.run_labels, problem.run_reports, strict=True))
                           ) if problem.run_reports else CheckReport(())
    tau = posterior.draws.reshape(-1, len(problem.names))[:, :p]
    lot = CheckReport((
        run_consistency(leave_one_run_out(problem), problem.run_labels),
        between_run_sd_identified(problem.coefficient_names, tau, problem.n_runs),
    ))
    return population + per_run + lot
