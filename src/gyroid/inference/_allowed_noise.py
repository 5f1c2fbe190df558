"""How much a bench fit's intervals rest on its noise levels' priors
(:class:`AllowedNoise`): each coefficient's range over the noise levels the log itself
cannot rule out.

A fit integrates the coefficients out exactly at any noise levels
(:mod:`gyroid.inference._collapsed`): one filter pass (or, under white noise, one solve on
the sufficient statistics) gives the levels' marginal likelihood and the coefficients'
conditional Gaussian. The *allowed* levels are those whose marginal
likelihood (their weak priors taken out, the defaults' log-sd of 3 that let a level be
negligible; measured priors and a time constant's kept) is within
``chi2_d(0.95) / 2`` of the best found, ``d`` the marginal coordinates; a coefficient's
range is the union of its conditional 95 % intervals over them, and its *widening* the largest
conditional sd among them over its posterior sd (the check ``noise_prior_dependence`` warns
from :data:`SAID_FROM`). The levels evaluated are those the posterior came from (every draw
importance sampling weighed, already evaluated; or at most ``POSTERIOR_LEVELS`` of a
chain's) and ``BOX_LEVELS`` drawn uniformly in a box about the allowed ones among them,
reaching ``ABOVE`` log units above them for each level with a prior, where the likelihood
of flicker and a walk ends: the range is the union over those, so at most the true union.

Why: a 10 h FOG bench hardly tells flicker of 0.01 deg/h and a walk of 0.005
deg/h/sqrt(h) from none (their Allan floor stands above the white noise only from about
0.6 h to 5 h). On the issue's benches (``experiments/fog_thermal_bench.py``) the likelihood
allowed B up to about 0.01 deg/h and K up to 0.02-0.03 deg/h/sqrt(h) alike on logs with
and without them (one-off, six logs), and w1's sd at the allowed levels was a median 2.9x
its posterior sd on 30 FOG logs and 4.4x on 20 white-only ones (results files). The
posterior's own interval is set there by the priors of B and K, whose medians let them be
negligible: right on average over those priors, too narrow for a gyro whose flicker and
walk sit near the likelihood's edge. No rule reading such a log tells the two kinds apart;
this says how much the answer rests on the priors, and noise measured at rest (``gyroid
noise``, then ``gyroid fit --noise DIR``) narrows it (a median 2.1x for w1 with 40 h at rest).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from gyroid.inference._batching import in_chunks
from gyroid.inference._check_report import Check
from gyroid.inference._importance import BATCH

#: The likelihood region's probability (chi-square with the marginal coordinates' number).
REGION = 0.95
#: Posterior draws of the levels evaluated at most, and uniform ones in the box.
POSTERIOR_LEVELS, BOX_LEVELS = 1000, 1000
#: How far the box reaches above the largest allowed draw of a level with a prior, and
#: beyond the allowed draws of every other coordinate (log units).
ABOVE, BESIDE = 6.0, 1.0
#: A noise level's prior this wide (log-sd) or wider is a placeholder, taken out of the
#: likelihood region; a narrower one (measured: ``gyroid fit --noise DIR``) stays in.
WEAK_FROM = 2.0
#: A coefficient's sd at allowed levels over its posterior sd from which the check warns.
SAID_FROM = 2.0
#: ... and beyond which the fit is not trustworthy (contract section 7, "trust by range"):
#: an interval that could be ten times as wide at levels the log allows is the priors'
#: answer, not the log's.
TRUSTED_UP_TO = 10.0
_Z95 = float(stats.norm.ppf(0.975))


@dataclass(frozen=True)
class AllowedNoise:
    """The noise levels a log allows and what they do to each coefficient."""

    upper: dict[str, float]  # each noise level's largest allowed value, natural units
    ranges: dict[str, tuple[float, float]]  # coefficient: union of conditional 95 % CIs
    #: coefficient: its largest conditional sd over the allowed levels / its posterior sd
    widening: dict[str, float]
    at: dict[str, dict[str, float]]  # coefficient: the allowed levels of that largest sd
    evaluated: int  # noise levels evaluated
    allowed: int  # of which inside the likelihood region

    @property
    def widest(self) -> tuple[str, float]:
        """The coefficient whose sd widens most, and by how much."""
        name = max(self.widening, key=self.widening.__getitem__)
        return name, self.widening[name]

    def check(self, units: dict[str, str]) -> Check:
        """A warning when some coefficient's sd at levels the log allows is
        :data:`SAID_FROM` times its posterior sd or more: the stated intervals rest on the
        noise levels' priors; an error beyond :data:`TRUSTED_UP_TO` times: the interval is
        the priors' answer, and the fit is not to be used (exit 3)."""
        name, factor = self.widest
        low, high = self.ranges[name]
        digits = int(np.clip(np.ceil(np.log10(max(abs(low), abs(high), 1e-300)
                                              / max(high - low, 1e-300))) + 2, 3, 12))
        levels = ", ".join(f"{k} = {v:.2g} {units.get(k, '')}".rstrip()
                           for k, v in self.at[name].items())
        untrusted = factor > TRUSTED_UP_TO
        if factor < SAID_FROM:
            return Check(
                name="noise_prior_dependence", passed=True, severity="warning",
                value=round(factor, 3), threshold=SAID_FROM,
                message=(f"at the noise levels this log allows ({levels}) {name}'s sd is at "
                         f"most {factor:.1f}x its posterior sd (95 % range over them "
                         f"[{low:.{digits}g}, {high:.{digits}g}]): the intervals do not rest "
                         "on the noise levels' priors"))
        return Check(
            name="noise_prior_dependence", passed=False,
            severity="error" if untrusted else "warning", value=round(factor, 3),
            threshold=TRUSTED_UP_TO if untrusted else SAID_FROM,
            message=(f"at noise levels this log does not rule out ({levels}) {name}'s sd "
                     f"is {factor:.1f}x its posterior sd (95 % range over such levels "
                     f"[{low:.{digits}g}, {high:.{digits}g}]): the intervals rest on the "
                     "noise levels' priors"
                     + (f", more than {TRUSTED_UP_TO:g}x, so they are not an answer"
                        if untrusted else "")
                     + "; the gyro's datasheet (fit with --noise FILE.toml), noise measured "
                     "at rest (gyroid noise, then fit with --noise DIR) or a longer log "
                     "narrows this"))

    def to_json(self) -> dict:
        return {"likelihood_region": REGION, "levels_up_to": self.upper,
                "ci95": {k: list(v) for k, v in self.ranges.items()},
                "sd_widening": self.widening, "widest_at": self.at,
                "levels_evaluated": self.evaluated, "levels_allowed": self.allowed}


def allowed_noise(problem, posterior, seed: int = 0) -> AllowedNoise | None:
    """:class:`AllowedNoise` of a bench fit whose coefficients its marginal integrates out
    (any noise model: under white noise the one level is pinned by the rows, and the range
    says so) and that has a posterior; None otherwise (no posterior, no coefficient
    integrated out, or no noise level sampled: a known sigma)."""
    if posterior is None:
        return None
    target = problem.marginal_target()
    if target is None or not target.real.size or not target.marginal.size:
        return None
    rng = np.random.default_rng([seed, 952])
    names = list(problem.names)
    drawn, rows = _posterior_levels(problem, target, posterior, rng)
    drop = stats.chi2.ppf(REGION, drawn.shape[1]) / 2.0
    log_lik = _log_likelihood(target, drawn, rows)
    if not np.isfinite(log_lik).any():
        return None
    # the box about the allowed levels among those, reaching above them
    near = drawn[log_lik >= log_lik.max() - drop]
    low, high = near.min(axis=0) - BESIDE, near.max(axis=0) + BESIDE
    for index, _, _ in target.tails:
        high[index] += ABOVE - BESIDE
    box = rng.uniform(low, high, (BOX_LEVELS, low.size))
    box_rows = in_chunks(target.solved, box, BATCH)
    levels, rows = np.concatenate([drawn, box]), np.concatenate([rows, box_rows])
    log_lik = np.concatenate([log_lik, _log_likelihood(target, box, box_rows)])
    inside = log_lik >= log_lik.max() - drop  # -inf where not finite: never inside
    p = target.real.size
    factors = rows[:, 1 + p:].reshape(-1, p, p)
    inside &= (np.all(np.isfinite(rows[:, 1:]), axis=1)
               & np.all(np.abs(np.diagonal(factors, axis1=1, axis2=2)) > 0.0, axis=1))
    if not inside.any():
        return None
    mean = rows[inside, 1:1 + p]
    # the conditional sds: the precision's Cholesky factor L (triangular, its diagonal
    # nonzero), covariance (L L')^-1
    inverse = np.linalg.inv(factors[inside])
    sd = np.sqrt(np.einsum("nji,nji->ni", inverse, inverse))
    lowest, highest = np.min(mean - _Z95 * sd, axis=0), np.max(mean + _Z95 * sd, axis=0)
    noise_at = list(enumerate(target.marginal, start=0))[target.n_positive:]
    allowed_levels = np.exp(levels[inside])
    ranges, widening, at = {}, {}, {}
    for j, index in enumerate(target.real):
        name = names[index]
        ranges[name] = (float(lowest[j]), float(highest[j]))
        widest = int(np.argmax(sd[:, j]))
        widening[name] = float(sd[widest, j] / posterior.summary[name]["sd"])
        at[name] = {names[i]: float(allowed_levels[widest, k]) for k, i in noise_at}
    upper = {names[i]: float(allowed_levels[:, k].max()) for k, i in noise_at}
    return AllowedNoise(upper=upper, ranges=ranges, widening=widening, at=at,
                        evaluated=int(levels.shape[0]), allowed=int(inside.sum()))


def _posterior_levels(problem, target, posterior, rng: np.random.Generator
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The marginal coordinates the posterior came from with their ``solved`` rows: those
    importance sampling weighed (all of them, already evaluated), else at most
    :data:`POSTERIOR_LEVELS` of a chain's distinct draws, evaluated here."""
    if posterior.evaluated is not None:
        return posterior.evaluated
    u = problem.to_sampling_host(posterior.draws.reshape(-1, len(problem.names)))
    drawn = np.unique(u[:, target.marginal], axis=0)
    if drawn.shape[0] > POSTERIOR_LEVELS:
        drawn = drawn[rng.choice(drawn.shape[0], POSTERIOR_LEVELS, replace=False)]
    return drawn, in_chunks(target.solved, drawn, BATCH)


def _log_likelihood(target, levels: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The marginal log-likelihood at ``levels`` from their ``solved`` rows: the marginal
    log-posterior with the weak priors of the noise levels taken out (measured ones, and a
    time constant's, kept); -inf where it is not finite."""
    log_lik = rows[:, 0].copy()
    for index, loc, scale in target.tails:
        if scale >= WEAK_FROM:
            log_lik -= stats.norm.logpdf(levels[:, index], loc, scale)
    return np.where(np.isfinite(log_lik), log_lik, -np.inf)
