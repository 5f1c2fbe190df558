"""The discrepancy workflow's loop and results, shared by bench and roll logs.

:func:`add_while_evidence` is the one greedy search: every candidate effect not yet in the
model is fitted, scored by ``dBIC = 2 (logL_with - logL_without) - k log n``, and the best
is added while it beats the threshold; candidates within ``AMBIGUITY_DBIC`` of the best
are reported as interchangeable. What a fit is (a bench problem's mode under white +
Gauss-Markov noise, the Kalman likelihood of paper B's loop on a roll log) is the caller's.
:class:`DiscrepancyReport` is what both kinds of log produce (``discrepancy.json``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from gyroid._compiled_programs import release_if_crowded
from gyroid.inference._checks import CheckReport

#: Two candidates scoring within this of each other are interchangeable on the log.
AMBIGUITY_DBIC = 6.0


@dataclass(frozen=True)
class NoiseLevels:
    """A bench search's white + Gauss-Markov noise: sds in deg/h, correlation time in s."""

    white: float
    gm: float
    tau_s: float

    def as_dict(self) -> dict[str, float]:
        return {"sigma_deg_h": self.white, "sigma_gm_deg_h": self.gm, "tau_gm_s": self.tau_s}


@dataclass(frozen=True)
class Trial:
    """A model fitted to the log: its terms, maximum log-likelihood and parameter count;
    ``fit`` is whatever the caller needs later (residuals, noise levels, a point estimate)."""

    terms: tuple[str, ...]
    log_likelihood: float
    n_parameters: int
    fit: Any


@dataclass(frozen=True)
class Step:
    """One effect added: why, by how much, and what else scored."""

    effect: str
    evidence: str
    rms_before: float
    rms_after: float
    score: float  # dBIC, noise re-estimated
    screening: dict[str, float]  # dBIC of every candidate tried at this step
    interchangeable_with: list[str]
    regressor: str
    correlation: float
    #: The added effect's fitted parameters (its size), in their registry units.
    values: dict[str, float] = field(default_factory=dict)

    def to_json(self) -> dict:
        return {
            "effect": self.effect,
            "values": self.values,
            "evidence": self.evidence,
            "rms_before_deg_h": self.rms_before,
            "rms_after_deg_h": self.rms_after,
            "score": self.score,
            "score_kind": "dBIC = 2 dlogL - k log n, noise re-estimated",
            "candidates_dbic": self.screening,
            "interchangeable_with": self.interchangeable_with,
            "regressor": self.regressor,
            "correlation": self.correlation,
        }


@dataclass(frozen=True)
class Unexplained:
    """Structure the final model leaves that no catalogued effect explains."""

    evidence: str
    score: float | None  # dBIC of a flexible term over the final model; None if not fitted
    where: list[list[float]]  # [[t_start_h, t_end_h], ...]
    lines_up_with: str | None
    noise_too_slow: bool = False
    flexible_terms: int | None = None

    def to_json(self) -> dict:
        return {"evidence": self.evidence, "score": self.score, "where": self.where,
                "lines_up_with": self.lines_up_with, "noise_too_slow": self.noise_too_slow,
                "flexible_terms": self.flexible_terms}


@dataclass(frozen=True)
class Search:
    """What :func:`add_while_evidence` found."""

    baseline: Trial
    final: Trial
    steps: list[Step]
    skipped: dict[str, str]  # candidate -> why it could not be tried on this log
    ambiguous: list[dict]


def add_while_evidence(
    baseline: Trial,
    candidates: tuple[str, ...],
    *,
    try_adding: Callable[[Trial, str], Trial | str],
    describe: Callable[[str, Trial, Trial, dict[str, float], list[str]], Step],
    n: int,
    threshold: float,
    max_added: int,
    progress: Callable[[str], None] | None = None,
) -> Search:
    """The greedy search: ``try_adding(current, name)`` fits the current model plus one
    candidate (or returns why it cannot be tried); ``describe`` writes the step of the
    winner. ``n`` is the number of observations the BIC penalty counts."""
    say = progress or (lambda _msg: None)
    current = baseline
    steps: list[Step] = []
    skipped: dict[str, str] = {}
    ambiguous: list[dict] = []
    while len(steps) < max_added:
        release_if_crowded()  # each round compiles its candidates' programs
        scores: dict[str, float] = {}
        trials: dict[str, Trial] = {}
        for name in candidates:
            if name in current.terms:
                continue
            say(f"  trying {name} ...")
            trial = try_adding(current, name)
            if isinstance(trial, str):
                skipped[name] = trial
                continue
            k = trial.n_parameters - current.n_parameters
            scores[name] = 2.0 * (trial.log_likelihood - current.log_likelihood) - k * math.log(n)
            trials[name] = trial
        if not scores:
            break
        best = max(scores, key=lambda n: scores[n])
        if scores[best] <= threshold:
            break
        rivals = [name for name, s in scores.items()
                  if name != best and s > threshold and scores[best] - s < AMBIGUITY_DBIC]
        if rivals:
            ambiguous.append({"step": len(steps) + 1, "chosen": best, "rivals": rivals,
                              "dbic": {r: scores[r] for r in [best, *rivals]}})
        steps.append(describe(best, current, trials[best], scores, rivals))
        say(f"  added {best}: dBIC = {scores[best]:.1f}")
        current = trials[best]
    return Search(baseline, current, steps, skipped, ambiguous)


@dataclass(frozen=True, eq=False)
class DiscrepancyReport:
    """The discrepancy workflow's result on one log (``discrepancy.json``)."""

    log_kind: str  # "bench" or "roll"
    baseline_terms: tuple[str, ...]
    final_terms: tuple[str, ...]
    steps: list[Step]
    rms_baseline: float
    rms_final: float
    rms_unit: str
    threshold_dbic: float
    checks: CheckReport
    unexplained: Unexplained | None
    time_s: np.ndarray = field(repr=False)
    residual_before: np.ndarray = field(repr=False)
    residual_after: np.ndarray = field(repr=False)
    skipped: dict[str, str] = field(default_factory=dict)
    ambiguous: list[dict] = field(default_factory=list)
    where: list[dict] = field(default_factory=list)
    lines_up_with: dict[str, float] = field(default_factory=dict)
    #: Bench logs: the rate estimator's window, s, the final noise levels (of one sample),
    #: and the regressor the figure draws the baseline residual against (name, values at
    #: the rows searched: a fast log's means; ``time_s`` and the residuals are its rows).
    rate_window_s: float | None = None
    noise: Any = None
    regressor: tuple[str, np.ndarray] | None = field(default=None, repr=False)

    @property
    def added(self) -> list[str]:
        return [s.effect for s in self.steps]

    @property
    def trustworthy(self) -> bool:
        """The final model's self-checks passed."""
        return self.checks.trustworthy

    def to_json(self) -> dict:
        out = {
            "log_kind": self.log_kind,
            "baseline_terms": list(self.baseline_terms),
            "added": self.added,
            "final_terms": list(self.final_terms),
            "rms_baseline_deg_h": self.rms_baseline,
            "rms_final_deg_h": self.rms_final,
            "rms_unit": self.rms_unit,
            "steps": [s.to_json() for s in self.steps],
            "threshold_dbic": self.threshold_dbic,
            "ambiguous": self.ambiguous,
            "where": self.where,
            "lines_up_with": self.lines_up_with,
            "skipped_candidates": self.skipped,
            "unexplained": None if self.unexplained is None else self.unexplained.to_json(),
        }
        if self.noise is not None:
            out["noise"] = self.noise.as_dict()
        if self.rate_window_s is not None:
            out["rate_window_s"] = self.rate_window_s
        return out | self.checks.to_json()

    def summary_lines(self) -> list[str]:
        """What the command prints: each added effect with its evidence, or why nothing."""
        lines = [f"added {step.effect}: {step.evidence}" for step in self.steps]
        if self.unexplained is not None:
            lines.append(f"unexplained: {self.unexplained.evidence}")
        elif not self.steps:
            lines.append(f"nothing is missing: no candidate effect reaches dBIC > "
                         f"{self.threshold_dbic:g}, and no structure is left in the residuals")
        return lines
