"""Fitting paper B's loop parameters to a roll log (contract section 4).

The SINS output ``w_x`` is inverted for the true rate, ``w = (w_x - D0) / (1 + D1)``, and
integrated into the roll angle; the stabiliser's angle is then predicted as
``psi0 + psi + platform error + encoder error`` with

* platform error ``int (D1gs m + D0gs) / (1 + D1gs) dt`` when the log has the stabiliser's
  MEMS output ``m`` (``gs_rate_deg_s``: then ``w_H = (m - D0gs) / (1 + D1gs)``), else
  ``D0gs t`` (an ideal stabiliser);
* encoder error ``a sin(psi) + b cos(psi)``: ``Denc = hypot(a, b)``, phase ``atan2(b, a)``.

The residual is the encoder's read-out noise (white, ``sigma_gs_deg``) plus the SINS gyro's
noise integrated into the angle (a random walk, ``sigma_sins_deg_s`` per sample); the exact
Gaussian likelihood comes from a Kalman filter. When the stabiliser is ideal (``m`` near
zero) its MEMS output is also an observation of ``D0gs`` (``m ~ N(D0gs, sigma_m)``): that is
what separates ``D0gs`` from the SINS bias ``D0``, which otherwise enter only through their
difference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from gyroid.checks import CheckReport, FitEvidence, fit_checks, point_fit_evidence
from gyroid.errors import GyroidInputError
from gyroid.priors import LogNormal, Normal, Prior, natural_with_sd
from gyroid.tables import check_plausible, check_time_increasing, read_log_table

_LOG_2PI = math.log(2.0 * math.pi)
DEG = math.pi / 180.0
#: The stabiliser angle enters the likelihood at about this many rows (see RollProblem).
MAX_OBSERVED_ROWS = 1000


#: Roll-side effects: their parameters and whether paper B's ideal loop has them.
ROLL_EFFECTS: dict[str, dict] = {
    "sf_error": {"parameters": ("D1",), "candidate": False,
                 "what": "the SINS roll gyro's SF error D1"},
    "gs_bias": {"parameters": ("D0gs",), "candidate": False,
                "what": "the stabiliser's MEMS bias D0gs"},
    "roll_bias": {"parameters": ("D0",), "candidate": True,
                  "what": "an additive SINS roll-gyro bias D0"},
    "gs_rate_leak": {"parameters": ("D1gs",), "candidate": True,
                     "what": "an overloaded stabiliser integrating its uncompensated rate with "
                             "SF error D1gs (needs gs_rate_deg_s)"},
    "encoder_error": {"parameters": ("enc_a", "enc_b"), "candidate": True,
                      "what": "an encoder error periodic per revolution, a sin(psi) + b cos(psi)"},
    "sf_nonlinearity": {"parameters": ("D2",), "candidate": True,
                        "what": "SF error growing with |w|: D2 per 1000 deg/s"},
}
ROLL_PRESETS = {"ideal": ("sf_error", "gs_bias"),
                "loop": ("sf_error", "gs_bias", "roll_bias", "gs_rate_leak", "encoder_error")}
_ROLL_PRIORS = {"D0": Normal(0.0, 0.1), "D1": Normal(0.0, 2e-3), "D0gs": Normal(0.0, 0.02),
                "D1gs": Normal(0.0, 1e-3), "enc_a": Normal(0.0, 1.0),
                "enc_b": Normal(0.0, 1.0), "D2": Normal(0.0, 1e-3)}


def resolve_roll_terms(spec) -> tuple[str, ...]:
    items = spec.split(",") if isinstance(spec, str) else list(spec)
    chosen: set[str] = set()
    for raw in items:
        item = raw.strip()
        if item in ROLL_PRESETS:
            chosen.update(ROLL_PRESETS[item])
        elif item in ROLL_EFFECTS:
            chosen.add(item)
        elif item:
            raise GyroidInputError(f"unknown roll term {item!r}; use a preset "
                                   f"({', '.join(ROLL_PRESETS)}) or {', '.join(ROLL_EFFECTS)}")
    chosen.update(("sf_error", "gs_bias"))
    return tuple(name for name in ROLL_EFFECTS if name in chosen)


@dataclass(frozen=True)
class RollLog:
    time_s: np.ndarray
    roll_rate_deg_s: np.ndarray
    gs_angle_deg: np.ndarray
    gs_rate_deg_s: np.ndarray | None
    source: str = "<memory>"
    notes: tuple[str, ...] = ()  # what loading changed (e.g. an unwrapped encoder angle)

    @property
    def n(self) -> int:
        return int(self.time_s.size)


def load_roll_log(path, column_map=()) -> RollLog:
    """Read and validate a roll log (contract section 4; .csv, .csv.gz or .parquet).

    A stabiliser angle that wraps (to [0, 360) or by one whole turn somewhere) is unwrapped
    with a note when every jump is a whole number of turns away from what the SINS rate
    predicts; a jump that is not is refused, naming its row."""
    table = read_log_table(path, tuple(column_map))
    if table.has("drift_deg_h") and not table.has("roll_rate_deg_s"):
        raise GyroidInputError(f"{table.path.name} is a bench log (it has drift_deg_h, no "
                               "roll_rate_deg_s): use 'gyroid fit' or 'gyroid discrepancy' "
                               "with drift terms")
    time_s = table.number_column("time_s")
    columns = {name: table.number_column(name, "a roll log needs roll_rate_deg_s and "
                                               "gs_angle_deg (contract section 4); map yours "
                                               f"with --map {name}=COLUMN[:UNIT]")
               for name in ("roll_rate_deg_s", "gs_angle_deg")}
    gs_rate = table.number_column("gs_rate_deg_s") if table.has("gs_rate_deg_s") else None
    for name, values in (("time_s", time_s), *columns.items(),
                         *((("gs_rate_deg_s", gs_rate),) if gs_rate is not None else ())):
        check_plausible(table, name, values)
    check_time_increasing(table, time_s)
    steps = np.diff(time_s)
    if steps.size and np.ptp(steps) > 1e-6 * np.median(steps):
        bad = int(np.argmax(np.abs(steps - np.median(steps)) > 1e-6 * np.median(steps))) + 1
        raise GyroidInputError(f"{table.path.name}: the roll log must be uniformly sampled; the "
                               f"step changes at {table.where(bad)}; resample the log")
    if table.n_rows < 50:
        raise GyroidInputError(f"{table.path.name}: {table.n_rows} rows are too few for a fit")
    angle, notes = unwrap_gs_angle(table, time_s, columns["roll_rate_deg_s"],
                                   columns["gs_angle_deg"])
    return RollLog(time_s, columns["roll_rate_deg_s"], angle, gs_rate, str(table.path),
                   tuple(notes))


#: A stabiliser-angle step further than this from the SINS-predicted step is a jump, deg.
JUMP_TOLERANCE_DEG = 45.0


def unwrap_gs_angle(table, time_s, roll_rate_deg_s, gs_angle_deg
                    ) -> tuple[np.ndarray, list[str]]:
    """Unwrap whole-turn jumps of the encoder angle (see :func:`load_roll_log`)."""
    dt = np.diff(time_s)
    predicted = 0.5 * (roll_rate_deg_s[1:] + roll_rate_deg_s[:-1]) * dt
    surprise = np.diff(gs_angle_deg) - predicted
    jumps = np.flatnonzero(np.abs(surprise) > JUMP_TOLERANCE_DEG)
    if not jumps.size:
        return gs_angle_deg, []
    turns = np.round(surprise[jumps] / 360.0)
    off = np.abs(surprise[jumps] - 360.0 * turns)
    bad = jumps[(turns == 0) | (off > JUMP_TOLERANCE_DEG)]
    if bad.size:
        i = int(bad[0]) + 1
        raise GyroidInputError(
            f"{table.path.name}: gs_angle_deg jumps by {np.diff(gs_angle_deg)[i - 1]:.6g} deg at "
            f"{table.where(i)} where the roll rate predicts {predicted[i - 1]:.6g} deg: not a "
            "whole turn, so it cannot be unwrapped; fix the encoder log (gyroid needs the "
            "unwrapped angle)")
    correction = np.zeros(gs_angle_deg.size)
    correction[jumps + 1] = -360.0 * turns
    unwrapped = gs_angle_deg + np.cumsum(correction)
    first = int(jumps[0]) + 1
    note = (f"gs_angle_deg was wrapped: {jumps.size} whole-turn jump(s), the first at "
            f"{table.where(first)}; unwrapped with the SINS rate as a guide")
    return unwrapped, [note]


#: Every roll-side parameter in one fixed order. The likelihood reads a model's parameters
#: into this vector through an index array, so every model of one log (the discrepancy
#: workflow's candidates) shares one compilation.
ALL_PARAMETERS = ("psi0", "D0", "D1", "D0gs", "D1gs", "enc_a", "enc_b", "D2", "sigma_gs_deg",
                  "sigma_sins_deg_s", "sigma_m_deg_s")
#: Values of the parameters a model leaves out: absent effects are 0; ``sigma_m_deg_s`` only
#: enters for an ideal stabiliser (its term is switched off otherwise), 1 keeps it finite.
_ABSENT = np.array([0.0] * 8 + [1.0, 1.0, 1.0])


class RollDensity(eqx.Module):
    """The JAX part of a roll problem on a vector ``v`` over all of ``ALL_PARAMETERS`` (in
    sampling coordinates); the entries outside the model (``active == 0``) are ignored.
    Arrays only, plus the block count and whether ``D2`` is in the model: every model of
    one log (the discrepancy workflow's candidates) has the same shapes and shares one
    compilation of the optimiser. Priors are normal on the sampling coordinate
    (``prior_loc``, ``prior_scale``).

    The likelihood costs O(observed rows), not O(samples): every per-sample sum it needs is
    a fixed sum of the data times a parameter, precomputed once (``cum_sins``,
    ``cum_gs_rate``, and per observed row the count, mean and spread of the MEMS samples).
    Only ``D2`` (a scale factor varying with |w|) needs the per-sample cumulative sum.
    """

    time_s: jax.Array  # elapsed time of every sample, s
    sins: jax.Array
    gs_angle: jax.Array
    gs_rate: jax.Array  # zeros when the log has none (then D1gs is never in the model)
    cum_sins: jax.Array  # int w_x dt, deg
    cum_gs_rate: jax.Array  # int m dt, deg
    block: jax.Array
    observed: jax.Array  # indices of the rows whose stabiliser angle enters the likelihood
    m_count: jax.Array  # MEMS samples owned by each observed row (ideal stabiliser)
    m_mean: jax.Array  # their mean, deg/s
    m_spread: jax.Array  # their sum of squares about that mean, (deg/s)^2
    sample_s: jax.Array
    ideal_gs: jax.Array  # 1.0: m ~ N(D0gs, sigma_m) is also an observation; else 0.0
    active: jax.Array
    positive: jax.Array
    prior_loc: jax.Array
    prior_scale: jax.Array
    n_blocks: int = eqx.field(static=True)
    has_d2: bool = eqx.field(static=True)

    def parameters(self, v) -> dict:
        """Every parameter of ``ALL_PARAMETERS`` in natural units (absent ones at rest)."""
        natural = jnp.where(self.positive, jnp.exp(v), v)
        return dict(zip(ALL_PARAMETERS, jnp.where(self.active > 0, natural, _ABSENT),
                        strict=True))

    def _predict_rows(self, v, rows):
        """The stabiliser's angle at ``rows`` (indices, or a slice), deg."""
        p = self.parameters(v)
        t = self.time_s[rows]
        if self.has_d2:
            scale = 1.0 + p["D1"] + p["D2"] * jnp.abs(self.sins) / 1000.0
            psi = (jnp.cumsum((self.sins - p["D0"]) / scale) * self.sample_s)[rows]
        else:  # int (w_x - D0) / (1 + D1) dt
            psi = (self.cum_sins[rows] - p["D0"] * t) / (1.0 + p["D1"])
        # int (D1gs m + D0gs) / (1 + D1gs) dt; with D1gs = 0 (absent) this is D0gs t.
        platform = (p["D1gs"] * self.cum_gs_rate[rows] + p["D0gs"] * t) / (1.0 + p["D1gs"])
        encoder = p["enc_a"] * jnp.sin(psi * DEG) + p["enc_b"] * jnp.cos(psi * DEG)
        return p["psi0"] + psi + platform + encoder

    def predict(self, v):
        """The stabiliser's angle at every sample, deg."""
        return self._predict_rows(v, slice(None))

    def innovations(self, v):
        """Kalman innovations of the stabiliser angle at the observed rows and their
        variances, deg and deg^2."""
        p = self.parameters(v)
        residual = self.gs_angle[self.observed] - self._predict_rows(v, self.observed)
        steps = jnp.diff(self.observed, prepend=-1)  # rows since the previous observation
        q = (p["sigma_sins_deg_s"] * self.sample_s) ** 2 * steps  # angle random walk
        r = p["sigma_gs_deg"] ** 2

        # The filter's mean follows the innovations; run it on (state, var) jointly.
        def kalman(carry, row):
            e, q_k = row
            mean, var = carry
            prior_var = var + q_k
            total = prior_var + r
            innovation = e - mean
            gain = prior_var / total
            return (mean + gain * innovation, (1.0 - gain) * prior_var), (innovation, total)

        _, (innovation, total) = jax.lax.scan(kalman, (jnp.zeros(()), jnp.zeros(())),
                                              (residual, q))
        return innovation, total

    def log_likelihood_rows(self, v):
        p = self.parameters(v)
        innovation, total = self.innovations(v)
        rows = -0.5 * (innovation**2 / total + jnp.log(total) + _LOG_2PI)
        # Ideal stabiliser: every MEMS sample observes D0gs, m ~ N(D0gs, sigma_m); the
        # samples' log-densities summed onto the observed row that owns them.
        sigma_m = p["sigma_m_deg_s"]
        squares = self.m_spread + self.m_count * (self.m_mean - p["D0gs"]) ** 2
        m_rows = -0.5 * squares / sigma_m**2 - self.m_count * (0.5 * _LOG_2PI
                                                                + jnp.log(sigma_m))
        return rows + self.ideal_gs * m_rows

    def log_likelihood_blocks(self, v):
        return jax.ops.segment_sum(self.log_likelihood_rows(v), self.block, self.n_blocks)

    def log_prior(self, v):
        z = (v - self.prior_loc) / self.prior_scale
        return jnp.sum(self.active * (-0.5 * z**2 - jnp.log(self.prior_scale) - 0.5 * _LOG_2PI))

    def log_posterior(self, v):
        value = jnp.sum(self.log_likelihood_rows(v)) + self.log_prior(v)
        return jnp.where(jnp.isfinite(value), value, -jnp.inf)


class ModelDensity(eqx.Module):
    """A model's densities on its own sampling coordinates ``u``: ``u[i]`` is entry
    ``slot[i]`` of the full vector of ``RollDensity`` (what the sampler sees)."""

    full: RollDensity
    slot: jax.Array

    def spread(self, u):
        """The model's coordinates placed in a vector over ``ALL_PARAMETERS``."""
        return jnp.zeros(len(ALL_PARAMETERS)).at[self.slot].set(u)

    def to_natural(self, u):
        return jnp.where(self.full.positive[self.slot], jnp.exp(u), u)

    def predict(self, u):
        return self.full.predict(self.spread(u))

    def log_likelihood_rows(self, u):
        return self.full.log_likelihood_rows(self.spread(u))

    def standardised_residuals(self, u):
        """Innovations over their sd: independent N(0, 1) when the model is right."""
        innovation, total = self.full.innovations(self.spread(u))
        return innovation / jnp.sqrt(total)

    def log_likelihood_blocks(self, u):
        return self.full.log_likelihood_blocks(self.spread(u))

    def log_prior(self, u):
        return self.full.log_prior(self.spread(u))

    def log_posterior(self, u):
        return self.full.log_posterior(self.spread(u))


def _normal_on_u(prior: Prior) -> tuple[float, float]:
    """(loc, scale) of a prior as a normal density on the sampling coordinate."""
    if isinstance(prior, LogNormal):
        return math.log(prior.median), prior.log_sd
    return prior.loc, prior.scale


@dataclass(frozen=True)
class RollProblem:
    """Posterior of the roll-loop parameters given a roll log: the model's description
    (terms, parameter names, priors) around its ``density`` (the JAX part)."""

    density: ModelDensity
    has_gs_rate: bool
    use_gs_rate: bool  # the platform error integrates m (gs_rate_leak is in the model)
    ideal_gs: bool  # m ~ D0gs: also an observation of D0gs
    terms: tuple[str, ...]
    names: tuple[str, ...]
    priors: tuple[Prior, ...]
    positive: tuple[bool, ...]

    @classmethod
    def from_log(cls, log: RollLog, terms="loop") -> RollProblem:
        sample_s = float(np.median(np.diff(log.time_s)))
        has_rate = log.gs_rate_deg_s is not None
        # Ideal: the platform is never left turning (the MEMS reads only its bias and noise).
        ideal = bool(has_rate and np.percentile(np.abs(log.gs_rate_deg_s), 99) < 1.0)
        terms = resolve_roll_terms(terms)
        if "gs_rate_leak" in terms and (not has_rate or ideal):
            # Without m, or with m ~ D0gs (an ideal stabiliser), D1gs cannot be seen.
            terms = tuple(t for t in terms if t != "gs_rate_leak")
        spec: list[tuple[str, Prior, bool]] = [("psi0", Normal(0.0, 10.0), False)]
        for term in terms:
            for name in ROLL_EFFECTS[term]["parameters"]:
                spec.append((name, _ROLL_PRIORS[name], False))
        spec += [("sigma_gs_deg", LogNormal(0.01, 2.0), True),
                 ("sigma_sins_deg_s", LogNormal(0.02, 2.0), True)]
        if ideal:
            spec.append(("sigma_m_deg_s", LogNormal(0.01, 3.0), True))
        # The angle comparison is informative on slow time scales: the likelihood uses every
        # stride-th row (exact for this noise model: the random walk's increments over a
        # stride add up), with an odd stride so the encoder phase keeps moving.
        stride = max(1, log.n // MAX_OBSERVED_ROWS)
        stride += 1 - stride % 2
        observed = np.arange(stride - 1, log.n, stride)
        t_obs = log.time_s[observed]
        block = np.floor((t_obs - t_obs[0]) / max(1.0, (t_obs[-1] - t_obs[0]) / 500.0))
        _, block = np.unique(block.astype(int), return_inverse=True)
        names = tuple(n for n, _, _ in spec)
        priors = tuple(p for _, p, _ in spec)
        positive = tuple(f for _, _, f in spec)
        slot = [ALL_PARAMETERS.index(n) for n in names]
        loc, scale = np.zeros(len(ALL_PARAMETERS)), np.ones(len(ALL_PARAMETERS))
        loc[slot], scale[slot] = np.array([_normal_on_u(p) for p in priors]).T
        active = np.zeros(len(ALL_PARAMETERS))
        active[slot] = 1.0
        positive_all = np.zeros(len(ALL_PARAMETERS), dtype=bool)
        positive_all[slot] = positive
        gs_rate = np.asarray(log.gs_rate_deg_s if has_rate else np.zeros(log.n), dtype=float)
        # Each MEMS sample belongs to the first observed row at or after it (the samples after
        # the last observed row to the last).
        owner = np.minimum(np.searchsorted(observed, np.arange(log.n)), observed.size - 1)
        m_count = np.bincount(owner, minlength=observed.size).astype(float)
        m_mean = np.bincount(owner, gs_rate, observed.size) / np.maximum(m_count, 1.0)
        m_spread = np.bincount(owner, (gs_rate - m_mean[owner]) ** 2, observed.size)
        full = RollDensity(
            time_s=jnp.asarray(log.time_s - log.time_s[0] + sample_s),
            sins=jnp.asarray(log.roll_rate_deg_s),
            gs_angle=jnp.asarray(log.gs_angle_deg),
            gs_rate=jnp.asarray(gs_rate),
            cum_sins=jnp.asarray(np.cumsum(log.roll_rate_deg_s) * sample_s),
            cum_gs_rate=jnp.asarray(np.cumsum(gs_rate) * sample_s),
            block=jnp.asarray(block),
            observed=jnp.asarray(observed),
            m_count=jnp.asarray(m_count),
            m_mean=jnp.asarray(m_mean),
            m_spread=jnp.asarray(m_spread),
            sample_s=jnp.asarray(sample_s),
            ideal_gs=jnp.asarray(float(ideal)),
            active=jnp.asarray(active),
            positive=jnp.asarray(positive_all),
            prior_loc=jnp.asarray(loc),
            prior_scale=jnp.asarray(scale),
            n_blocks=int(block.max()) + 1,
            has_d2="D2" in names,
        )
        density = ModelDensity(full, jnp.asarray(slot))
        return cls(density, has_rate, "gs_rate_leak" in terms, ideal, terms, names, priors,
                   positive)

    # ----- the log, as the fit sees it -------------------------------------------------------
    @property
    def time_s(self):
        return self.density.full.time_s

    @property
    def sins(self):
        return self.density.full.sins

    @property
    def gs_angle(self):
        return self.density.full.gs_angle

    @property
    def gs_rate(self):
        return self.density.full.gs_rate if self.has_gs_rate else None

    @property
    def observed(self):
        return self.density.full.observed

    @property
    def sample_s(self) -> float:
        return float(self.density.full.sample_s)

    # ----- densities (delegated to the JAX part) ---------------------------------------------
    def to_natural(self, u):
        return self.density.to_natural(u)

    def to_sampling(self, x):
        mask = jnp.asarray(self.positive)
        return jnp.where(mask, jnp.log(jnp.where(mask, x, 1.0)), x)

    def values(self, u) -> dict:
        return dict(zip(self.names, self.to_natural(u), strict=True))

    def predict(self, u):
        return self.density.predict(u)

    def log_likelihood_rows(self, u):
        return self.density.log_likelihood_rows(u)

    def log_likelihood_blocks(self, u):
        return self.density.log_likelihood_blocks(u)

    def log_prior(self, u):
        return self.density.log_prior(u)

    def log_posterior(self, u):
        return self.density.log_posterior(u)

    # ----- ArviZ hooks -----------------------------------------------------------------------
    def observed_data(self):
        return {"gs_angle_deg": np.asarray(self.gs_angle)[np.asarray(self.observed)]}

    def constant_data(self):
        return {"time_s": np.asarray(self.time_s)[np.asarray(self.observed)],
                "loo_block": np.asarray(self.density.full.block)}

    def idata_attrs(self):
        return {"model": "paper B roll-correction loop", "ideal_stabiliser": str(self.ideal_gs)}


@dataclass
class RollPoint:
    names: tuple[str, ...]
    u: np.ndarray
    covariance_u: np.ndarray
    value: dict[str, float]
    sd: dict[str, float]
    converged: bool
    message: str


def _nlp_full(v, density: RollDensity):
    return -density.log_posterior(v)


_nlp_hessian = eqx.filter_jit(jax.hessian(_nlp_full))


@eqx.filter_jit
def _minimise(density: RollDensity, v0, scale):
    """BFGS in standardised coordinates (v = v0 + scale z) over all of ``ALL_PARAMETERS``,
    so that every model of a log shares one compilation: the entries outside the model have
    no gradient, so BFGS never moves them. Standardised because D1 is known to 1e-7 while
    the offsets are known to 1e-3: unscaled step tolerances would stop far too early."""

    def objective(z, args):
        return _nlp_full(v0 + scale * z, args)

    solution = optx.minimise(objective, optx.BFGS(rtol=1e-10, atol=1e-10), jnp.zeros_like(v0),
                             args=density, max_steps=5000, throw=False)
    v = v0 + scale * solution.value
    return v, solution.result, jax.hessian(_nlp_full)(v, density)


def roll_point_estimate(problem: RollProblem) -> RollPoint:
    """Linearised least squares for a start, then BFGS (optimistix) on the log-posterior;
    covariance from the inverse Hessian."""
    t = np.asarray(problem.time_s)
    psi_x = np.cumsum(np.asarray(problem.sins)) * problem.sample_s
    y = np.asarray(problem.gs_angle) - psi_x
    design = np.column_stack([np.ones_like(t), -psi_x, t, np.sin(psi_x * DEG),
                              np.cos(psi_x * DEG)])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    start = dict(psi0=coef[0], D0=0.0, D1=coef[1], D0gs=coef[2], D1gs=0.0, enc_a=coef[3],
                 enc_b=coef[4], D2=0.0, sigma_gs_deg=0.01, sigma_sins_deg_s=0.02,
                 sigma_m_deg_s=0.01)
    if problem.ideal_gs:
        start["D0gs"] = float(np.median(np.asarray(problem.gs_rate)))
        start["D0"] = start["D0gs"] - coef[2]
    x0 = np.array([start[n] for n in problem.names])
    slot = np.asarray(problem.density.slot)
    v0 = np.asarray(problem.density.spread(problem.to_sampling(jnp.asarray(x0))))
    # Scales from the curvature at the start (diagonal of the Hessian), floored for safety;
    # 1 for the parameters outside the model (they have no curvature).
    curvature = np.abs(np.diag(np.asarray(_nlp_hessian(jnp.asarray(v0), problem.density.full))))
    scale = 1.0 / np.sqrt(np.where(np.isfinite(curvature) & (curvature > 0), curvature, 1.0))
    value, result, hessian = _minimise(problem.density.full, jnp.asarray(v0), jnp.asarray(scale))
    ok = bool(result == optx.RESULTS.successful)
    message = "converged" if ok else optx.RESULTS[result].split("\n")[0]
    hessian = np.asarray(hessian)[np.ix_(slot, slot)]
    try:
        cov = np.linalg.inv(hessian)
    except np.linalg.LinAlgError:
        cov = np.full_like(hessian, np.nan)
    u = np.asarray(value)[slot]
    x, sd = natural_with_sd(u, cov, problem.positive)
    return RollPoint(problem.names, u, cov, dict(zip(problem.names, x.tolist(), strict=True)),
                     dict(zip(problem.names, sd.tolist(), strict=True)), ok, message)


CONFOUNDING_THRESHOLD = 0.9


@dataclass
class RollFit:
    problem: RollProblem
    point: RollPoint
    posterior: object
    summary: dict = field(default_factory=dict)
    checks: CheckReport = field(default_factory=lambda: CheckReport(()))
    notes: tuple[str, ...] = ()

    @property
    def trustworthy(self) -> bool:
        return self.checks.trustworthy

    def to_json(self) -> dict:
        post = self.posterior
        flat = post.draws.reshape(-1, len(self.problem.names))
        derived = {}
        if "enc_a" in self.problem.names:
            a = flat[:, self.problem.names.index("enc_a")]
            b = flat[:, self.problem.names.index("enc_b")]
            derived = {"Denc": np.hypot(a, b), "encoder_phase_rad": np.arctan2(b, a)}
        summary = {k: dict(v) for k, v in post.summary.items()}
        for name, values in derived.items():
            lo, hi = np.percentile(values, [2.5, 97.5])
            summary[name] = {"mean": float(values.mean()), "sd": float(values.std(ddof=1)),
                             "ci95": [float(lo), float(hi)], "derived_from": ["enc_a", "enc_b"]}
        loop_names = [n for n in ("D0", "D1", "D0gs", "D1gs", "D2") if n in self.problem.names]
        corr = np.corrcoef(flat[:, [self.problem.names.index(n) for n in loop_names]],
                           rowvar=False)
        confounded = []
        advice = {
            ("D0", "D0gs"): "log the stabiliser's MEMS output (gs_rate_deg_s) while it holds "
                            "the platform (ideal stabiliser): it measures D0gs alone",
            ("D1", "D1gs"): "vary the roll rate while the stabiliser stays unsaturated, or "
                            "hold it ideal for part of the flight: D1 then acts alone",
            ("D0", "D1"): "vary the roll rate (a ramp or a reversal): D1 scales with it, D0 "
                          "does not",
        }
        pairs = {(a_name, loop_names[j]): float(corr[i, j])
                 for i, a_name in enumerate(loop_names) for j in range(i + 1, len(loop_names))
                 if abs(corr[i, j]) > CONFOUNDING_THRESHOLD}
        # A pair without advice of its own is usually a consequence of advised pairs that
        # share a parameter with it (D0 ~ D0gs and D1 ~ D1gs make D0gs ~ D1gs): say so.
        advised = [pair for pair in pairs if pair in advice]
        for pair, r in pairs.items():
            item = {"parameters": list(pair), "correlation": r,
                    "identified": "only their combination"}
            if pair in advice:
                item["suggestion"] = advice[pair]
            else:
                causes = [p for p in advised if set(p) & set(pair)]
                item["follows_from"] = [list(p) for p in causes]
                item["suggestion"] = (
                    "separates once " + " and ".join(f"{a} and {b}" for a, b in causes)
                    + " are separated" if causes else
                    "no manoeuvre in gyroid's catalogue separates them: report their "
                    "combination")
            confounded.append(item)
        return {
            "terms": list(self.problem.terms),
            "parameters": {n: summary[n] for n in (*loop_names, *(["Denc"] if derived else []))},
            "point": {n: self.point.value[n] for n in self.problem.names},
            "point_sd": {n: self.point.sd[n] for n in self.problem.names},
            "posterior": summary,
            "confounded": confounded,
            "ideal_stabiliser_assumed": not self.problem.use_gs_rate,
            "gs_rate_used": bool(self.problem.gs_rate is not None
                                 and (self.problem.use_gs_rate or self.problem.ideal_gs)),
            "n_samples": int(self.problem.time_s.shape[0]),
            "convergence": {"point_estimate": self.point.message,
                            "sampler_steps": post.n_steps, "sampler_move": post.move,
                            "converged": post.converged},
            "units": {"D0": "deg/s", "D1": "relative", "D0gs": "deg/s", "D1gs": "relative",
                      "Denc": "deg", "psi0": "deg", "sigma_gs_deg": "deg",
                      "sigma_sins_deg_s": "deg/s"},
            "notes": list(self.notes),
            **self.checks.to_json(),
        }


def fit_roll_log(log: RollLog, *, seed: int = 0, settings=None) -> RollFit:
    from gyroid.sampling import sample_posterior

    problem = RollProblem.from_log(log)
    point = roll_point_estimate(problem)
    posterior = sample_posterior(problem, point, seed=seed, settings=settings)
    fit = RollFit(problem, point, posterior, notes=log.notes)
    fit.checks = fit_checks(roll_evidence(fit))
    return fit


_ROLL_HINTS = {
    "D1": "D1 needs a flight whose roll angle advances further (a longer or faster roll)",
    "D0": "D0 needs the stabiliser's MEMS output (gs_rate_deg_s) from an ideal stabiliser",
    "D0gs": "D0gs is told apart from D0 only by the stabiliser's MEMS output "
            "(gs_rate_deg_s) logged while the stabiliser holds the platform",
    "D1gs": "D1gs needs a stabiliser that is overloaded for part of the flight",
    "enc_a": "the encoder error needs whole turns of roll", "enc_b": "the encoder error "
    "needs whole turns of roll",
}


def roll_evidence(fit: RollFit) -> FitEvidence:
    """What the self-checks need from a roll fit (its priors are physical, so they are also
    the identifiability yardstick)."""
    problem, point, post = fit.problem, fit.point, fit.posterior
    n_model = sum(not n.startswith("sigma_") for n in problem.names)
    draws_u = np.asarray(problem.to_sampling(jnp.asarray(post.draws)))
    reference = {n: _normal_on_u(p)[1] for n, p in zip(problem.names, problem.priors,
                                                       strict=True)}
    residuals = np.asarray(problem.density.standardised_residuals(jnp.asarray(point.u)))
    return FitEvidence(
        names=problem.names, n_model=n_model, point_u=np.asarray(point.u),
        point_converged=point.converged, point_message=point.message,
        priors=problem.priors, reference_sd=reference, residuals=residuals,
        sigma_given=False, noise="white", draws_u=draws_u, summary=post.summary,
        hints=_ROLL_HINTS,
    )


# ----- the discrepancy workflow on roll logs ------------------------------------------------

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


def _max_log_likelihood(problem: RollProblem) -> tuple[float, RollPoint, np.ndarray]:
    point = roll_point_estimate(problem)
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


def find_roll_discrepancies(log: RollLog, terms="ideal", *, max_added: int = 3, progress=None,
                            residuals: dict | None = None) -> dict:
    """The discrepancy workflow for roll logs: roll-side candidates scored by dBIC (exact
    likelihood with the noise levels re-estimated per model), added while dBIC exceeds
    ``ROLL_ADD_THRESHOLD``."""
    say = progress or (lambda _m: None)
    current = resolve_roll_terms(terms)
    baseline_problem = RollProblem.from_log(log, current)
    current = baseline_problem.terms
    log_lik, final_point, residual = _max_log_likelihood(baseline_problem)
    baseline_residual = residual
    final_problem = baseline_problem
    baseline_rms = float(np.sqrt(np.mean(residual**2)))
    regs = roll_regressors(baseline_problem)
    n = int(baseline_problem.observed.shape[0])
    steps, skipped = [], {}
    while len(steps) < max_added:
        scores, fits = {}, {}
        for name, effect in ROLL_EFFECTS.items():
            if name in current or not effect["candidate"]:
                continue
            problem = RollProblem.from_log(log, (*current, name))
            if name not in problem.terms:
                skipped[name] = ("needs the stabiliser's rate (gs_rate_deg_s) from an overloaded "
                                 "stabiliser")
                continue
            say(f"  trying {name} ...")
            trial_ll, trial_point, trial_residual = _max_log_likelihood(problem)
            k = len(effect["parameters"])
            scores[name] = 2.0 * (trial_ll - log_lik) - k * math.log(n)
            fits[name] = (trial_ll, trial_residual, problem, trial_point)
        if not scores:
            break
        best = max(scores, key=scores.get)
        if scores[best] <= ROLL_ADD_THRESHOLD:
            break
        trial_ll, trial_residual, problem, final_point = fits[best]
        final_problem = problem
        change = residual - trial_residual
        name, r = max(((k, float(np.corrcoef(change, v)[0, 1])) for k, v in regs.items()
                       if np.ptp(v) > 0), key=lambda kv: abs(kv[1]))
        r_res = float(np.corrcoef(residual, regs[name])[0, 1])
        rms_before = float(np.sqrt(np.mean(residual**2)))
        rms_after = float(np.sqrt(np.mean(trial_residual**2)))
        steps.append({
            "effect": best,
            "evidence": (f"the stabiliser-angle residuals follow {name} (r = {r_res:.2f}); "
                         f"adding {best} ({ROLL_EFFECTS[best]['what']}) cuts the RMS from "
                         f"{rms_before:.3g} to {rms_after:.3g} deg; dBIC = {scores[best]:.1f}"),
            "rms_before_deg_h": rms_before, "rms_after_deg_h": rms_after,
            "score": scores[best], "candidates_dbic": scores,
        })
        say(f"  added {best}: dBIC = {scores[best]:.1f}")
        current, log_lik, residual = problem.terms, trial_ll, trial_residual
    if residuals is not None:
        residuals.update(before=baseline_residual, after=residual,
                         time_s=np.asarray(baseline_problem.time_s))
    n_model = sum(not name.startswith("sigma_") for name in final_problem.names)
    u = jnp.asarray(final_point.u)
    checks = fit_checks(point_fit_evidence(
        final_problem.names, n_model, np.asarray(u),
        np.asarray(final_problem.density.standardised_residuals(u)), noise="white",
        converged=final_point.converged, message=final_point.message))
    return {
        "log_kind": "roll",
        "baseline_terms": list(baseline_problem.terms),
        "added": [s["effect"] for s in steps],
        "final_terms": list(current),
        "rms_baseline_deg_h": baseline_rms,
        "rms_final_deg_h": min(float(np.sqrt(np.mean(residual**2))), baseline_rms),
        "rms_unit": "deg (stabiliser angle minus model, for a roll log)",
        "steps": steps,
        "threshold_dbic": ROLL_ADD_THRESHOLD,
        "skipped_candidates": skipped,
        "unexplained": _roll_unexplained(checks),
        **checks.to_json(),
    }


def _roll_unexplained(checks: CheckReport) -> dict | None:
    """A roll log's left-over structure: the final model's Kalman innovations are not white
    (no flexible term is fitted on the roll side yet; its score is null)."""
    whiteness = next(c for c in checks.checks if c.name == "residual_whiteness")
    if whiteness.passed:
        return None
    return {"evidence": "the final model's stabiliser-angle innovations are not white: "
                        + whiteness.message,
            "score": None, "where": [], "lines_up_with": None}
