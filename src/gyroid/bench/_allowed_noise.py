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

The same holds between noise models: a Gauss-Markov bias is flat beyond its correlation
time, where flicker and a walk rise. Under ``--noise white+gm`` a log whose wander is
flicker and a walk reads as a bump standing in for the wander at the scales the log
resolves, its coefficients' intervals too narrow at the hour scales that decide them: on
the MEMS benches of ``experiments/mems_thermal_bench.py`` 4 of 5 fits had a truth 2.6-5.1
sd outside its interval, every check passed, and the default fitted those logs better by
5-16 nats. Nothing in the residuals says so; the likelihoods do. So under a correlated model other
than the default's terms the default's levels are explored on the same rows too
(:func:`other_noise_model`), and the region is over both: a coefficient's widest there is
its conditional sd and its mean's shift from the posterior's in quadrature.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from gyroid.inference._batching import in_chunks
from gyroid.inference._check_report import Check
from gyroid.inference._importance import BATCH
from gyroid.noise._model import NoiseModel

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
class OtherNoise:
    """The other noise model a fit's range also spans (:func:`other_noise_model`): its
    name, its best marginal log-likelihood over the fit's own (nats; negative: worse) and
    how many of its levels the log allows."""

    model: str
    gain: float
    allowed: int

    def to_json(self) -> dict:
        return {"model": self.model, "log_likelihood_gain": self.gain,
                "levels_allowed": self.allowed}


@dataclass(frozen=True)
class AllowedNoise:
    """The noise levels a log allows and what they do to each coefficient."""

    upper: dict[str, float]  # each noise level's largest allowed value, natural units
    ranges: dict[str, tuple[float, float]]  # coefficient: union of conditional 95 % CIs
    #: coefficient: its largest conditional sd over the allowed levels / its posterior sd
    #: (under the other noise model: that sd and the shift of its conditional mean from the
    #: posterior mean, in quadrature)
    widening: dict[str, float]
    at: dict[str, dict[str, float]]  # coefficient: the allowed levels of that largest sd
    evaluated: int  # noise levels evaluated
    allowed: int  # of which inside the likelihood region
    units: dict[str, str] = field(default_factory=dict)  # each level's unit
    #: the fit's noise model, and the coefficients whose widest is the other model's
    model: str = ""
    under_other: frozenset[str] = frozenset()
    other: OtherNoise | None = None

    @property
    def own_allowed(self) -> int:
        """Of the allowed levels, the fit's own noise model's."""
        return self.allowed - (self.other.allowed if self.other is not None else 0)

    @property
    def widest(self) -> tuple[str, float]:
        """The coefficient whose sd widens most, and by how much."""
        name = max(self.widening, key=self.widening.__getitem__)
        return name, self.widening[name]

    def check(self) -> Check:
        """A warning when some coefficient's sd at levels the log allows is
        :data:`SAID_FROM` times its posterior sd or more: the stated intervals rest on the
        noise levels' priors (or on the choice of noise model); an error beyond
        :data:`TRUSTED_UP_TO` times: the interval is the priors' answer, and the fit is not
        to be used (exit 3)."""
        name, factor = self.widest
        low, high = self.ranges[name]
        digits = int(np.clip(np.ceil(np.log10(max(abs(low), abs(high), 1e-300)
                                              / max(high - low, 1e-300))) + 2, 3, 12))
        levels = ", ".join(f"{k} = {v:.2g} {self.units.get(k, '')}".rstrip()
                           for k, v in self.at[name].items())
        span = f"[{low:.{digits}g}, {high:.{digits}g}]"
        other = self.other
        fits = "" if other is None else (
            f"{other.model}, which fits this log "
            + ("better" if other.allowed and not self.own_allowed else
               "as well" if other.allowed else "worse")
            + f" ({other.gain:+.1f} nats of log-likelihood)")
        compared = "" if other is None else (
            f"; under {fits}, its allowed levels were counted too" if other.allowed
            else f"; {fits}, is ruled out")
        untrusted = factor > TRUSTED_UP_TO
        if factor < SAID_FROM:
            return Check(
                name="noise_prior_dependence", passed=True, severity="warning",
                value=round(factor, 3), threshold=SAID_FROM,
                message=(f"at the noise levels this log allows ({levels}) {name}'s sd is at "
                         f"most {factor:.1f}x its posterior sd (95 % range over them "
                         f"{span}): the intervals do not rest on the noise levels' priors"
                         + compared))
        remedies: tuple[str, ...] = ()
        if other is not None and name in self.under_other:
            # the finding first: a console line shows a warning up to its first colon
            what = (f"the intervals rest on the choice of {self.model} over {fits}: under "
                    f"it, at levels the log does not rule out ({levels}), {name}'s sd and "
                    f"the shift of its mean come to {factor:.1f}x its posterior sd (95 % "
                    f"range over both models' allowed levels {span})")
            remedy = (f"; {other.model} (--noise auto) carries the wander a "
                      f"{self.model} fit cannot, and noise measured at rest (gyroid noise, "
                      "then fit with --noise DIR) or a longer log narrows it")
            remedies = ("noise_model",)
        else:
            what = (f"at noise levels this log does not rule out ({levels}) {name}'s sd "
                    f"is {factor:.1f}x its posterior sd (95 % range over such levels "
                    f"{span}): the intervals rest on the noise levels' priors")
            remedy = ("; the gyro's datasheet (fit with --noise FILE.toml), noise measured "
                      "at rest (gyroid noise, then fit with --noise DIR) or a longer log "
                      "narrows this")
        return Check(
            name="noise_prior_dependence", passed=False,
            severity="error" if untrusted else "warning", value=round(factor, 3),
            threshold=TRUSTED_UP_TO if untrusted else SAID_FROM,
            message=(what + (f", more than {TRUSTED_UP_TO:g}x, so they are not an answer"
                             if untrusted else "") + remedy), remedies=remedies)

    def to_json(self) -> dict:
        out = {"likelihood_region": REGION, "levels_up_to": self.upper,
               "ci95": {k: list(v) for k, v in self.ranges.items()},
               "sd_widening": self.widening, "widest_at": self.at,
               "levels_evaluated": self.evaluated, "levels_allowed": self.allowed}
        if self.other is not None:
            out["other_noise_model"] = {**self.other.to_json(),
                                        "widest_under_it": sorted(self.under_other)}
        return out


def other_noise_model(problem) -> NoiseModel | None:
    """The noise model a bench fit's range also spans: its noise model's
    :attr:`~gyroid.noise.NoiseModel.rival` (the default, for another correlated model; on
    the MEMS benches of ``experiments/mems_thermal_bench.py`` ``--noise white+gm`` fits had
    truths 2.6-5.1 of their sds away and the default fitted those logs 5-16 nats better),
    on the same rows; none on a burst log's segment means (which the default does not
    read)."""
    return None if problem.reads_segment_means else problem.noise.rival


@dataclass(frozen=True)
class _Explored:
    """Marginal coordinates evaluated under one noise model: the levels, their ``solved``
    rows and log-likelihoods, and the names and units of the levels."""

    levels: np.ndarray
    rows: np.ndarray
    log_lik: np.ndarray
    level_names: tuple[str, ...]
    units: dict[str, str]
    first_level: int  # the first noise level among the marginal coordinates

    @classmethod
    def about(cls, problem, target, drawn: np.ndarray, rows: np.ndarray,
              rng: np.random.Generator) -> _Explored:
        """``drawn`` levels (``rows`` their ``solved`` rows) and :data:`BOX_LEVELS` drawn
        uniformly in a box about those the log allows among them, reaching :data:`ABOVE`
        log units above them for each level with a prior."""
        drop = stats.chi2.ppf(REGION, drawn.shape[1]) / 2.0
        log_lik = _log_likelihood(target, drawn, rows)
        near = drawn[log_lik >= log_lik.max() - drop] if np.isfinite(log_lik).any() else drawn
        low, high = near.min(axis=0) - BESIDE, near.max(axis=0) + BESIDE
        for index, _, _ in target.tails:
            high[index] += ABOVE - BESIDE
        box = rng.uniform(low, high, (BOX_LEVELS, low.size))
        box_rows = in_chunks(target.solved, box, BATCH)
        names = tuple(problem.names[i] for i in target.marginal[target.n_positive:])
        return cls(np.concatenate([drawn, box]), np.concatenate([rows, box_rows]),
                   np.concatenate([log_lik, _log_likelihood(target, box, box_rows)]),
                   names, problem.noise.units, target.n_positive)

    def inside(self, best: float, drop: float, p: int) -> np.ndarray:
        """Which levels the log allows: within ``drop`` of the ``best`` log-likelihood, with
        finite rows and a nonsingular precision factor (``p`` coefficients)."""
        factors = self.rows[:, 1 + p:].reshape(-1, p, p)
        return ((self.log_lik >= best - drop)  # -inf where not finite: never inside
                & np.all(np.isfinite(self.rows[:, 1:]), axis=1)
                & np.all(np.abs(np.diagonal(factors, axis1=1, axis2=2)) > 0.0, axis=1))

    def conditional(self, inside: np.ndarray, p: int) -> tuple[np.ndarray, np.ndarray]:
        """The coefficients' conditional means and sds at the allowed levels: the
        precision's Cholesky factor L (triangular, its diagonal nonzero), covariance
        (L L')^-1."""
        factors = self.rows[inside, 1 + p:].reshape(-1, p, p)
        inverse = np.linalg.inv(factors)
        return self.rows[inside, 1:1 + p], np.sqrt(np.einsum("nji,nji->ni", inverse, inverse))


def allowed_noise(problem, posterior, seed: int = 0) -> AllowedNoise | None:
    """:class:`AllowedNoise` of a bench fit whose coefficients its marginal integrates out
    (any noise model: under white noise the one level is pinned by the rows, and the range
    says so) and that has a posterior; None otherwise (no posterior, no coefficient
    integrated out, or no noise level sampled: a known sigma). Under
    :func:`other_noise_model`'s cases the other model's levels near its marginal mode are
    explored too, on the same rows, and the likelihood region is over both."""
    if posterior is None:
        return None
    target = problem.marginal_target()
    if target is None or not target.real.size or not target.marginal.size:
        return None
    rng = np.random.default_rng([seed, 952])
    explored = [_Explored.about(problem, target, *_posterior_levels(problem, target,
                                                                    posterior, rng), rng)]
    other_model = other_noise_model(problem)
    if other_model is not None:
        explored.append(_about_mode(problem.under_noise(other_model), rng))
    best = max(float(e.log_lik.max()) for e in explored)
    if not np.isfinite(best):
        return None
    drop = float(stats.chi2.ppf(REGION, max(e.levels.shape[1] for e in explored))) / 2.0
    p = target.real.size
    names = [problem.names[i] for i in target.real]
    post_mean = np.array([posterior.summary[n]["mean"] for n in names])
    post_sd = np.array([posterior.summary[n]["sd"] for n in names])
    lowest, highest = np.full(p, np.inf), np.full(p, -np.inf)
    widening, at, upper = np.zeros(p), [{} for _ in names], {}
    widest_other = np.zeros(p, dtype=bool)
    allowed_each = []
    for k, part in enumerate(explored):
        inside = part.inside(best, drop, p)
        allowed_each.append(int(inside.sum()))
        if not inside.any():
            continue
        mean, sd = part.conditional(inside, p)
        lowest = np.minimum(lowest, np.min(mean - _Z95 * sd, axis=0))
        highest = np.maximum(highest, np.max(mean + _Z95 * sd, axis=0))
        scale = sd if k == 0 else np.sqrt(sd**2 + (mean - post_mean) ** 2)
        natural = np.exp(part.levels[inside][:, part.first_level:])
        for j in range(p):
            widest = int(np.argmax(scale[:, j]))
            factor = float(scale[widest, j] / post_sd[j])
            if factor > widening[j]:
                widening[j], widest_other[j] = factor, k > 0
                at[j] = dict(zip(part.level_names, map(float, natural[widest]), strict=True))
        upper.update({n: float(v) for n, v in zip(part.level_names, natural.max(axis=0),
                                                   strict=True)})
    if not sum(allowed_each):
        return None
    other = None if other_model is None else OtherNoise(
        other_model.name, float(explored[1].log_lik.max() - explored[0].log_lik.max()),
        allowed_each[1])
    return AllowedNoise(
        upper=upper, ranges={n: (float(lowest[j]), float(highest[j]))
                             for j, n in enumerate(names)},
        widening=dict(zip(names, map(float, widening), strict=True)),
        at=dict(zip(names, at, strict=True)),
        evaluated=sum(e.levels.shape[0] for e in explored), allowed=sum(allowed_each),
        units={k: v for e in explored for k, v in e.units.items()},
        model=problem.noise.name,
        under_other=frozenset(n for j, n in enumerate(names) if widest_other[j]),
        other=other)


def _about_mode(problem, rng: np.random.Generator) -> _Explored:
    """A problem's levels explored about its marginal mode: :data:`POSTERIOR_LEVELS` drawn
    from the Gaussian of the mode's inverse Hessian (the mode among them), then the box
    about those the log allows (:meth:`_Explored.about`)."""
    target = problem.marginal_target()
    point = problem.mode()
    marginal = target.marginal
    centre = np.asarray(point.u)[marginal]
    covariance = np.asarray(point.covariance_u)[np.ix_(marginal, marginal)]
    if not np.all(np.isfinite(covariance)):
        covariance = np.eye(centre.size)
    drawn = np.vstack([centre, rng.multivariate_normal(centre, covariance,
                                                       POSTERIOR_LEVELS - 1,
                                                       check_valid="ignore")])
    return _Explored.about(problem, target, drawn, in_chunks(target.solved, drawn, BATCH), rng)


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
