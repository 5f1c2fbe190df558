"""The discrepancy workflow: where does a model disagree with a log, which missing effect
explains it, and how much does adding it close the gap?

Evidence. Every comparison uses the exact Gaussian likelihood under a white + Gauss-Markov
noise model (:func:`gyroid.kalman.gauss_markov_innovations`), so slowly wandering noise
(bias instability) is not mistaken for an effect. A candidate effect is scored by the BIC
difference ``dBIC = 2 (logL_with - logL_without) - k log n`` (``k`` its parameters, ``n``
rows), the large-sample (Laplace) approximation to twice the log Bayes factor. A candidate
is added when ``dBIC > 10`` ("very strong" on the Kass-Raftery scale: a Bayes factor above
150 after paying for the extra parameters). Each model's noise levels are re-estimated from
its own residuals (alternating with the fit), so an effect is not hidden by a noise model
that has absorbed it. Two candidates whose scores are within ``AMBIGUITY_DBIC`` of each other
(a Bayes factor below 20) are reported as interchangeable on this log.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from scipy.optimize import minimize

from gyroid import effects as registry
from gyroid.allan import contiguous_segments
from gyroid.checks import CheckReport, fit_checks, point_fit_evidence
from gyroid.discrepancy_report import (
    DiscrepancyReport,
    Step,
    Trial,
    Unexplained,
    add_while_evidence,
)
from gyroid.drift import DriftModel
from gyroid.effects import EFFECTS, EXTRA_PREFIX, resolve_terms
from gyroid.errors import GyroidInputError
from gyroid.inputs import T0_C, DriftInputs
from gyroid.kalman import gauss_markov_innovations
from gyroid.likelihood import NOISE_PRIORS
from gyroid.logs import BenchLog
from gyroid.rate_window import choose_rate_window

#: dBIC a candidate must reach to be added.
ADD_THRESHOLD = 10.0
#: Rate-estimator windows tried on logs whose model reads dT/dt, s.
RATE_WINDOWS_S = (300.0, 600.0, 1200.0)
#: Multiples of a time constant's prior median used as starting grid.
TAU_GRID = (0.05, 0.15, 0.4, 1.0, 2.5, 6.0, 15.0)
_LOG_2PI = math.log(2.0 * math.pi)


REGRESSOR_UNITS = {
    "temperature": "degC from t0", "temperature^2": "degC^2", "temperature^3": "degC^3",
    "dT/dt": "degC/h", "d2T/dt2": "degC/h^2", "elapsed time": "h",
    "start-up transient": "exp(-t / 20 min)", "Hx": "H/H0", "Hy": "H/H0", "Hz": "H/H0",
    "sign of the last Hx change": "+/-1", "sign of the last Hy change": "+/-1",
    "sign of the last Hz change": "+/-1",
}


def regressors(x: DriftInputs) -> dict[str, np.ndarray]:
    """Quantities residuals may line up with, by the names effects give as signatures."""
    time_h = np.asarray(x.time_h)
    t = np.asarray(x.t_rel)
    out = {
        "temperature": t,
        "temperature^2": t**2,
        "temperature^3": t**3,
        "dT/dt": np.asarray(x.rate_C_h),
        "d2T/dt2": np.gradient(np.asarray(x.rate_C_h), time_h) if time_h.size > 1 else t * 0,
        "elapsed time": time_h,
        "start-up transient": np.exp(-time_h / 0.33),
    }
    for k, axis in enumerate("xyz"):
        out[f"H{axis}"] = np.asarray(x.field_rel[:, k])
        out[f"sign of the last H{axis} change"] = np.asarray(x.field_sign[:, k])
    for k, name in enumerate(x.extra_names):
        out[name] = np.asarray(x.extra[:, k])
    return out


@dataclass(frozen=True)
class NoiseLevels:
    """White + Gauss-Markov noise: sds in deg/h, correlation time in s."""

    white: float
    gm: float
    tau_s: float

    def as_dict(self) -> dict[str, float]:
        return {"sigma_deg_h": self.white, "sigma_gm_deg_h": self.gm, "tau_gm_s": self.tau_s}


@dataclass
class ModelFit:
    terms: tuple[str, ...]
    values: dict[str, float]
    log_likelihood: float
    n_parameters: int
    residual: np.ndarray  # data minus model at the whitened-LS optimum, deg/h
    rms_ols: float  # RMS of the ordinary least-squares fit of the same model, deg/h


# ----- whitened least squares ------------------------------------------------------------


@eqx.filter_jit
def _profile(model: DriftModel, inputs: DriftInputs, y, positive_u, steps_s, noise):
    """Max log-likelihood over the real parameters with the positive ones fixed."""
    positive = np.array([p.positive for p in model.parameters])
    real_idx = np.flatnonzero(~positive)
    pos_idx = np.flatnonzero(positive)
    base = jnp.zeros(positive.size).at[pos_idx].set(jnp.exp(positive_u))

    def predict(values):
        return model.predict(base.at[real_idx].set(values), inputs)

    zero = jnp.zeros(real_idx.size)
    offset = predict(zero)
    design = jax.jacfwd(predict)(zero)
    stacked = jnp.concatenate([(y - offset)[:, None], design], axis=1)
    white, gm, tau = noise
    innovations, variance = gauss_markov_innovations(stacked, steps_s, white, gm, tau)
    scale = 1.0 / jnp.sqrt(variance)
    target = innovations[:, 0] * scale
    columns = innovations[:, 1:] * scale[:, None]
    coef, *_ = jnp.linalg.lstsq(columns, target)
    rss = jnp.sum((target - columns @ coef) ** 2)
    log_lik = -0.5 * rss - 0.5 * jnp.sum(jnp.log(variance)) - 0.5 * y.shape[0] * _LOG_2PI
    values = base.at[real_idx].set(coef)
    return log_lik, values, y - model.predict(values, inputs)


def _fit(model: DriftModel, inputs: DriftInputs, y, steps_s, noise: NoiseLevels) -> ModelFit:
    """Whitened least squares of ``model`` with fixed noise; time constants by a grid search
    followed by a local (Nelder-Mead / bounded) search on the profile likelihood."""
    params = model.parameters
    positive = [p for p in params if p.positive]
    noise_args = (jnp.asarray(noise.white), jnp.asarray(noise.gm), jnp.asarray(noise.tau_s))
    y = jnp.asarray(y)

    def profile(u):
        return _profile(model, inputs, y, jnp.asarray(u, dtype=float), steps_s, noise_args)

    if positive:
        grids = [np.log(p.start_values(inputs)) if p.start_values is not None else
                 math.log(p.prior.median) + np.log(TAU_GRID) for p in positive]
        best_u, best = None, -np.inf
        for combo in itertools.product(*grids):
            u = np.asarray(combo, dtype=float)
            value = float(profile(u)[0])
            if value > best:
                best_u, best = u, value
        bounds = [(float(g.min()) + math.log(0.2), float(g.max()) + math.log(50.0 / 15.0))
                  for g in grids]
        method = "Nelder-Mead" if len(positive) > 1 else "Powell"
        options = {"xatol": 1e-4, "fatol": 1e-4} if len(positive) > 1 else {"xtol": 1e-4}
        found = minimize(
            lambda u: -float(profile(u)[0]), best_u, method=method, bounds=bounds, options=options
        )
        u = found.x if -found.fun >= best else best_u
    else:
        u = np.zeros(0)
    log_lik, values, residual = profile(u)
    ols = _ols_rms(model, inputs, np.asarray(y), u)
    return ModelFit(
        terms=model.terms,
        values=dict(zip(model.parameter_names, np.asarray(values).tolist(), strict=True)),
        log_likelihood=float(log_lik),
        n_parameters=len(params),
        residual=np.asarray(residual),
        rms_ols=ols,
    )


def _ols_rms(model: DriftModel, inputs: DriftInputs, y: np.ndarray, positive_u) -> float:
    """RMS residual of ordinary least squares of the model (time constants as given)."""
    n = y.size
    steps = jnp.ones(n)
    log_lik, values, residual = _profile(
        model,
        inputs,
        jnp.asarray(y),
        jnp.asarray(positive_u, dtype=float),
        steps,
        (jnp.asarray(1.0), jnp.asarray(1e-9), jnp.asarray(1.0)),
    )
    del log_lik, values
    return float(np.sqrt(np.mean(np.asarray(residual) ** 2)))


#: Longest correlation time the noise model may take, s. A Gauss-Markov process with a
#: correlation time comparable with the log is indistinguishable from a slow effect (a trend,
#: a warm-up); bias instability of FOGs sits at seconds to tens of minutes.
MAX_NOISE_TAU_S = 1800.0


def _noise_tau(u):
    return MAX_NOISE_TAU_S * jax.nn.sigmoid(u)


def _noise_nll(u, args):
    residual, steps_s = args
    white, gm, tau = jnp.exp(u[0]), jnp.exp(u[1]), _noise_tau(u[2])
    innovation, variance = gauss_markov_innovations(residual, steps_s, white, gm, tau)
    log_lik = -0.5 * jnp.sum(innovation**2 / variance + jnp.log(variance))
    prior = (
        NOISE_PRIORS["sigma_deg_h"].log_density(u[0])
        + NOISE_PRIORS["sigma_gm_deg_h"].log_density(u[1])
        + NOISE_PRIORS["tau_gm_s"].log_density(jnp.log(tau))
    )
    return -(log_lik + prior)


@eqx.filter_jit
def _noise_solve(u0, residual, steps_s):
    solution = optx.minimise(
        _noise_nll,
        optx.BFGS(rtol=1e-7, atol=1e-7),
        u0,
        args=(residual, steps_s),
        max_steps=400,
        throw=False,
    )
    return solution.value


def estimate_noise(residual: np.ndarray, steps_s) -> NoiseLevels:
    """Maximum a-posteriori white + Gauss-Markov noise levels of a residual series."""
    residual = np.asarray(residual)
    white0 = max(float(np.std(np.diff(residual))) / math.sqrt(2.0), 1e-6)
    gm0 = max(0.3 * float(np.std(residual)), 1e-4)
    u0 = jnp.asarray([math.log(white0), math.log(gm0), math.log(300.0 / (MAX_NOISE_TAU_S - 300.0))])
    u = np.asarray(_noise_solve(u0, jnp.asarray(residual), steps_s))
    if not np.all(np.isfinite(u)):
        u = np.asarray(u0)
    return NoiseLevels(float(np.exp(u[0])), float(np.exp(u[1])), float(_noise_tau(u[2])))


def _fit_with_noise(model, inputs, y, steps_s, start: NoiseLevels, rounds: int = 2):
    """Alternate the whitened fit and the noise estimate (the noise profiled out)."""
    noise = start
    fit = _fit(model, inputs, y, steps_s, noise)
    for _ in range(rounds):
        noise = estimate_noise(fit.residual, steps_s)
        fit = _fit(model, inputs, y, steps_s, noise)
    return fit, noise


# ----- the workflow ------------------------------------------------------------------------


def _applicable(
    effect: str, terms: tuple[str, ...], log: BenchLog, inputs: DriftInputs
) -> str | None:
    """Why a candidate cannot be tried on this log (None when it can)."""
    e = registry.effect(effect)
    missing = [c for c in e.columns if not log.has(c)]
    if missing:
        return f"the log has no {missing[0]} column"
    if any(need not in terms for need in e.needs_effects):
        return f"needs {', '.join(e.needs_effects)} in the model"
    try:
        DriftModel(terms=resolve_terms((*terms, effect))).check_identifiable(
            inputs, frozenset(log.columns)
        )
    except GyroidInputError as error:
        return str(error)
    return None


def _choose_rate_window(log: BenchLog, model: DriftModel, t0_C: float) -> float:
    """The rate window on the workflow's short grid (the fit's ``auto`` uses a wider one)."""
    return choose_rate_window(log, model, t0_C=t0_C, grid=np.asarray(RATE_WINDOWS_S))[0]


def _where(
    time_s, residual, inputs: DriftInputs, noise: NoiseLevels, log: BenchLog, top: int = 3
) -> list[dict]:
    """Time windows with the largest standardised mean residual."""
    span = time_s[-1] - time_s[0]
    window = max(span / 40.0, 60.0)
    # Whole windows only: the log's last samples join the last window (a window of one
    # sample at the very end would otherwise rank by its noise alone).
    last = max(int(span // window) - 1, 0)
    index = np.minimum(np.floor((time_s - time_s[0]) / window).astype(int), last)
    out = []
    for k in np.unique(index):
        inside = index == k
        count = int(inside.sum())
        expected = math.sqrt(noise.white**2 / count + noise.gm**2)
        mean = float(residual[inside].mean())
        row = {
            "start_s": float(time_s[inside][0]),
            "end_s": float(time_s[inside][-1]),
            "mean_residual_deg_h": mean,
            "z": mean / expected,
        }
        if log.has("temperature_C"):
            row["temperature_C"] = float(np.mean(log.columns["temperature_C"][inside]))
            row["dT_dt_C_h"] = float(np.mean(np.asarray(inputs.rate_C_h)[inside]))
        for c in ("Hx_uT", "Hy_uT", "Hz_uT"):
            if log.has(c):
                row[c] = float(np.mean(log.columns[c][inside]))
        out.append(row)
    out.sort(key=lambda r: -abs(r["z"]))
    return out[:top]


#: Effects that read nothing but the clock (their evidence says they may be stand-ins).
TIME_ONLY_SIGNATURES = ("elapsed time", "start-up transient")
#: Below this |correlation| (on 60 s means) a regressor is not offered as what the residuals
#: follow.
MIN_FOLLOW_R = 0.2
#: Cosines of elapsed time, cos(k pi tau) for k = 1..FLEXIBLE_TERMS over the log (tau from
#: 0 to 1): the flexible term that stands for structure no catalogued effect describes.
#: Twelve resolve features of about a twelfth of the log. Such slow structure is seen
#: through the log's 60 s means, not its samples, so their dBIC penalty is 12 log(number
#: of 60 s means): 12 log n would ask a slow effect to beat white noise sample by sample,
#: which the Gauss-Markov part of the noise model already soaks (a 0.1 deg/h two-hour
#: oscillation gave 2 dlogL = 115 on 12 terms, p ~ 1e-18, and dBIC -11 with log n).
FLEXIBLE_TERMS = 12
FLEXIBLE_BLOCK_S = 60.0
#: The noise model's correlation time counts as pinned at its cap above this fraction.
TAU_AT_CAP = 0.98


def _flexible_basis(time_s: np.ndarray) -> np.ndarray:
    tau = (time_s - time_s[0]) / max(float(time_s[-1] - time_s[0]), 1e-9)
    return np.cos(np.pi * np.outer(tau, np.arange(1, FLEXIBLE_TERMS + 1)))


def _whitened_fit(residual: np.ndarray, basis: np.ndarray, steps_s, noise: NoiseLevels):
    """Log-likelihood of ``residual`` less its best whitened fit on ``basis`` under
    ``noise``, and that fit (deg/h per row)."""
    stacked = jnp.concatenate([jnp.asarray(residual)[:, None], jnp.asarray(basis)], axis=1)
    innovations, variance = gauss_markov_innovations(stacked, steps_s, noise.white, noise.gm,
                                                     noise.tau_s)
    scale = 1.0 / jnp.sqrt(variance)
    target, columns = innovations[:, 0] * scale, innovations[:, 1:] * scale[:, None]
    coef, *_ = jnp.linalg.lstsq(columns, target)
    rss = float(jnp.sum((target - columns @ coef) ** 2))
    log_lik = (-0.5 * rss - 0.5 * float(jnp.sum(jnp.log(variance)))
               - 0.5 * residual.size * _LOG_2PI)
    return log_lik, np.asarray(basis) @ np.asarray(coef)


def _noise_log_likelihood(residual: np.ndarray, steps_s, noise: NoiseLevels) -> float:
    innovation, variance = gauss_markov_innovations(jnp.asarray(residual), steps_s, noise.white,
                                                    noise.gm, noise.tau_s)
    return float(-0.5 * jnp.sum(innovation**2 / variance + jnp.log(variance))
                 - 0.5 * residual.size * _LOG_2PI)


def find_unexplained(log: BenchLog, fit: ModelFit, noise: NoiseLevels, steps_s,
                     regs: dict[str, np.ndarray]) -> Unexplained | None:
    """Structure the final model leaves: a smooth function of time (FLEXIBLE_TERMS cosines)
    against the final residual, the noise re-estimated with it, scored by dBIC on the
    candidates' scale. None unless it beats ``ADD_THRESHOLD``; then where it is, what it
    lines up with, and whether the noise model had run into its correlation-time cap (slow
    structure taken for noise)."""
    time_s = np.asarray(log.time_s)
    residual = np.asarray(fit.residual)
    basis = _flexible_basis(time_s)
    base = _noise_log_likelihood(residual, steps_s, noise)
    flexible_noise = noise
    for _ in range(2):
        _, curve = _whitened_fit(residual, basis, steps_s, flexible_noise)
        flexible_noise = estimate_noise(residual - curve, steps_s)
    log_lik, curve = _whitened_fit(residual, basis, steps_s, flexible_noise)
    blocks = max((time_s[-1] - time_s[0]) / FLEXIBLE_BLOCK_S, FLEXIBLE_TERMS + 2.0)
    score = 2.0 * (log_lik - base) - FLEXIBLE_TERMS * math.log(min(blocks, residual.size))
    pinned = noise.tau_s >= TAU_AT_CAP * MAX_NOISE_TAU_S
    if score <= ADD_THRESHOLD and not pinned:
        return None
    span = time_s[-1] - time_s[0]
    window = max(span / 40.0, 60.0)
    index = np.minimum(np.floor((time_s - time_s[0]) / window).astype(int),
                       max(int(span // window) - 1, 0))
    # Where: the flexible curve's stretches when it won; else (the noise model pinned at
    # its cap) the final residual's own slow part.
    shape = curve if score > ADD_THRESHOLD else residual
    means = np.bincount(index, weights=shape) / np.maximum(np.bincount(index), 1)
    strong = np.flatnonzero(np.abs(means) >= 0.5 * np.abs(means).max())
    where = []
    for k in strong:  # merge neighbouring windows into stretches, h
        start, end = float(k * window / 3600.0), float(min((k + 1) * window, span) / 3600.0)
        if where and abs(where[-1][1] - start) < 1e-9:
            where[-1][1] = end
        else:
            where.append([start, end])
    correlations = {name: float(np.corrcoef(_block_means(shape, time_s),
                                            _block_means(values, time_s))[0, 1])
                    for name, values in regs.items() if np.ptp(values) > 0}
    best = max(correlations, key=lambda k: abs(correlations[k]), default=None)
    lines_up = best if best is not None and abs(correlations[best]) >= 0.5 else None
    if score > ADD_THRESHOLD:
        found = (f"a smooth function of time ({FLEXIBLE_TERMS} cosines) explains structure "
                 f"that no catalogued effect does: dBIC = {score:.1f} over the final model "
                 f"(penalty on the number of 60 s means; threshold {ADD_THRESHOLD:g})")
    else:
        found = (f"the noise model's correlation time ran into its cap of "
                 f"{MAX_NOISE_TAU_S:g} s (Gauss-Markov sd {noise.gm:.3g} deg/h): structure "
                 "slower than the noise model allows is being called noise (a smooth function "
                 f"of time scores dBIC = {score:.1f}; a step or a jump is not smooth)")
    evidence = (
        found + "; it is largest at " + ", ".join(f"{a:.2f}-{b:.2f} h" for a, b in where[:3])
        + (f" and lines up with {lines_up} (r = {correlations[lines_up]:.2f} on 60 s means)"
           if lines_up else " and lines up with no logged quantity")
        + ". The named effects, if any, may be stand-ins for it: log the quantity that "
          "drives it, or offer it with --extra-columns")
    return Unexplained(evidence, score, where, lines_up, bool(pinned), FLEXIBLE_TERMS)


def _final_checks(log: BenchLog, fit: ModelFit, noise: NoiseLevels, steps_s) -> CheckReport:
    """The self-checks of the final model: its innovations under the estimated noise."""
    innovation, variance = gauss_markov_innovations(
        jnp.asarray(fit.residual), steps_s, noise.white, noise.gm, noise.tau_s)
    names = tuple(fit.values)
    evidence = point_fit_evidence(
        names, len(names), np.asarray(list(fit.values.values())),
        np.asarray(innovation / jnp.sqrt(variance)), noise="white+gm",
        message="whitened least squares", segments=tuple(contiguous_segments(log.time_s)),
        where=log.where)
    return fit_checks(evidence)


def _correlations(residual: np.ndarray, regs: dict[str, np.ndarray]) -> dict[str, float]:
    out = {}
    for name, values in regs.items():
        if np.ptp(values) > 0:
            out[name] = float(np.corrcoef(residual, values)[0, 1])
    return dict(sorted(out.items(), key=lambda kv: -abs(kv[1])))


def find_discrepancies(
    log: BenchLog,
    terms: str | tuple[str, ...],
    *,
    candidates: tuple[str, ...] | None = None,
    max_added: int = 3,
    t0_C: float = T0_C,
    progress=None,
) -> DiscrepancyReport:
    """Fit ``terms``, find what is missing from the registry's effects, add it, repeat."""
    say = progress or (lambda _msg: None)
    start = DriftModel.from_terms(terms)
    window = _choose_rate_window(log, start, t0_C)
    inputs = log.inputs(t0_C=t0_C, rate_window_s=window)
    time_s = log.time_s
    steps_s = jnp.asarray(np.concatenate([[np.median(np.diff(time_s))], np.diff(time_s)]))
    y = np.asarray(log.drift_deg_h)
    pool = candidates or tuple(
        [name for name in EFFECTS if name not in start.terms]
        + [EXTRA_PREFIX + column for column in log.extra_columns])
    regs = regressors(inputs)

    def trial(model: DriftModel, noise: NoiseLevels) -> Trial:
        fit, new_noise = _fit_with_noise(model, inputs, y, steps_s, noise)
        return Trial(model.terms, fit.log_likelihood, fit.n_parameters, (fit, new_noise))

    def try_adding(current: Trial, name: str) -> Trial | str:
        reason = _applicable(name, current.terms, log, inputs)
        if reason:
            return reason
        return trial(DriftModel(terms=resolve_terms((*current.terms, name))), current.fit[1])

    def describe(best, current, chosen, scores, rivals) -> Step:
        before, after = current.fit[0], chosen.fit[0]
        signature = registry.effect(best).signature
        regressor, r = _explaining_regressor(before.residual, before.residual - after.residual,
                                             regs, time_s, signature)
        follows = (f"residuals follow {regressor} (r = {r:.2f} on 60 s means)"
                   if abs(r) >= MIN_FOLLOW_R else
                   f"the residuals line up with no single logged quantity (at most r = "
                   f"{r:.2f}, with {regressor}, on 60 s means)")
        evidence = (
            f"{follows}; adding {best} cuts the RMS from {before.rms_ols:.3g} to "
            f"{after.rms_ols:.3g} deg/h; dBIC = {scores[best]:.1f} (threshold {ADD_THRESHOLD:g})"
            + (f"; nearly interchangeable here with {', '.join(rivals)}" if rivals else "")
            + ("; it is a function of time alone, so it says when, not why: on a longer log "
               "it may prove a stand-in for a slow cause"
               if signature in TIME_ONLY_SIGNATURES else "")
        )
        return Step(best, evidence, before.rms_ols, after.rms_ols, scores[best], scores, rivals,
                    regressor, r)

    search = add_while_evidence(
        trial(start, NoiseLevels(1.0, 1e-6, 300.0)), pool, try_adding=try_adding,
        describe=describe, n=y.size, threshold=ADD_THRESHOLD, max_added=max_added,
        progress=say)
    baseline_fit = search.baseline.fit[0]
    fit_now, noise = search.final.fit
    say("  testing the final model against a flexible term ...")
    return DiscrepancyReport(
        log_kind="bench",
        unexplained=find_unexplained(log, fit_now, noise, steps_s, regs),
        checks=_final_checks(log, fit_now, noise, steps_s),
        baseline_terms=start.terms,
        final_terms=search.final.terms,
        steps=search.steps,
        rms_baseline=baseline_fit.rms_ols,
        rms_final=min(fit_now.rms_ols, baseline_fit.rms_ols),
        rms_unit="deg/h",
        threshold_dbic=ADD_THRESHOLD,
        rate_window_s=window,
        noise=noise,
        where=_where(time_s, baseline_fit.residual, inputs, noise, log),
        lines_up_with=_correlations(baseline_fit.residual, regs),
        ambiguous=search.ambiguous,
        residual_before=baseline_fit.residual,
        residual_after=fit_now.residual,
        time_s=time_s,
        skipped=search.skipped,
    )


def _block_means(values: np.ndarray, time_s: np.ndarray, window_s: float = 60.0) -> np.ndarray:
    index = np.floor((time_s - time_s[0]) / window_s).astype(int)
    counts = np.bincount(index)
    keep = counts > 0
    return np.bincount(index, weights=values)[keep] / counts[keep]


def _explaining_regressor(residual: np.ndarray, change: np.ndarray,
                          regs: dict[str, np.ndarray], time_s: np.ndarray, signature: str):
    """The regressor that best matches what the added effect changed (its fitted
    contribution), and its correlation with the residual; both on 60 s means (averaging
    first keeps white noise from hiding the relation). Ties go to the effect's signature."""
    residual_m = _block_means(residual, time_s)
    change_m = _block_means(change, time_s)
    if signature in regs and np.ptp(regs[signature]) > 0:
        # The quantity the chosen effect's form reads is the one to name.
        values_m = _block_means(regs[signature], time_s)
        return signature, float(np.corrcoef(residual_m, values_m)[0, 1])
    best = (signature, 0.0, -1.0)
    for name, values in regs.items():
        values_m = _block_means(values, time_s)
        if np.ptp(values_m) == 0 or np.ptp(change_m) == 0:
            continue
        match = abs(float(np.corrcoef(change_m, values_m)[0, 1]))
        if name.startswith(signature.split(" ")[0]) or name == signature:
            match += 1e-6
        if match > best[2]:
            best = (name, float(np.corrcoef(residual_m, values_m)[0, 1]), match)
    return best[0], best[1]
