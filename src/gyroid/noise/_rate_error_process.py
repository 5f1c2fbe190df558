"""The thermometer's noise in the estimated dT/dt, as a state-space process that a
correlated-noise filter carries (errors in variables under every noise model).

The dT/dt estimator is a local polynomial's slope over a window (a Savitzky-Golay
differentiator, :func:`~gyroid.models.temperature_rate_deg_c_per_h`): white thermometer
noise becomes a rate error whose autocovariance is the differentiator's kernel correlated
with itself, ``v sum_i h_i h_(i+k)``. It has no power at zero frequency (the kernel of a
derivative sums to zero), a positive lobe, a negative one and smaller damped ripples, and
it ends after two windows. Times wD it enters the drift's residual: on a bench with fast
temperature changes (a short window) it exceeds the white noise of a block mean, and a
filter without it takes it in as flicker (intervals ten times too wide, B 14x its truth on
paper A's bench with raised-cosine transitions: issue 42).

A finite-order filter cannot carry a kernel of finite support exactly (that is a moving
average of the window's length). It carries the velocity ``dx/dt`` of a stochastic damped
harmonic oscillator ``x'' + (omega / Q) x' + omega^2 x = white noise`` (Foreman-Mackey et
al. 2017's SHO term): two states, no power at zero frequency, a damped oscillation of its
autocovariance. Its mean over a block is exact, ``(x(end) - x(start)) / L``. Its three
parameters (the rate error's variance, ``omega``, ``Q``) are those whose Gaussian is
closest to the estimator's (Kullback-Leibler, per block mean, with the log's white noise
beside it): on paper A's benches the matched process leaves 3-5 % of the divergence that
ignoring the error leaves. The parameters are fixed for the log (the thermometer's level is
measured on it, wD is its least-squares value), not sampled.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float
from scipy.linalg import expm
from scipy.optimize import minimize

#: States the process adds to a filter.
STATES = 2
#: Frequencies in the Whittle approximation of the divergence (a power of two).
_FREQUENCIES = 4096


def _drift_matrix(omega: float, quality: float) -> np.ndarray:
    """The oscillator's state equation ``d(x, x')/dt = A (x, x') + (0, noise)``."""
    return np.array([[0.0, 1.0], [-(omega**2), -omega / quality]])


def _stationary(variance: float, omega: float) -> np.ndarray:
    """The stationary covariance of ``(x, x')`` for a velocity variance ``variance``."""
    return np.diag([variance / omega**2, variance])


def _transitions(drift: np.ndarray, times_s: np.ndarray) -> np.ndarray:
    """``expm(drift t)`` for each time ``t`` (s), computed once per distinct time (a log's
    blocks share a few spans and gaps)."""
    distinct, where = np.unique(times_s, return_inverse=True)
    return expm(drift[None] * distinct[:, None, None])[where.reshape(-1)]


def block_system(span_s: np.ndarray, gap_s: np.ndarray, variance: float, omega: float,
                 quality: float) -> dict[str, np.ndarray]:
    """Per block (a mean of the velocity over ``span_s`` after a pause ``gap_s``, s): the
    state transition from the previous block's end (``transition``, (n, 2, 2)), the block
    mean per previous state (``to_mean``, (n, 2)), and the new noise's covariances: of the
    state (``state_noise``), of the mean (``mean_noise``) and between them
    (``cross_noise``); exact for every span and gap."""
    a = _drift_matrix(omega, quality)
    stationary = _stationary(variance, omega)
    span = np.asarray(span_s, dtype=float)
    gap = np.asarray(gap_s, dtype=float)
    f_l, f_g = _transitions(a, span), _transitions(a, gap)

    def noise(f):
        return stationary[None] - f @ stationary @ np.swapaxes(f, 1, 2)

    q_l, q_g = noise(f_l), noise(f_g)
    lift = (f_l - np.eye(2)[None])[:, 0, :] / span[:, None]  # the mean per state at start
    return {
        "transition": f_l @ f_g,
        "to_mean": np.einsum("ni,nij->nj", lift, f_g),
        "state_noise": f_l @ q_g @ np.swapaxes(f_l, 1, 2) + q_l,
        "mean_noise": np.einsum("ni,nij,nj->n", lift, q_g, lift) + q_l[:, 0, 0] / span**2,
        "cross_noise": np.einsum("nij,nkj,nk->ni", f_l, q_g, lift)
                       + q_l[:, :, 0] / span[:, None],
        "stationary": stationary,
    }


def block_autocovariance(lags: int, step_s: float, variance: float, omega: float,
                         quality: float) -> np.ndarray:
    """The autocovariance of the velocity's means over touching blocks ``step_s`` long, at
    lags ``0 .. lags - 1`` (blocks): the process as a filter on such blocks sees it."""
    system = block_system(np.array([step_s]), np.array([0.0]), variance, omega, quality)
    f, c = system["transition"][0], system["to_mean"][0]
    out = np.empty(lags)
    out[0] = c @ system["stationary"] @ c + system["mean_noise"][0]
    # Cov(state at a block's end, that block's mean)
    carried = f @ system["stationary"] @ c + system["cross_noise"][0]
    values, vectors = np.linalg.eig(f)
    left = c @ vectors
    right = np.linalg.solve(vectors, carried)
    powers = values[None, :] ** np.arange(lags - 1)[:, None]
    out[1:] = np.real(powers @ (left * right))
    return out


def _spectrum(autocovariance: np.ndarray) -> np.ndarray:
    """The spectral density at :data:`_FREQUENCIES` frequencies of a symmetric sequence
    given at lags 0, 1, ... (zero beyond)."""
    padded = np.zeros(_FREQUENCIES)
    k = min(autocovariance.size, _FREQUENCIES // 2)
    padded[:k] = autocovariance[:k]
    padded[_FREQUENCIES - k + 1:] = autocovariance[1:k][::-1]
    return np.real(np.fft.rfft(padded))


def divergence_per_block(target: np.ndarray, approximation: np.ndarray,
                         white_var: float) -> float:
    """The Kullback-Leibler divergence per block (Whittle's approximation) from the
    Gaussian of autocovariance ``target + white`` to that of ``approximation + white``
    (white: a block's white variance)."""
    s0 = _spectrum(target) + white_var
    s1 = np.maximum(_spectrum(approximation) + white_var, 1e-300)
    ratio = s0 / s1
    # the mean over [0, pi] on the rfft grid, end points halved (trapezoid)
    terms = ratio - 1.0 - np.log(ratio)
    return float(0.5 * (np.sum(terms) - 0.5 * (terms[0] + terms[-1])) / (terms.size - 1))


class RateErrorProcess(eqx.Module):
    """The dT/dt error's process on a log's blocks (module docstring): its per-block system
    (:func:`block_system`, as arrays a filter reads) and its parameters: the velocity's
    variance ``variance`` ((deg/h)^2, wD^2 times the rate error's), ``omega`` (rad/s) and
    the quality factor ``quality``; the divergence per block left against the estimator's
    own error (``divergence``, and ``divergence_without``: with none carried)."""

    transition: Float[Array, "n 2 2"]
    to_mean: Float[Array, "n 2"]
    state_noise: Float[Array, "n 2 2"]
    mean_noise: Float[Array, " n"]
    cross_noise: Float[Array, "n 2"]
    stationary: Float[Array, "2 2"]
    # arrays, not static floats: logs of one shape share one compilation
    variance: Float[Array, ""]
    omega: Float[Array, ""]
    quality: Float[Array, ""]
    divergence: Float[Array, ""]
    divergence_without: Float[Array, ""]

    @classmethod
    def matched(cls, autocovariance: np.ndarray, step_s: float, white_var: float,
                span_s: np.ndarray, gap_s: np.ndarray) -> RateErrorProcess:
        """The process closest to an error of ``autocovariance`` ((deg/h)^2 at lags of one
        row, ``step_s`` s) beside white noise of ``white_var`` per row, set up on blocks of
        spans ``span_s`` after gaps ``gap_s`` (s)."""
        variance, omega, quality, left, without = match(autocovariance, step_s, white_var)
        system = block_system(span_s, gap_s, variance, omega, quality)
        scalars = {"variance": variance, "omega": omega, "quality": quality,
                   "divergence": left, "divergence_without": without}
        return cls(**{k: jnp.asarray(v) for k, v in (system | scalars).items()})

    def row_covariance(self) -> np.ndarray:
        """The covariance of the process's block means over the log's blocks, dense
        ((deg/h)^2; for the predictive check's parts and for tests), by the recursion the
        filter runs, to where it has decayed below 1e-12 of the variance."""
        f = np.asarray(self.transition)
        c = np.asarray(self.to_mean)
        stationary = np.asarray(self.stationary)
        n = c.shape[0]
        cov = np.zeros((n, n))
        variance = np.einsum("ni,ij,nj->n", c, stationary, c) + np.asarray(self.mean_noise)
        cov[np.diag_indices(n)] = variance
        # Cov(state at block j's end, block j's mean), carried forward block by block
        carried = np.einsum("nij,jk,nk->ni", f, stationary, c) + np.asarray(self.cross_noise)
        rows = np.arange(n)
        for lag in range(1, n):
            k = rows[lag:]
            values = np.einsum("ni,ni->n", c[k], carried[: n - lag])
            cov[k, k - lag] = cov[k - lag, k] = values
            if np.all(np.abs(values) < 1e-12 * np.max(variance)):
                break
            carried = np.einsum("nij,nj->ni", f[k], carried[: n - lag])
        return cov


def match(autocovariance: np.ndarray, step_s: float, white_var: float
          ) -> tuple[float, float, float, float, float]:
    """The oscillator (velocity variance, omega rad/s, Q) whose block means' Gaussian is
    closest (:func:`divergence_per_block`) to an error of ``autocovariance`` beside white
    noise ``white_var``, the divergence per block it leaves and the divergence without it.
    Started from the degree-5 differentiator's shape (omega about 9 per window, Q about
    1.6), the window read from the kernel's support."""
    target = np.asarray(autocovariance, dtype=float)
    window_s = max(target.size - 1, 1) * step_s
    lags = min(_FREQUENCIES // 2, max(8 * target.size, 64))

    def loss(p):
        variance, omega, quality = np.exp(p)
        trial = block_autocovariance(lags, step_s, variance, omega, quality)
        return divergence_per_block(target, trial, white_var)

    start = np.log([max(target[0], 1e-300), 9.0 / window_s, 1.6])
    best = minimize(loss, start, method="Nelder-Mead",
                    options={"xatol": 1e-4, "fatol": 1e-9, "maxiter": 2000})
    variance, omega, quality = (float(x) for x in np.exp(best.x))
    without = divergence_per_block(target, np.zeros(1), white_var)
    return variance, omega, quality, float(best.fun), without
