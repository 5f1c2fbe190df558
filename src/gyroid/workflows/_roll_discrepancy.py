"""The discrepancy workflow for roll logs: roll-side candidates scored by dBIC on the exact
likelihood, added while they win, and the left-over structure reported."""

from __future__ import annotations

from dataclasses import dataclass

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from gyroid.inference._checks import CheckReport, fit_checks, point_fit_evidence
from gyroid.inference._problem import PointEstimate
from gyroid.io._roll_log import RollLog
from gyroid.models._roll_effects import ROLL_EFFECTS, resolve_roll_terms, roll_parameter
from gyroid.roll._density import RollDensity
from gyroid.roll._problem import RollProblem
from gyroid.workflows._discrepancy_report import (
    DiscrepancyReport,
    Step,
    Trial,
    Unexplained,
    add_while_evidence,
)

#: dBIC a roll-side candidate must reach ("decisive", a Bayes factor above 2e4). Stricter than
#: for bench logs: the angle residual holds the SINS noise integrated into a random walk, one
#: realisation with few effective degrees of freedom, which a smooth candidate (e.g.
#: sf_nonlinearity on an oscillating roll rate) can partly imitate; on 40 s clean flights
#: such spurious gains reached dBIC ~ 11, real effects score 100 to 5000.
ROLL_ADD_THRESHOLD = 20.0


@eqx.filter_jit
def _fit_quality(density: RollDensity, v):
    """Log-likelihood and angle residual (deg) at ``v`` (one compilation per log shape)."""
    return jnp.sum(density.log_likelihood_rows(v)), density.gs_angle - density.predict(v)


def _max_log_likelihood(problem: RollProblem) -> tuple[float, PointEstimate, np.ndarray]:
    point = problem.mode()
    v = problem.density.spread(jnp.asarray(point.u))
    log_lik, residual = _fit_quality(problem.density.full, v)
    return float(log_lik), point, np.asarray(residual)


def roll_regressors(problem: RollProblem) -> dict[str, np.ndarray]:
    psi = np.cumsum(np.asarray(problem.sins)) * problem.sample_s
    out = {"elapsed time": np.asarray(problem.time_s), "roll angle": psi,
           "sin(roll angle)": np.sin(np.deg2rad(psi)), "cos(roll angle)": np.cos(np.deg2rad(psi)),
           "roll angle x |roll rate|": np.cumsum(np.abs(np.asarray(problem.sins))
                                                 * np.asarray(problem.sins)) * problem.sample_s}
    if problem.gs_rate is not None:
        rate = np.asarray(problem.gs_rate)
        out["integrated stabiliser rate"] = np.cumsum(rate) * problem.sample_s
    return out


@dataclass(frozen=True)
class RollTrialFit:
    problem: RollProblem
    point: PointEstimate
    residual: np.ndarray  # stabiliser angle minus model, deg

    @property
    def rms(self) -> float:
        return float(np.sqrt(np.mean(self.residual**2)))


def _trial(problem: RollProblem) -> Trial:
    log_lik, point, residual = _max_log_likelihood(problem)
    return Trial(problem.terms, log_lik, len(problem.names),
                 RollTrialFit(problem, point, residual))


def find_roll_discrepancies(log: RollLog, terms="ideal", *, max_added: int = 3,
                            progress=None) -> DiscrepancyReport:
    """The discrepancy workflow for roll logs (:func:`gyroid.workflows._discrepancy_report.
    add_while_evidence` on paper B's loop): roll-side candidates scored by dBIC on the exact
    likelihood with the noise levels estimated per model, added while dBIC exceeds
    ``ROLL_ADD_THRESHOLD``."""
    baseline = _trial(RollProblem.from_log(log, resolve_roll_terms(terms)))
    regs = roll_regressors(baseline.fit.problem)

    def try_adding(current: Trial, name: str) -> Trial | str:
        problem = RollProblem.from_log(log, (*current.terms, name))
        if name not in problem.terms:
            return "needs the stabiliser's rate (gs_rate_deg_s) from an overloaded stabiliser"
        return _trial(problem)

    def describe(best, current, chosen, scores, rivals) -> Step:
        before, after = current.fit, chosen.fit
        change = before.residual - after.residual
        name, _ = max(((k, float(np.corrcoef(change, v)[0, 1])) for k, v in regs.items()
                       if np.ptp(v) > 0), key=lambda kv: abs(kv[1]))
        r = float(np.corrcoef(before.residual, regs[name])[0, 1])
        size = {p.name: after.point.value[p.name] for p in ROLL_EFFECTS[best].parameters}
        fitted = ", ".join(f"{k} = {v:.4g} {roll_parameter(k).unit}" for k, v in size.items())
        evidence = (f"the stabiliser-angle residuals follow {name} (r = {r:.2f}); adding "
                    f"{best} ({ROLL_EFFECTS[best].what}; {fitted}) cuts the RMS from "
                    f"{before.rms:#.3g} to {after.rms:#.3g} deg; dBIC = {scores[best]:.1f} "
                    f"(threshold {ROLL_ADD_THRESHOLD:g})"
                    + (f"; nearly interchangeable here with {', '.join(rivals)}"
                       if rivals else ""))
        return Step(best, evidence, before.rms, after.rms, scores[best], scores, rivals, name, r,
                    size)

    candidates = tuple(name for name, e in ROLL_EFFECTS.items() if e.candidate)
    search = add_while_evidence(
        baseline, candidates, try_adding=try_adding, describe=describe,
        n=int(baseline.fit.problem.observed.shape[0]), threshold=ROLL_ADD_THRESHOLD,
        max_added=max_added, progress=progress)
    final = search.final.fit
    problem = final.problem
    n_model = sum(not name.startswith("sigma_") for name in problem.names)
    u = jnp.asarray(final.point.u)
    checks = fit_checks(point_fit_evidence(
        problem.names, n_model, np.asarray(u),
        np.asarray(problem.density.standardised_residuals(u)), correlated_noise=False,
        converged=final.point.converged, message=final.point.message))
    return DiscrepancyReport(
        log_kind="roll",
        baseline_terms=baseline.terms,
        final_terms=search.final.terms,
        steps=search.steps,
        rms_baseline=baseline.fit.rms,
        rms_final=min(final.rms, baseline.fit.rms),
        rms_unit="deg (stabiliser angle minus model, for a roll log)",
        threshold_dbic=ROLL_ADD_THRESHOLD,
        checks=checks,
        unexplained=_roll_unexplained(checks),
        time_s=np.asarray(baseline.fit.problem.time_s),
        residual_before=baseline.fit.residual,
        residual_after=final.residual,
        skipped=search.skipped,
        ambiguous=search.ambiguous,
    )


def _roll_unexplained(checks: CheckReport) -> Unexplained | None:
    """A roll log's left-over structure: the final model's Kalman innovations are not white
    (no flexible term is fitted on the roll side yet; its score is None)."""
    whiteness = next(c for c in checks.checks if c.name == "residual_whiteness")
    if whiteness.passed:
        return None
    return Unexplained("the final model's stabiliser-angle innovations are not white: "
                       + whiteness.message, None, [], None)
