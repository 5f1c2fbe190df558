"""Whitened least squares of a drift model under white + Gauss-Markov noise, the noise
levels estimated from the residuals (alternating with the fit): the fits the discrepancy
workflow compares. Real coefficients are solved in closed form on the Kalman-whitened
design; time constants (and a step's time) from the shared start grid
(:mod:`gyroid.inference._starts`) and a local search on that profile.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from scipy.optimize import minimize

from gyroid.inference._starts import grid_points, start_grid
from gyroid.models._drift import DriftModel
from gyroid.models._inputs import DriftInputs
from gyroid.noise._kalman import gauss_markov_innovations
from gyroid.noise._kinds import GaussMarkov

_LOG_2PI = math.log(2.0 * math.pi)
#: The white + Gauss-Markov levels' priors (paper A's FOG priors, densities on log x).
_NOISE_PRIORS = GaussMarkov().fog_priors()


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


def _whitened_solution(model: DriftModel, inputs: DriftInputs, y, positive_u, steps_s, noise,
                       weight=None):
    """Generalised least squares of the real parameters with the positive ones fixed: the
    design (the model's Jacobian in its real parameters, exact: they enter linearly) and the
    data whitened by the Kalman filter; rows of ``weight`` 0 are predicted through, not fitted.
    Returns (coefficients, whitened design, whitened target, innovation variances, parameter
    vector builder, design)."""
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
    innovations, variance = gauss_markov_innovations(stacked, steps_s, white, gm, tau, weight)
    scale = 1.0 / jnp.sqrt(variance) if weight is None else weight / jnp.sqrt(variance)
    target = innovations[:, 0] * scale
    columns = innovations[:, 1:] * scale[:, None]
    coef, *_ = jnp.linalg.lstsq(columns, target)
    return coef, columns, target, variance, lambda c: base.at[real_idx].set(c), design


@eqx.filter_jit
def _profile(model: DriftModel, inputs: DriftInputs, y, positive_u, steps_s, noise):
    """Max log-likelihood over the real parameters with the positive ones fixed."""
    coef, columns, target, variance, values_of, _ = _whitened_solution(
        model, inputs, y, positive_u, steps_s, noise)
    rss = jnp.sum((target - columns @ coef) ** 2)
    log_lik = -0.5 * rss - 0.5 * jnp.sum(jnp.log(variance)) - 0.5 * y.shape[0] * _LOG_2PI
    values = values_of(coef)
    return log_lik, values, y - model.predict(values, inputs)


@eqx.filter_jit
def held_out_solution(model: DriftModel, inputs: DriftInputs, y, positive_u, steps_s, noise,
                      weight):
    """The whitened least-squares fit on the rows of ``weight`` 1 (time constants and noise
    levels fixed): the drift it predicts at every row (deg/h), the covariance of its real
    coefficients and the design in them (deg/h per unit): what a predictive check needs."""
    coef, columns, _, _, values_of, design = _whitened_solution(
        model, inputs, y, positive_u, steps_s, noise, weight)
    covariance = jnp.linalg.pinv(columns.T @ columns)
    return model.predict(values_of(coef), inputs), covariance, design


def fit_whitened(
    model: DriftModel, inputs: DriftInputs, y, steps_s, noise: NoiseLevels
) -> ModelFit:
    """Whitened least squares of ``model`` with fixed noise; time constants from the grid of
    :mod:`gyroid.inference._starts`, refined on the profile likelihood by a bounded local
    search (a fifth of the grid's least value to 3.3 times its largest).

    The local search is SciPy's (Nelder-Mead; Powell in one dimension) over the compiled
    profile, not optimistix's: an optimistix solver is compiled anew for every candidate
    model of the discrepancy loop, and with ``optx.NelderMead`` the discrepancy tests took
    35-90 % longer for the same optima (measured 2026-11-23)."""
    params = model.parameters
    noise_args = (jnp.asarray(noise.white), jnp.asarray(noise.gm), jnp.asarray(noise.tau_s))
    y = jnp.asarray(y)

    def profile(u):
        return _profile(model, inputs, y, jnp.asarray(u, dtype=float), steps_s, noise_args)

    grids = start_grid(params, inputs)
    if grids:
        best_u, best = None, -np.inf
        for u in grid_points(grids):
            value = float(profile(u)[0])
            if value > best:
                best_u, best = u, value
        bounds = [(float(g.min()) + math.log(0.2), float(g.max()) + math.log(50.0 / 15.0))
                  for g in grids]
        method = "Nelder-Mead" if len(grids) > 1 else "Powell"
        options = {"xatol": 1e-4, "fatol": 1e-4} if len(grids) > 1 else {"xtol": 1e-4}
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
        _NOISE_PRIORS["sigma_deg_h"].log_density(u[0])
        + _NOISE_PRIORS["sigma_gm_deg_h"].log_density(u[1])
        + _NOISE_PRIORS["tau_gm_s"].log_density(jnp.log(tau))
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


def fit_with_noise(model, inputs, y, steps_s, start: NoiseLevels, rounds: int = 2):
    """Alternate the whitened fit and the noise estimate (the noise profiled out)."""
    noise = start
    fit = fit_whitened(model, inputs, y, steps_s, noise)
    for _ in range(rounds):
        noise = estimate_noise(fit.residual, steps_s)
        fit = fit_whitened(model, inputs, y, steps_s, noise)
    return fit, noise


def basis_fit(residual: np.ndarray, basis: np.ndarray, steps_s, noise: NoiseLevels):
    """Log-likelihood of ``residual`` less its best whitened fit on ``basis`` (columns) under
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


def noise_log_likelihood(residual: np.ndarray, steps_s, noise: NoiseLevels) -> float:
    """Log-likelihood of ``residual`` (deg/h) as noise alone under ``noise``."""
    innovation, variance = gauss_markov_innovations(jnp.asarray(residual), steps_s, noise.white,
                                                    noise.gm, noise.tau_s)
    return float(-0.5 * jnp.sum(innovation**2 / variance + jnp.log(variance))
                 - 0.5 * residual.size * _LOG_2PI)
