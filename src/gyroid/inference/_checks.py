"""Self-checks: every fit says whether it may be used (docs/formats.md section 3, "Self-checks").

Written once for every kind of fit. A fit (bench drift, roll loop, and later pooled fits)
hands :func:`fit_checks` a :class:`FitEvidence`: its parameter names, point estimate and
posterior draws in sampling coordinates, the priors, a reference scale per coefficient and
its standardised residuals (innovations over their sd: independent N(0, 1) when the model
and its noise model are right). Each check returns a :class:`Check`; a :class:`CheckReport`
is trustworthy when no error-severity check failed.

Thresholds and where they come from:

* convergence: ``r_hat <= 1.01`` and ``ess_bulk >= 400`` (the sampler's own targets).
* point vs posterior: the point estimate (posterior mode) and the posterior mean differ by
  less than one posterior sd in sampling coordinates. For a nearly Gaussian posterior they
  differ by Monte-Carlo error alone (sd / sqrt(ESS) ~ 0.05 sd); a skewed posterior
  moves them apart by a fraction of an sd; a whole sd means a second mode, a sampler stuck
  away from the mode, or a mode-finder that stopped early.
* prior-data conflict: the prior's pull on the posterior mean, ``post_sd * (mean - loc) /
  prior_sd**2`` (the shift a normal prior causes, in posterior sds). Above 0.5 posterior sd
  the prior moves the answer and the log disagrees with it: an error. A posterior more than
  3 prior sds from the prior's centre whose pull is small is a warning (the prior is
  misplaced but harmless here).
* goodness of fit (when the log gives ``sigma_deg_h``): the mean square ``q`` of the
  standardised residuals is ``1 +/- sqrt(2/n)`` under the model. ``|q - 1| > 4 sqrt(2/n)``
  (p ~ 6e-5) fails; it is an error when the residual scale ``sqrt(q)`` is also more than
  1.2 times the stated sigma (intervals 20 % too narrow or worse), else a warning.
* residual whiteness: for block lengths m = 2, 4, 8, ..., the variance of block means of
  the standardised residuals times m is ``chi2(B-1)/(B-1)`` for B blocks when they are
  white; a block length whose one-sided p-value times the number of block lengths
  (Bonferroni) is below 1e-4 fails the test. Its practical size is the largest such
  ratio: the factor by which the variance of a long average, and so of a slowly varying
  coefficient, is underrated. Above 2 (intervals at least 1.4x too narrow) it is an error
  under a white-noise model, else a warning. (Correlated noise ratios reach 10-30 at
  hundreds of samples; the rate estimator's smoothing on paper A's bench gives ~1.8.)
  A log with gaps (burst sampling) adds one more member to the family: the segments
  themselves as blocks, ``sum n_k (mean_k - mean)**2 / (K - 1)`` over K segments, the same
  ratio for unequal blocks. Bias wander between bursts shows there and nowhere else.
* outliers: a standardised residual beyond ``z_max``, where white Gaussian noise leaves
  one of n samples out with probability 0.01 (``z_max = Phi^-1(1 - 0.005 / n)``, 4.8 for
  n = 6000). Each moves a bias-like coefficient by ``z / sqrt(n)`` posterior sd; when the
  outliers together move it by more than 1 posterior sd it is an error (spikes decide the
  answer), else a warning naming the rows. Outliers that mostly sit next to each other are
  called structure, not spikes. Outliers that make more than half the residual variance
  are an error too: the noise level, and every interval and check scaled by it, rest on a
  handful of samples (heavy-tailed noise such as Student-t with 3 dof leaves about a
  quarter). The whiteness test leaves them out, so that they cannot hide correlation.
* identifiability: a coefficient's posterior sd over its reference scale (the default
  prior's sd, set from the log's drift scale and the regressor's physical span: see
  :mod:`gyroid.models._prior_scales`). Above 0.5 the log does not pin the coefficient down.
"""

from __future__ import annotations

import math

import numpy as np

from gyroid.inference._check_report import (  # noqa: F401  (the checks' public surface)
    BENCH_REMEDIES,
    REMEDIES,
    Check,
    CheckReport,
    FitEvidence,
    Severity,
    fit_verdict,
    point_fit_evidence,
)
from gyroid.inference._residual_checks import (  # noqa: F401  (re-exported)
    WHITENESS_INFLATION,
    block_variance_ratios,
    outliers,
    residual_whiteness,
    segment_variance_ratio,
    spike_threshold,
    without_spikes,
)
from gyroid.models._priors import LogNormal, Normal, Prior

MAX_R_HAT = 1.01
MIN_ESS = 400.0
POINT_POSTERIOR_SD = 1.0
PRIOR_PULL_SD = 0.5
PRIOR_TAIL_SD = 3.0
GOF_Z = 4.0
GOF_SCALE_ERROR = 1.2
IDENTIFIED_RATIO = 0.5


def fit_checks(evidence: FitEvidence) -> CheckReport:
    """Every check that applies to a fit."""
    return CheckReport((
        convergence(evidence),
        point_vs_posterior(evidence),
        prior_data_conflict(evidence),
        goodness_of_fit(evidence),
        residual_whiteness(evidence.residuals, segments=evidence.segments,
                           correlated_noise_modelled=evidence.correlated_noise,
                           remedies=evidence.remedies),
        outliers(evidence.residuals, where=evidence.where),
        identifiability(evidence),
    ))


def _posterior_u(evidence: FitEvidence) -> tuple[np.ndarray, np.ndarray] | None:
    if evidence.draws_u is None:
        return None
    flat = np.asarray(evidence.draws_u).reshape(-1, len(evidence.names))
    return flat.mean(axis=0), flat.std(axis=0, ddof=1)


def convergence(evidence: FitEvidence) -> Check:
    if evidence.summary is None:
        ok = evidence.point_converged
        return Check("convergence", ok, "error", None, None,
                     "the point estimate converged (no posterior was sampled)" if ok else
                     f"the point estimate did not converge ({evidence.point_message}); "
                     "simplify the model or check the log")
    summary = evidence.summary
    r_hat = max(float(s["r_hat"]) for s in summary.values())
    ess = min(float(s["ess_bulk"]) for s in summary.values())
    ok = r_hat <= MAX_R_HAT and ess >= MIN_ESS
    worst = max(summary, key=lambda k: summary[k]["r_hat"])
    if ok:
        message = f"the sampler converged (max r_hat {r_hat:.3f}, min ess_bulk {ess:.0f})"
        if not evidence.point_converged:  # the screen shows the mode's search as stopped
            message += (f"; the point estimate's own search stopped "
                        f"({evidence.point_message}), so its sds may be missing: the "
                        "posterior, not the point estimate, is the answer")
    else:
        message = (f"the sampler did not converge (r_hat {r_hat:.3f} on {worst}, min ess_bulk "
                   f"{ess:.0f}; wanted <= {MAX_R_HAT} and >= {MIN_ESS:.0f}): the posterior "
                   "is not reliable; look for a multimodal or unidentified parameter")
    return Check("convergence", ok, "error", r_hat, MAX_R_HAT, message)


def point_vs_posterior(evidence: FitEvidence) -> Check:
    """The point estimate against the posterior mean, in posterior sd, for the coefficients
    and the noise levels the log resolves. A noise level whose posterior is mostly its prior
    (its sd more than :data:`IDENTIFIED_RATIO` of the prior's, as a coefficient the log does
    not identify) is not compared: a flicker or a walk the log cannot rule out has a
    posterior from negligible up to what the log allows, whose mode sits at its upper end,
    a posterior sd or more from its mean, in a posterior that is neither multimodal nor
    stopped early."""
    moments = _posterior_u(evidence)
    if moments is None:
        return Check("point_vs_posterior", True, "error", None, POINT_POSTERIOR_SD,
                     "no posterior to compare with")
    mean, sd = moments
    z = np.abs(np.asarray(evidence.point_u) - mean) / np.where(sd > 0, sd, np.inf)
    unresolved = [i for i in range(evidence.n_model, len(evidence.names))
                  if _mostly_prior(evidence.priors[i], sd[i])]
    z[unresolved] = 0.0
    k = int(np.argmax(z))
    value = float(z[k])
    name = evidence.names[k]
    ok = value <= POINT_POSTERIOR_SD
    aside = ("" if not unresolved else
             f"; {', '.join(evidence.names[i] for i in unresolved)} not compared: the log does "
             "not resolve them, their posteriors are mostly their priors")
    message = (f"point estimate and posterior mean agree (largest gap {value:.2f} posterior "
               f"sd, {name}){aside}" if ok else
               f"the point estimate of {name} is {value:.1f} posterior sd from the posterior "
               "mean: the posterior is multimodal or the fit stopped early; do not use either "
               "until they agree (check the priors, try flat priors, or simplify the model)")
    return Check("point_vs_posterior", ok, "error", value, POINT_POSTERIOR_SD, message,
                 () if ok else ("prior",))


def _mostly_prior(prior: Prior, posterior_sd: float) -> bool:
    """Whether a parameter's posterior sd (sampling coordinates) exceeds
    :data:`IDENTIFIED_RATIO` of its prior's."""
    moments = _prior_moments(prior)
    return moments is not None and posterior_sd > IDENTIFIED_RATIO * moments[1]


def _prior_moments(prior: Prior) -> tuple[float, float] | None:
    if isinstance(prior, Normal):
        return prior.loc, prior.scale
    if isinstance(prior, LogNormal):
        return math.log(prior.median), prior.log_sd
    return None


def prior_data_conflict(evidence: FitEvidence) -> Check:
    moments = _posterior_u(evidence)
    if moments is None:
        mean = np.asarray(evidence.point_u)
        sd = np.full(mean.size, np.nan)
    else:
        mean, sd = moments
    pulls: dict[str, float] = {}
    tails: dict[str, float] = {}
    for i, (name, prior) in enumerate(zip(evidence.names, evidence.priors, strict=True)):
        pm = _prior_moments(prior)
        if pm is None:
            continue
        loc, scale = pm
        tails[name] = float(abs(mean[i] - loc) / scale)
        pulls[name] = (float(abs(sd[i] * (mean[i] - loc) / scale**2)) if np.isfinite(sd[i])
                       else tails[name])
    name = max(pulls, key=lambda n: pulls[n], default=None)
    pull = pulls[name] if name is not None else 0.0
    if name is not None and pull > PRIOR_PULL_SD:
        i = evidence.names.index(name)
        prior = evidence.priors[i]
        # A noise parameter held up by its prior (e.g. a Gauss-Markov level the log does not
        # show) does not bias the coefficients: a warning; a coefficient's is an error.
        severity: Severity = "error" if i < evidence.n_model else "warning"
        form = "lognormal(MEDIAN,LOG_SD)" if isinstance(prior, LogNormal) else "normal(MU,SD)"
        # a prior the log overrules (a datasheet's level 40x off) is news beside one it pulls
        others = {n: t for n, t in tails.items() if n != name}
        far = max(others, key=lambda n: others[n], default=None)
        also = (f"; {far} sits {others[far]:.1f} prior sd from its prior's centre, where the "
                "log dominates: that prior is misplaced for this gyro"
                if far is not None and others[far] > PRIOR_TAIL_SD else "")
        return Check("prior_data_conflict", False, severity, pull, PRIOR_PULL_SD,
                     f"the prior of {name} ({prior.describe()}) disagrees with the log and "
                     f"pulls its posterior by {pull:.1f} posterior sd; widen it ({name} = "
                     f"{form}) or choose another prior set{also}", ("prior",))
    tail_name = max(tails, key=lambda n: tails[n], default=None)
    tail = tails[tail_name] if tail_name is not None else 0.0
    if tail_name is not None and tail > PRIOR_TAIL_SD:
        return Check("prior_data_conflict", False, "warning", tail, PRIOR_TAIL_SD,
                     f"{tail_name} sits {tail:.1f} prior sd from its prior's centre, but the "
                     f"log dominates (pull {pull:.2f} posterior sd); the prior is misplaced "
                     "for this gyro")
    return Check("prior_data_conflict", True, "error", pull, PRIOR_PULL_SD,
                 "no prior disagrees with the log" if name is not None else
                 "flat priors: nothing to disagree with")


def goodness_of_fit(evidence: FitEvidence) -> Check:
    if not evidence.sigma_given or evidence.residuals is None:
        return Check("goodness_of_fit", True, "error", None, None,
                     "the noise level was estimated from the log (no sigma_deg_h): its "
                     "residual scale is 1 by construction")
    z = np.asarray(evidence.residuals)
    n = z.size
    q = float(np.mean(z**2))
    band = GOF_Z * math.sqrt(2.0 / n)
    scale = math.sqrt(q)
    if abs(q - 1.0) <= band:
        return Check("goodness_of_fit", True, "error", scale, 1.0 + band,
                     f"residuals match the stated sigma_deg_h (scale {scale:.3f})")
    if q > 1.0:
        severity: Severity = "error" if scale > GOF_SCALE_ERROR else "warning"
        message = (f"the residuals are {scale:.2f} times the stated sigma_deg_h: the model "
                   "misses part of the drift or sigma_deg_h is too small, and the intervals "
                   "are too narrow; look for a missing effect, or drop sigma_deg_h to "
                   "estimate the noise")
    else:
        severity = "warning"
        message = (f"the residuals are only {scale:.2f} times the stated sigma_deg_h: "
                   "sigma_deg_h is too large and the intervals are too wide")
    return Check("goodness_of_fit", False, severity, scale, 1.0 + band, message,
                 ("discrepancy",) if q > 1.0 else ())


def identifiability(evidence: FitEvidence) -> Check:
    moments = _posterior_u(evidence)
    if moments is None:
        return Check("identifiability", True, "error", None, IDENTIFIED_RATIO,
                     "no posterior to judge identifiability")
    _, sd = moments
    worst, worst_name = 0.0, None
    poor: list[str] = []
    for i, name in enumerate(evidence.names[: evidence.n_model]):
        reference = evidence.reference_sd.get(name)
        if not reference or not np.isfinite(reference):
            continue
        ratio = float(sd[i] / reference)
        if ratio > IDENTIFIED_RATIO:
            poor.append(name)
        if ratio > worst:
            worst, worst_name = ratio, name
    if not poor:
        return Check("identifiability", True, "error", worst, IDENTIFIED_RATIO,
                     "every coefficient is pinned down by this log" if worst_name is None
                     else f"every coefficient is pinned down by this log (worst: {worst_name},"
                          f" posterior sd {100 * worst:.0f} % of its reference scale)")
    hints = "; ".join(dict.fromkeys(evidence.hints[n] for n in poor if n in evidence.hints))
    return Check("identifiability", False, "error", worst, IDENTIFIED_RATIO,
                 f"this log does not identify {', '.join(poor)} (posterior sd up to "
                 f"{100 * worst:.0f} % of the reference scale): "
                 + (hints or "use a log that exercises them, or drop their terms"))
