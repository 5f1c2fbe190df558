"""A fitted roll log (:class:`RollFit`): its self-checks and the confounded parameter pairs.
What :meth:`~gyroid.roll.RollProblem.result` builds; it reads the problem through its
attributes and names it for the type checker only."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import jax.numpy as jnp
import numpy as np

from gyroid.inference._check_report import CheckReport, FitEvidence
from gyroid.inference._checks import fit_checks
from gyroid.inference._posterior import Posterior, interval_summary
from gyroid.inference._problem import PointEstimate
from gyroid.inference._result import Fit
from gyroid.inference._storage import inference_data
from gyroid.models._priors import prior_arrays
from gyroid.models._roll_effects import ROLL_CONFOUNDED, roll_parameter
from gyroid.roll._predictive import roll_predictive

if TYPE_CHECKING:
    from gyroid.roll._problem import RollProblem

#: The loop's parameters whose correlations are examined, in report order.
LOOP_PARAMETERS = ("D0", "D1", "D0gs", "D1gs", "D2")
#: |correlation| above which two loop parameters are reported as confounded.
CONFOUNDING_THRESHOLD = 0.9


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
class RollFit(Fit["RollProblem"]):
    """A fitted roll log: problem, mode, posterior, the encoder error's amplitude and phase,
    the confounded pairs and the self-checks."""

    derived: dict[str, dict] = field(repr=False)  # Denc, encoder_phase_rad summaries
    confounded: tuple[Confounded, ...] = field(repr=False)

    def __repr__(self) -> str:
        verdict = "trustworthy" if self.trustworthy else "NOT trustworthy"
        return (f"RollFit(terms={','.join(self.problem.terms)!r}, "
                f"n_samples={self.problem.log.n}, {verdict})")

    @property
    def loop_names(self) -> tuple[str, ...]:
        return tuple(n for n in LOOP_PARAMETERS if n in self.problem.names)

    @property
    def parameter_summaries(self) -> dict[str, dict]:
        """The loop's parameters (and Denc) as reported: posterior mean, sd, 95 % interval."""
        summary = {k: dict(v) for k, v in self.sampled.summary.items()} | self.derived
        shown = (*self.loop_names, *(["Denc"] if self.derived else []))
        return {n: summary[n] for n in shown}

    def summary(self) -> str:
        """The loop's parameters, the confounded pairs and the failed self-checks."""
        lines = [f"roll loop {','.join(self.problem.terms)} on {self.problem.log.n} rows:"]
        lines += [f"  {name:>5s} = {s['mean']:.6g} +/- {s['sd']:.2g}"
                  for name, s in self.parameter_summaries.items()]
        lines += [f"  confounded: {' and '.join(c.parameters)} (r = {c.correlation:.3f})"
                  for c in self.confounded]
        lines += [f"  {line}" for line in self.checks.lines()]
        return "\n".join([*lines, f"  {self.checks.verdict()}"])

    def inference_data(self):
        return inference_data(self.problem, self.sampled)

    def to_json(self) -> dict:
        """``roll_fit.json``."""
        problem, post = self.problem, self.sampled
        summary = {k: dict(v) for k, v in post.summary.items()} | self.derived
        return {
            "terms": list(problem.terms),
            "parameters": self.parameter_summaries,
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
        hints={n: hint for n in problem.names if (hint := roll_parameter(n).hint)},
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
