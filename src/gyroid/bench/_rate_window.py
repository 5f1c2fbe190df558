"""Choosing the temperature-rate estimator's window from the data (``--rate-window auto``).

A short window follows fast ramps and kinks but passes more thermometer noise into dT/dt
(errors in variables: the rate coefficient is attenuated); a long window is quiet but
smears every change in the rate over its length, and the drift model then sees a wrong
dT/dt near each kink. The window is chosen on a geometric grid by the least residual sum
of squares of the model's least-squares fit (the same number of coefficients at every
window, so this is the profile likelihood and BIC alike): the window whose dT/dt explains
the drift best. Only models that read dT/dt choose; others keep the default.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from gyroid.bench._starts import best_least_squares, grid_points, start_grid
from gyroid.errors import GyroidInputError
from gyroid.io._logs import BenchLog
from gyroid.models._derived import RATE_POLY_DEGREE, RATE_WINDOW_S, temperature_rate_deg_c_per_h
from gyroid.models._design import with_rows
from gyroid.models._drift import DriftModel

#: The grid's bounds, s, and its number of windows.
SHORTEST_S = 60.0
LONGEST_S = 7200.0
GRID_POINTS = 13


def reads_rate(model: DriftModel) -> bool:
    """True when the model's drift depends on the estimated dT/dt."""
    return "temperature_rate" in model.terms


def window_grid(time_s: np.ndarray) -> np.ndarray:
    """Candidate windows, s: geometric from ``max(60 s, 4 (degree + 1) samples)`` to
    ``min(2 h, a third of the log)``, with the default 1200 s when it is inside."""
    time_s = np.asarray(time_s, dtype=float)
    step = float(np.median(np.diff(time_s)))
    duration = float(time_s[-1] - time_s[0])
    low = max(SHORTEST_S, 4 * (RATE_POLY_DEGREE + 1) * step)
    high = min(LONGEST_S, duration / 3.0)
    if high <= low:
        return np.array([min(RATE_WINDOW_S, max(duration, step))])
    grid = np.geomspace(low, high, GRID_POINTS)
    if low < RATE_WINDOW_S < high:
        grid = np.unique(np.append(grid, RATE_WINDOW_S))
    return grid


@eqx.filter_jit
def _columns(model: DriftModel, inputs, u_positive: jax.Array) -> tuple[jax.Array, jax.Array]:
    """:meth:`~gyroid.models.DriftModel.columns_at`, compiled per model and log shape."""
    return model.columns_at(inputs, u_positive)


def grid_least_squares(model: DriftModel, inputs, y: np.ndarray,
                       weights: np.ndarray | None = None) -> tuple[float, np.ndarray | None]:
    """A model with positive parameters (time constants, a step's time) by least squares:
    its real coefficients at each point of the start grid of :mod:`gyroid.inference.
    _starts`; the best point's residual sum of squares and parameters (natural units;
    None where no point gives finite columns)."""
    points = list(grid_points(start_grid(model.parameters, inputs)))
    w = np.ones_like(y) if weights is None else weights

    def stacks():
        for point in points:
            offset, design = (np.asarray(a) for a in _columns(model, inputs, jnp.asarray(point)))
            yield np.column_stack([y - offset * w, design * w[:, None]])

    index, rss, coefficients, _ = best_least_squares(stacks())
    if coefficients is None:
        return rss, None
    positive = np.array([p.positive for p in model.parameters], dtype=bool)
    theta = np.empty(positive.size)
    theta[~positive], theta[positive] = coefficients, np.exp(points[index])
    return rss, theta


def choose_rate_window(log: BenchLog, model: DriftModel, *, t0_C: float,
                       grid: np.ndarray | None = None, inputs=None,
                       thermometer_var_C2: float = 0.0
                       ) -> tuple[float, dict[float, float]]:
    """The window (s) with the least residual sum of squares, and the RSS per window
    (``inputs``: the log's inputs at ``t0_C``, if the caller has them). With the
    thermometer's noise carried in the likelihood (``thermometer_var_C2``, a row's variance,
    degC^2; a linear model): the longest window no longer than that whose smearing biases
    no coefficient (:func:`_least_biased`), and the bias in posterior sd per window tried.

    For a linear model only the dT/dt column changes between windows: the other columns'
    design ``A`` is kept (n x (p - 1)) with the R factor of ``[A, y]``, and each window
    costs one product ``A' r`` of its dT/dt ``r``: O(n p), with no Q factor formed."""
    if not reads_rate(model) or not log.has("temperature_C"):
        return RATE_WINDOW_S, {}
    inputs = log.inputs(t0_C=t0_C) if inputs is None else inputs
    time_s = np.asarray(log.time_s)
    temperature = np.asarray(log.columns["temperature_C"])
    weights = 1.0 / np.asarray(log.sigma_deg_h) if log.sigma_deg_h is not None else None
    y = np.asarray(log.drift_deg_h) if weights is None else np.asarray(log.drift_deg_h) * weights
    windows = window_grid(time_s) if grid is None else grid

    def rate(window: float) -> np.ndarray:
        r = temperature_rate_deg_c_per_h(time_s, temperature, float(window))
        return r if weights is None else r * weights

    scores: dict[float, float] = {}
    if model.is_linear:
        others = [e for e in model.effects if e.name != "temperature_rate"]
        fixed = np.empty((y.size, len(model.parameter_names) - 1))
        r_fixed = None
        for rows, block in model.design_blocks(inputs, others):
            fixed[rows] = block if weights is None else block * weights[rows, None]
            r_fixed = with_rows(r_fixed, np.column_stack([fixed[rows], y[rows]]))
        if r_fixed is None:
            raise ValueError("the log has no rows to choose a window on")
        k = fixed.shape[1]
        factor, q_y = r_fixed[:k, :k], r_fixed[:k, k]  # A = Q factor; Q'y = q_y
        y_perp2 = float(r_fixed[k, k] ** 2)  # |y - Q Q'y|^2
        for window in windows:
            r = rate(window)
            q_r = np.linalg.lstsq(factor.T, fixed.T @ r, rcond=None)[0]  # Q'r
            r_perp2 = float(r @ r - q_r @ q_r)
            cross = float(r @ y - q_r @ q_y)  # (r - QQ'r)'(y - QQ'y)
            scores[float(window)] = y_perp2 - cross**2 / r_perp2
    else:
        for window in windows:
            trial = eqx.tree_at(lambda x: x.rate_C_h, inputs, jnp.asarray(rate(window)))
            scores[float(window)] = grid_least_squares(model, trial, y, weights)[0]
    best = min(scores, key=lambda w: scores[w])
    if thermometer_var_C2 > 0 and model.is_linear and weights is None:
        shorter = np.sort([w for w in scores if w <= best])
        return _least_biased(log, model, inputs, shorter, thermometer_var_C2)
    return best, scores


#: Under errors in variables, the longest window whose smearing moves no coefficient by
#: more than this many posterior sd (a 0.3 sd bias costs a 95 % interval 1 % coverage).
MAX_BIAS_SD = 0.3


def _least_biased(log: BenchLog, model: DriftModel, inputs, windows: np.ndarray,
                  thermometer_var_C2: float) -> tuple[float, dict[float, float]]:
    """The longest of ``windows`` (ascending) whose smearing of dT/dt biases no coefficient
    by more than :data:`MAX_BIAS_SD` posterior sd, and that bias per window tried (the
    longest down to the one chosen).

    Why: with the rate's noise carried in the likelihood (a covariance), a short window
    costs only width, while a long one smears the rate over each kink, which no
    covariance carries and which moves the coefficients. The RSS (and the likelihood)
    reward the long window's quieter rate: on paper A's bench with a 0.01 degC thermometer
    they chose 1530 s, and wD's posterior sat 0.8 sd above its truth on average (30
    logs); at 912 or 1200 s it was centred. The smearing at window W is read against the
    shortest window's rate, ``d = r_W - r_0``: the generalised least-squares coefficients
    move by ``wD G d``, less the part of ``d`` that is the two windows' noise (its
    covariance ``v (L_W - L_0)(L_W - L_0)'`` is known), over their posterior sd."""
    from gyroid.models._derived import temperature_rate_operator
    from gyroid.models._rate_error import rate_coefficient_index, white_level_var

    time_s = np.asarray(log.time_s)
    temperature = np.asarray(log.columns["temperature_C"])
    y = np.asarray(log.drift_deg_h)
    white = white_level_var(y)
    index = rate_coefficient_index(model)
    reference = temperature_rate_operator(time_s, temperature, float(windows[0]))
    biases: dict[float, float] = {}
    # from the longest down: the first window within the bound is the answer
    for window in windows[::-1]:
        operator = (reference if window == windows[0]
                    else temperature_rate_operator(time_s, temperature, float(window)))
        trial = eqx.tree_at(lambda x: x.rate_C_h, inputs, jnp.asarray(operator @ temperature))
        design = np.asarray(model.design(trial))
        wd = np.linalg.lstsq(design, y, rcond=None)[0][index]
        whitened = covariance_solve(operator, wd**2 * thermometer_var_C2, white,
                                    design)  # C^-1 X
        posterior = np.linalg.pinv(design.T @ whitened)
        gain = posterior @ whitened.T  # G: y -> coefficients
        difference = operator - reference
        shift = wd * gain @ (difference @ temperature)
        noise = wd**2 * thermometer_var_C2 * np.sum((gain @ difference) ** 2, axis=1)
        bias2 = np.maximum(shift**2 - noise, 0.0) / np.diag(posterior)
        biases[float(window)] = float(np.sqrt(np.max(bias2)))
        if biases[float(window)] <= MAX_BIAS_SD:
            return float(window), biases
    return float(windows[0]), biases


def covariance_solve(operator: np.ndarray, rate_var: float, white_var: float,
                     right: np.ndarray) -> np.ndarray:
    """``C^-1 right`` for ``C = rate_var L L' + white_var I`` (``L``: the rate ``operator``,
    n x n), by the band of ``L L'`` where ``L`` is banded (its rows read a window's
    columns: some 25 of 1000 block means at paper A's bench's window), else densely. The
    dense form's product and factor, some 70 ms a window tried at 1000 rows, were most of
    the window choice's time under the thermometer's noise; the band's solve is the same
    to rounding (tests/test_derived.py)."""
    import scipy.linalg
    import scipy.sparse

    n = operator.shape[0]
    rows, columns = np.nonzero(operator)
    half = int(np.max(np.abs(rows - columns))) if rows.size else 0
    if 4 * half >= n:
        covariance = rate_var * (operator @ operator.T)
        covariance[np.diag_indices_from(covariance)] += white_var
        return scipy.linalg.cho_solve(scipy.linalg.cho_factor(covariance, lower=True), right)
    sparse = scipy.sparse.csr_matrix(operator)
    product = (sparse @ sparse.T).tocsr()
    band = 2 * half
    upper = np.zeros((band + 1, n))  # scipy's upper banded form: upper[band + i - j, j]
    for k in range(band + 1):
        upper[band - k, k:] = rate_var * product.diagonal(k)
    upper[band] += white_var
    return scipy.linalg.solveh_banded(upper, right)


def parse_rate_window(value: str | float | None) -> float | None:
    """``auto`` (None) or a window in seconds."""
    if value is None or (isinstance(value, str) and value.strip().lower() == "auto"):
        return None
    try:
        seconds = float(value)
    except ValueError:
        raise GyroidInputError(f"--rate-window {value!r}: give 'auto' or seconds") from None
    if not math.isfinite(seconds) or seconds <= 0:
        raise GyroidInputError(f"--rate-window {value!r}: the window must be positive seconds")
    return seconds
