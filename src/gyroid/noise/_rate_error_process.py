"""The thermometer's noise in the estimated dT/dt, in the log's interior, as a state-space
process that a block filter carries (errors in variables beside a correlated term; the
one-sided rows at the log's ends are carried exactly beside it:
:mod:`gyroid.noise._rate_error_rows`; beside white noise alone the rows' exact covariance
is carried instead: :mod:`gyroid.noise._rate_error_eigenbasis`).

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
average of the window's length). It carries the sum of the velocities ``dx/dt`` of
:data:`OSCILLATORS` independent stochastic damped harmonic oscillators ``x'' + (omega / Q)
x' + omega^2 x = white noise`` (Foreman-Mackey et al. 2017's SHO term): two states each, no
power at zero frequency, a damped oscillation of the autocovariance. A velocity's mean over
a block is exact, ``(x(end) - x(start)) / L``. The oscillators' parameters (each one's
velocity variance, ``omega``, ``Q``) are those whose Gaussian is closest to the estimator's
(Kullback-Leibler, per block mean, with the log's white noise beside it) among those with
the estimator's power at low frequencies (``S(w) ~ c w^2``, ``c = -sum k^2 gamma_k``):
the drift's columns (temperature, its square, dT/dt) vary over hours, and there the
coefficients' precision is read. One oscillator matched by the divergence alone had 0.38 to
0.43 of that power, and wD's sd under it was 0.78 to 0.86 of the exact covariance's on paper
A's bench with a 0.05 degC thermometer (``experiments/rate_error_edges.py``); a constrained
single oscillator mends that but misses the kernel's negative lobe, two follow it. The
parameters are fixed for the log (the thermometer's level is measured on it, wD is its
least-squares value), not sampled.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float
from scipy.linalg import block_diag, expm
from scipy.optimize import minimize

#: The oscillators summed into the process (two filter states each).
OSCILLATORS = 2
#: Frequencies in the Whittle approximation of the divergence (a power of two).
_FREQUENCIES = 4096
#: The match's starts: each oscillator's omega (radians per window) and Q, then the logit
#: of the first one's share of the low-frequency power (a shape near the single
#: oscillator's beside a faster one; a slower, damped one beside a faster, sharper one).
_STARTS = ((9.0, 1.6, 20.0, 1.6, 0.0), (6.0, 1.0, 14.0, 3.0, 1.0))


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
    """One oscillator per block (a mean of the velocity over ``span_s`` after a pause
    ``gap_s``, s): the state transition from the previous block's end (``transition``,
    (n, 2, 2)), the block mean per previous state (``to_mean``, (n, 2)), and the new noise's
    covariances: of the state (``state_noise``), of the mean (``mean_noise``) and between
    them (``cross_noise``); exact for every span and gap."""
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


def _block_lags(step_s: float, omega: np.ndarray, quality: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit-variance oscillators' velocity means over touching blocks ``step_s`` long, in
    closed form (vectorised over oscillators): ``gamma_0`` and the terms ``a``, ``lam`` of
    ``gamma_k = sum a lam^(k - 1)`` (k >= 1; a real sum of complex terms). The position's
    kernel is ``s^2 (m+ e^(m- t) - m- e^(m+ t)) / (m+ - m-)`` with ``m`` the state
    equation's roots and ``s^2 = 1 / omega^2``; a velocity's block mean is the position's
    difference over the block."""
    omega = np.asarray(omega, dtype=float)[:, None]
    quality = np.asarray(quality, dtype=float)[:, None]
    root = np.sqrt((1.0 / (4.0 * quality**2) - 1.0).astype(complex))
    root = np.where(np.abs(root) < 1e-6, 1e-6, root)  # critical damping: a hair off it
    m = omega * (-1.0 / (2.0 * quality) + np.concatenate([root, -root], axis=1))
    # the kernel's terms b e^(m t): b+ for m+ is -s^2 m- / (m+ - m-), and its mirror
    b = np.stack([-m[:, 1], m[:, 0]], axis=1) / (m[:, :1] - m[:, 1:]) / omega**2
    lam = np.exp(m * step_s)
    gamma0 = np.real(2.0 * np.sum(b * (1.0 - lam), axis=1)) / step_s**2
    a = b * lam * (2.0 - lam - 1.0 / lam) / step_s**2
    return gamma0, a, lam


def block_autocovariance(lags: int, step_s: float, variance: float, omega: float,
                         quality: float) -> np.ndarray:
    """The autocovariance of one oscillator's velocity means over touching blocks
    ``step_s`` long, at lags ``0 .. lags - 1`` (blocks): the process as a filter on such
    blocks sees it."""
    gamma0, a, lam = _block_lags(step_s, np.array([omega]), np.array([quality]))
    powers = lam[0][None, :] ** np.arange(lags - 1)[:, None]
    return variance * np.concatenate([gamma0, np.real(powers @ a[0])])


def low_frequency_power(autocovariance: np.ndarray) -> float:
    """``c`` in ``S(w) ~ c w^2`` near zero frequency (w in rad per lag) of a sequence with
    no power at zero frequency, from its autocovariance at lags 0, 1, ...: ``-sum k^2
    gamma_k`` over positive lags."""
    gamma = np.asarray(autocovariance, dtype=float)
    return float(-np.sum(np.arange(1, gamma.size) ** 2 * gamma[1:]))


def _spectrum(autocovariance: np.ndarray) -> np.ndarray:
    """The spectral density at :data:`_FREQUENCIES` frequencies of a symmetric sequence
    given at lags 0, 1, ... (zero beyond)."""
    padded = np.zeros(_FREQUENCIES)
    k = min(autocovariance.size, _FREQUENCIES // 2)
    padded[:k] = autocovariance[:k]
    padded[_FREQUENCIES - k + 1:] = autocovariance[1:k][::-1]
    return np.real(np.fft.rfft(padded))


#: ``exp(-i w)`` on :func:`_spectrum`'s frequencies.
_PHASE = np.exp(-2j * np.pi * np.arange(_FREQUENCIES // 2 + 1) / _FREQUENCIES)


def _divergence(s0: np.ndarray, s1: np.ndarray, white_var: float) -> float:
    """Whittle's Kullback-Leibler divergence per block between spectra ``s0 + white`` and
    ``s1 + white``: the mean over [0, pi] on the rfft grid, end points halved."""
    ratio = (s0 + white_var) / np.maximum(s1 + white_var, 1e-300)
    terms = ratio - 1.0 - np.log(ratio)
    return float(0.5 * (np.sum(terms) - 0.5 * (terms[0] + terms[-1])) / (terms.size - 1))


def divergence_per_block(target: np.ndarray, approximation: np.ndarray,
                         white_var: float) -> float:
    """The Kullback-Leibler divergence per block (Whittle's approximation) from the
    Gaussian of autocovariance ``target + white`` to that of ``approximation + white``
    (white: a block's white variance)."""
    return _divergence(_spectrum(target), _spectrum(approximation), white_var)


def match(autocovariance: np.ndarray, step_s: float, white_var: float
          ) -> tuple[np.ndarray, float, float]:
    """The :data:`OSCILLATORS` oscillators (rows: velocity variance, omega rad/s, Q) whose
    block means' Gaussian is closest (:func:`divergence_per_block`) to an error of
    ``autocovariance`` beside white noise ``white_var``, among those whose summed
    low-frequency power is the error's own (module docstring); the divergence per block
    they leave and the divergence without them. Nelder-Mead from :data:`_STARTS` over the
    logarithms of each one's omega (per window, read from the kernel's support) and Q and
    the logit of the first one's share of that power; the spectra in closed form."""
    target = np.asarray(autocovariance, dtype=float)
    window_s = max(target.size - 1, 1) * step_s
    power = low_frequency_power(target)
    s0 = _spectrum(target)

    def oscillators(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        shape = np.exp(np.clip(p[:4], -12.0, 12.0)).reshape(OSCILLATORS, 2)
        omega, quality = shape[:, 0] / window_s, np.clip(shape[:, 1], 0.05, 50.0)
        first = 1.0 / (1.0 + np.exp(-p[4]))
        gamma0, a, lam = _block_lags(step_s, omega, quality)
        # each one's low-frequency power per unit variance: -sum k^2 a lam^(k - 1)
        unit = -np.real(np.sum(a * (1.0 + lam) / (1.0 - lam) ** 3, axis=1))
        variance = np.array([first, 1.0 - first]) * power / np.maximum(unit, 1e-300)
        spectra = gamma0[:, None] + 2.0 * np.real(
            np.sum(a[:, :, None] * _PHASE / (1.0 - lam[:, :, None] * _PHASE), axis=1))
        return np.column_stack([variance, omega, quality]), variance @ spectra

    def loss(p: np.ndarray) -> float:
        return _divergence(s0, oscillators(p)[1], white_var)

    def start(x: tuple[float, ...]) -> np.ndarray:
        return np.array([np.log(x[0]), np.log(x[1]), np.log(x[2]), np.log(x[3]), x[4]])

    searches = [minimize(loss, start(x), method="Nelder-Mead",
                         options={"xatol": 1e-4, "fatol": 1e-9, "maxiter": 4000})
                for x in _STARTS]
    best = min(searches, key=lambda r: r.fun)
    without = _divergence(s0, np.zeros_like(s0), white_var)
    return oscillators(best.x)[0], float(best.fun), without


class RateErrorProcess(eqx.Module):
    """The dT/dt error's process on a log's blocks (module docstring): its per-block system
    (:func:`block_system` for each oscillator, the oscillators' states side by side, as
    arrays a filter reads; unobserved on the rows whose error is carried apart, the
    one-sided ones), ``oscillators`` (rows: each one's velocity variance, (deg/h)^2, omega,
    rad/s, and Q) and the divergence per block left against the estimator's own error
    (``divergence``, and ``divergence_without``: with none carried)."""

    transition: Float[Array, "n k k"]
    to_mean: Float[Array, "n k"]
    state_noise: Float[Array, "n k k"]
    mean_noise: Float[Array, " n"]
    cross_noise: Float[Array, "n k"]
    stationary: Float[Array, "k k"]
    # arrays, not static floats: logs of one shape share one compilation
    oscillators: Float[Array, "m 3"]
    divergence: Float[Array, ""]
    divergence_without: Float[Array, ""]

    @classmethod
    def of(cls, oscillators: np.ndarray, span_s: np.ndarray, gap_s: np.ndarray,
           observed: np.ndarray | None = None, divergence: float = 0.0,
           divergence_without: float = 0.0) -> RateErrorProcess:
        """The process of ``oscillators`` (rows: velocity variance, omega, Q) on blocks of
        spans ``span_s`` after gaps ``gap_s`` (s), observed on the rows ``observed`` (a
        boolean mask; all when None)."""
        oscillators = np.atleast_2d(np.asarray(oscillators, dtype=float))
        systems = [block_system(span_s, gap_s, *row) for row in oscillators]
        n = np.size(span_s)
        observed = np.ones(n) if observed is None else np.asarray(observed, dtype=float)

        def side_by_side(key: str) -> np.ndarray:  # each oscillator's 2 x 2 on the diagonal
            out = np.zeros((n, 2 * len(systems), 2 * len(systems)))
            for i, system in enumerate(systems):
                out[:, 2 * i:2 * i + 2, 2 * i:2 * i + 2] = system[key]
            return out

        arrays = {
            "transition": side_by_side("transition"),
            "to_mean": np.concatenate([s["to_mean"] for s in systems], axis=1)
                       * observed[:, None],
            "state_noise": side_by_side("state_noise"),
            "mean_noise": sum(s["mean_noise"] for s in systems) * observed,
            "cross_noise": np.concatenate([s["cross_noise"] for s in systems], axis=1)
                           * observed[:, None],
            "stationary": block_diag(*(s["stationary"] for s in systems)),
            "oscillators": oscillators, "divergence": divergence,
            "divergence_without": divergence_without}
        return cls(**{k: jnp.asarray(v) for k, v in arrays.items()})

    @classmethod
    def matched(cls, autocovariance: np.ndarray, step_s: float, white_var: float,
                span_s: np.ndarray, gap_s: np.ndarray, observed: np.ndarray | None = None
                ) -> RateErrorProcess:
        """The process closest to an error of ``autocovariance`` ((deg/h)^2 at lags of one
        row, ``step_s`` s) beside white noise of ``white_var`` per row (:func:`match`), set
        up on blocks of spans ``span_s`` after gaps ``gap_s`` (s), observed on the rows
        ``observed``."""
        oscillators, left, without = match(autocovariance, step_s, white_var)
        return cls.of(oscillators, span_s, gap_s, observed, left, without)

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
        scale = max(float(np.max(variance)), 1e-300)
        for lag in range(1, n):
            k = rows[lag:]
            values = np.einsum("ni,ni->n", c[k], carried[: n - lag])
            cov[k, k - lag] = cov[k - lag, k] = values
            if np.all(np.abs(carried[: n - lag]) < 1e-12 * np.sqrt(scale)
                      * np.max(np.abs(c), initial=1.0)) and np.all(np.abs(values)
                                                                   < 1e-12 * scale):
                break
            carried = np.einsum("nij,nj->ni", f[k], carried[: n - lag])
        return cov
