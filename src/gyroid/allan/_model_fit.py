"""One set of noise terms' fit (:class:`NoiseModelFit`): what a
:class:`~gyroid.allan._problem.NoiseProblem` gives, with the checks of its
posterior. :func:`~gyroid.allan.fit_noise` averages such fits over the sets of terms a
log supports."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyroid.allan._terms import term
from gyroid.inference._check_report import CheckReport, FitEvidence
from gyroid.inference._checks import fit_checks
from gyroid.inference._posterior import Posterior
from gyroid.inference._problem import PointEstimate
from gyroid.inference._result import Fit

if TYPE_CHECKING:
    from gyroid.allan._problem import NoiseProblem

#: The checks a noise fit keeps of those every fit has (the others read a drift's residuals).
POSTERIOR_CHECKS = ("convergence", "point_vs_posterior", "prior_data_conflict")


@dataclass(frozen=True, eq=False)
class NoiseModelFit(Fit["NoiseProblem"]):
    """One set of noise terms' posterior (log-amplitudes sampled) and its checks."""

    @property
    def terms(self) -> tuple[str, ...]:
        return self.problem.terms

    def summary(self) -> str:
        lines = [f"noise terms {', '.join(self.terms)}; posterior mean +/- sd:"]
        lines += [f"  {name:>4s} = {entry['mean']:.4g} +/- {entry['sd']:.2g} {term(name).unit}"
                  for name, entry in self.sampled.summary.items()]
        return "\n".join([*lines, *(f"  {line}" for line in self.checks.lines()),
                          f"  {self.checks.verdict()}"])

    def to_json(self) -> dict:
        return {"terms": list(self.terms), "posterior": self.sampled.summary,
                **self.checks.to_json()}



def noise_model_result(problem: NoiseProblem, point: PointEstimate,
                       posterior: Posterior | None, *, seed: int = 0) -> NoiseModelFit:
    """The frozen :class:`NoiseModelFit` of one sampled set of terms, checks first
    (``seed``: the sampler's; the result draws nothing of its own)."""
    if posterior is None:
        raise ValueError("a noise fit reports posterior intervals: sample it")
    # Every term is a noise level (n_model 0): as for a bench fit's levels, a term whose
    # posterior is mostly its prior (the log barely resolves it; its mode sits at the upper
    # end of a posterior spanning decades) is not compared with its mode, and a prior that
    # pulls one is a warning (on an ADIS16405 run, K at weight 0.5 had mode and mean 1.2
    # posterior sd apart in a unimodal posterior).
    evidence = FitEvidence(
        names=problem.names, n_model=0, point_u=np.asarray(point.u),
        point_converged=point.converged, point_message=point.message,
        priors=problem.priors, reference_sd={}, residuals=None, sigma_given=False,
        correlated_noise=False, draws_u=problem.to_sampling_host(posterior.draws),
        summary=posterior.summary, remedies=frozenset({"discrepancy"}))
    # The checks of residuals and identifiability read a drift fit's residuals and
    # reference scales, which a noise fit does not have (level_fit and the terms' inclusion
    # do their work): only the checks of the posterior itself are kept.
    kept = tuple(c for c in fit_checks(evidence).checks if c.name in POSTERIOR_CHECKS)
    return NoiseModelFit(problem=problem, point=point, posterior=posterior, seed=seed,
                         checks=CheckReport(kept))
