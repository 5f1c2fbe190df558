"""What the self-checks take and give: :class:`FitEvidence` (what any fit hands them),
:class:`Check` (one check's result) and :class:`CheckReport` (a result's checks and its
verdict). The checks themselves are :mod:`gyroid.inference._checks`."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from gyroid.models._priors import Flat, Prior

Severity = Literal["error", "warning"]


#: What a failed check may advise, as codes (``Check.remedies``); a command turns the codes
#: it can act on into its own options (the command line's ``report_checks``).
REMEDIES = {
    "noise_model": "model the correlated noise (white+flicker+rw)",
    "noise_terms": "the noise is more than white plus one Gauss-Markov process (flicker, a "
                   "rate random walk): fit with IEEE 952's terms (--noise white+flicker+rw), "
                   "and name them on a static stretch (gyroid noise)",
    "segment_means": "fit the bursts' means, one row per burst",
    "discrepancy": "look for a missing effect (the discrepancy workflow)",
    "prior": "widen a prior, or choose another prior set",
}
#: The remedies a bench fit can take; other kinds of fit give their own.
BENCH_REMEDIES = frozenset({"noise_model", "noise_terms", "segment_means", "discrepancy",
                            "prior"})


@dataclass(frozen=True)
class Check:
    """One self-check: what was measured against what, one sentence of advice, and the
    codes of the remedies that advice names (keys of :data:`REMEDIES`)."""

    name: str
    passed: bool
    severity: Severity
    value: float | None
    threshold: float | None
    message: str
    remedies: tuple[str, ...] = ()

    def to_json(self) -> dict:
        out = {"passed": self.passed, "severity": self.severity, "value": self.value,
               "threshold": self.threshold, "message": self.message}
        return out | ({"remedies": list(self.remedies)} if self.remedies else {})


@dataclass(frozen=True)
class CheckReport:
    """The checks of one result; ``trustworthy`` unless an error-severity check failed."""

    checks: tuple[Check, ...]

    @property
    def failed(self) -> tuple[Check, ...]:
        return tuple(c for c in self.checks if not c.passed)

    @property
    def trustworthy(self) -> bool:
        return not any(c.severity == "error" for c in self.failed)

    def __add__(self, other: CheckReport) -> CheckReport:
        return CheckReport(self.checks + other.checks)

    def to_json(self) -> dict:
        return {"checks": {c.name: c.to_json() for c in self.checks},
                "trustworthy": self.trustworthy}

    def lines(self) -> list[str]:
        """One line per failed check, errors first."""
        ordered = sorted(self.failed, key=lambda c: c.severity != "error")
        return [f"{c.severity}: {c.name}: {c.message}" for c in ordered]

    def verdict(self) -> str:
        if self.trustworthy:
            return "every error-level self-check passed: the result may be used"
        return ("NOT TRUSTWORTHY: do not use this result until the errors above are dealt "
                "with (exit code 3)")


@dataclass(frozen=True)
class FitEvidence:
    """What any fit hands to the self-checks.

    Parameters are in sampling coordinates (a positive parameter as its log). ``names``
    lists every sampled parameter; the first ``n_model`` are model coefficients (checked
    for identifiability), the rest noise parameters. ``reference_sd`` gives, per model
    coefficient, the scale against which its posterior sd is judged. ``residuals`` are the
    standardised residuals (or innovations), in time order; ``segments`` the ``[start,
    stop)`` index ranges of the log's contiguous stretches when it has gaps, and ``where``
    turns a residual's index into the row it came from ('row 12 (line 13 of log.csv)').
    """

    names: tuple[str, ...]
    n_model: int
    point_u: np.ndarray
    point_converged: bool
    point_message: str
    priors: tuple[Prior, ...]
    reference_sd: Mapping[str, float]
    residuals: np.ndarray | None
    sigma_given: bool
    #: Whether the fit's noise model has correlated parts (its residuals are innovations).
    correlated_noise: bool
    draws_u: np.ndarray | None = None  # (walkers, draws, d)
    summary: Mapping[str, Mapping] | None = None  # r_hat, ess_bulk per name
    hints: Mapping[str, str] = field(default_factory=dict)  # per coefficient: what to vary
    segments: tuple[tuple[int, int], ...] | None = None
    where: Callable[[int], str] | None = None
    #: The remedies this kind of fit can take (codes of :data:`REMEDIES`).
    remedies: frozenset[str] = BENCH_REMEDIES


def fit_verdict(trustworthy: bool, use: str) -> Check:
    """A result built on a fit inherits its verdict (``use``: what the result does with it,
    e.g. 'compensating with it')."""
    return Check("fit_trustworthy", trustworthy, "error", None, None,
                 "the fit's own self-checks passed" if trustworthy else
                 "the fit was marked not trustworthy (see its fit.json checks); refit "
                 f"before {use}")


def point_fit_evidence(names: tuple[str, ...], n_model: int, point_u: np.ndarray,
                       residuals: np.ndarray, *, correlated_noise: bool, converged: bool = True,
                       message: str = "converged",
                       segments: tuple[tuple[int, int], ...] | None = None,
                       where: Callable[[int], str] | None = None,
                       remedies: frozenset[str] = BENCH_REMEDIES) -> FitEvidence:
    """Evidence of a maximum-likelihood fit without priors or posterior (the discrepancy
    workflow's): the checks that need draws report that they do not apply."""
    return FitEvidence(names=tuple(names), n_model=n_model, point_u=np.asarray(point_u),
                       point_converged=converged, point_message=message,
                       priors=tuple(Flat() for _ in names), reference_sd={},
                       residuals=np.asarray(residuals), sigma_given=False,
                       correlated_noise=correlated_noise,
                       segments=segments, where=where, remedies=remedies)
