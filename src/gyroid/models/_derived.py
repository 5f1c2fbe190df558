"""Derived inputs of the drift model, computed once from a log.

* relative temperature ``t = T - t0`` (degC);
* the temperature rate dT/dt (degC/h) from a logged temperature that carries sensor noise;
* the sign of the last change of each field component (for ``magnetic_hysteresis``) and
  of the temperature (for ``thermal_hysteresis``): :mod:`gyroid.models._change_signs`;
* the specific force (g) the overload effects read: the accelerometer averaged over a
  centred window of ``ACCEL_WINDOW_S``;
* the first-order-lagged temperature (for ``thermal_lag``), in JAX because its time
  constant is a fitted parameter.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.models._recurrences import linear_recurrence

#: Default length of the temperature-rate estimator's window, s.
RATE_WINDOW_S = 1200.0
#: Most samples a rate window spans; faster logs are binned first.
MAX_WINDOW_SAMPLES = 20_000
#: Polynomial degree of the local fit behind the rate estimator.
RATE_POLY_DEGREE = 5
#: Default dead band of the field-change sign detector, uT.
HYSTERESIS_DEADBAND_UT = 10.0
#: Dead band of the temperature-change sign detector, degC (thermal_hysteresis): far above
#: a thermometer's noise, far below a thermal cycle's swing.
TEMPERATURE_DEADBAND_C = 0.5
#: The temperature-change sign is found on at most this many evenly spaced samples.
SIGN_POINTS = 20_000
#: The overload effects read the accelerometer averaged over a centred window this long, s:
#: its white noise (about 1 mg per sample on a MEMS unit) would otherwise pass for
#: variation in g and lend the sensitivities information the orientations do not give.
ACCEL_WINDOW_S = 10.0


def centred_mean(time_s: np.ndarray, values: np.ndarray, window_s: float) -> np.ndarray:
    """Each sample's mean of ``values`` over the samples within ``window_s / 2`` of it
    (irregular sampling allowed; O(n log n), by cumulative sums)."""
    time_s = np.asarray(time_s, dtype=float)
    values = np.asarray(values, dtype=float)
    total = np.concatenate([[0.0], np.cumsum(values)])
    first = np.searchsorted(time_s, time_s - window_s / 2.0, side="left")
    last = np.searchsorted(time_s, time_s + window_s / 2.0, side="right")
    return (total[last] - total[first]) / (last - first)


def _edge_fit(
    window: np.ndarray, positions: np.ndarray, width_x: np.ndarray, degree: int
) -> tuple[np.ndarray, np.ndarray, float]:
    """The degree-``degree`` least-squares polynomial through ``window`` (sampled at
    ``width_x``): its slopes, per unit of position, at ``positions``, each slope's variance
    per unit sample variance (``d(x)' (V'V)^-1 d(x)``), and the fit's residual sum of
    squares. Memory O(window + positions)."""
    vander = np.vander(width_x, degree + 1, increasing=True)
    gram_inv = np.linalg.inv(vander.T @ vander)
    coefficients = gram_inv @ (vander.T @ window)
    rss = float(np.sum((window - vander @ coefficients) ** 2))
    d = np.zeros((positions.size, degree + 1))
    d[:, 1:] = np.vander(positions, degree, increasing=True) * np.arange(1, degree + 1)
    return d @ coefficients, np.einsum("ij,jk,ik->i", d, gram_inv, d), rss


#: An end window's temperature counts as a lower-degree polynomial unless an F test against
#: the full degree rejects it at this level.
EDGE_DEGREE_LEVEL = 1e-3


def _edge_slopes(window: np.ndarray, x: np.ndarray, half: int, degree: int,
                 reference: float, floor: int | None = None) -> tuple[np.ndarray, int]:
    """Slopes at the first ``half`` positions of ``window`` (one end of the log), and the
    lowest degree used there.

    The lowest degree the window supports (an F test against ``degree``) is the floor, so
    the slope is unbiased as far as the data can tell; above it, each position takes the
    highest degree whose slope is no noisier than the interior's (``reference``): a degree-5
    slope at the window's very end is 8 times noisier than at its centre, and that error,
    correlated over the half window, would masquerade as a start-up transient. A given
    ``floor`` skips the test: the slopes are then linear in ``window`` (which may then be
    ``(width, k)``: k columns at once)."""
    fits = {p: _edge_fit(window, x[:half], x, p) for p in range(1, degree + 1)}
    if floor is None:
        from scipy.stats import f as f_dist

        dof = window.size - degree - 1
        noise_var = max(fits[degree][2] / dof, 1e-12 * max(float(np.var(window)), 1.0))
        floor = degree
        for p in range(1, degree):
            statistic = (fits[p][2] - fits[degree][2]) / (degree - p) / noise_var
            if statistic < f_dist.ppf(1.0 - EDGE_DEGREE_LEVEL, degree - p, dof):
                floor = p
                break
    out = np.zeros((half, *window.shape[1:]))
    chosen = np.zeros(half, dtype=bool)
    for p in range(degree, floor - 1, -1):
        slope, variance, _ = fits[p]
        use = ~chosen if p == floor else ~chosen & (variance <= reference * (1.0 + 1e-9))
        out[use] = slope[use]
        chosen |= use
    return out, floor


def _slope_kernel(half: int, degree: int) -> tuple[np.ndarray, np.ndarray, float]:
    """A window of ``2 half + 1`` samples: its positions scaled to [-1, 1], the weights that
    give the degree-``degree`` least-squares slope at its centre (per unit of position),
    and their squared norm (the centre slope's noise per unit sample variance)."""
    x = np.arange(-half, half + 1) / half
    centre = np.linalg.pinv(np.vander(x, degree + 1, increasing=True))[1]
    return x, centre, float(centre @ centre)


def half_and_degree(window_s: float, step: float, size: int) -> tuple[int, int]:
    """The estimator's half window (samples) and polynomial degree for ``window_s`` on a
    grid of ``size`` points ``step`` apart: shortened to the grid, and the degree with it,
    when the window is longer (degree below 1: a single slope over the whole grid)."""
    half = max(int(round(window_s / step / 2.0)), RATE_POLY_DEGREE)
    degree = RATE_POLY_DEGREE
    if 2 * half + 1 > size:
        half = (size - 1) // 2
        degree = min(RATE_POLY_DEGREE, 2 * half - 1)
    return half, degree


def slope_kernel_weights(window_s: float, step_s: float) -> np.ndarray:
    """The interior estimator's weights on ``2 half + 1`` samples ``step_s`` apart (degC/h
    per degC): the rate at a window's centre is their dot product with its temperatures."""
    half, degree = half_and_degree(window_s, step_s, 2**62)
    return _slope_kernel(half, degree)[1] / (half * step_s / 3600.0)


def _local_polynomial_slope(values: np.ndarray, half: int, degree: int, step: float,
                            floors: tuple[int, int] | None = None
                            ) -> tuple[np.ndarray, tuple[int, int]]:
    """Slope of a local least-squares polynomial over ``2 half + 1`` uniform samples, and
    the degree floors chosen at the two ends.

    Positions are scaled to [-1, 1] so the fit stays well conditioned for long windows; the
    interior is one FFT convolution. The first and last ``half`` samples take the slope of a
    polynomial fitted to the first or last full window (:func:`_edge_slopes` chooses its
    degree, unless ``floors`` gives them).
    """
    from scipy.signal import oaconvolve  # here: importing scipy.signal costs 0.7 s at start-up

    width = 2 * half + 1
    x, centre, reference = _slope_kernel(half, degree)
    scale = 1.0 / (half * step)
    first, last = (None, None) if floors is None else floors
    out = np.empty(values.shape)
    kernel = (centre[::-1] * scale).reshape(-1, *([1] * (values.ndim - 1)))
    out[half : values.shape[0] - half] = oaconvolve(values, kernel, mode="valid", axes=0)
    head, first = _edge_slopes(values[:width], x, half, degree, reference, first)
    out[:half] = head * scale
    # The last window read backwards is a first window with the slope's sign flipped.
    tail, last = _edge_slopes(values[-width:][::-1], x, half, degree, reference, last)
    out[values.shape[0] - half :] = -tail[::-1] * scale
    return out, (first, last)


def temperature_rate_deg_c_per_h(
    time_s: Float[np.ndarray, " n"],
    temperature_C: Float[np.ndarray, " n"],
    window_s: float = RATE_WINDOW_S,
) -> Float[np.ndarray, " n"]:
    """Estimate dT/dt in degC/h from a noisy temperature log.

    Estimator: the slope of a local least-squares polynomial of degree 5 over a centred
    window of ``window_s`` seconds (a Savitzky-Golay differentiator). It has **zero lag**
    and no bias for any temperature history that is locally a polynomial of degree <= 5;
    within ``window_s / 2`` of either end of the log the window is one-sided (the polynomial
    fitted to the first or last window; towards the ends its degree is lowered, to 2 at the
    very first and last samples, so that the noise is never larger than in the interior,
    but never below the degree an F test finds the window's temperature needs, so that a
    log starting or ending mid-transition is not followed with a bias). White thermometer noise
    of ``s`` degC at a sample interval ``d`` s over a window of ``N`` samples gives a rate
    noise of ``s * 3600 * sqrt(229.7 / (d**2 N**3))`` degC/h: 0.013 degC/h for 0.01 degC at
    1 Hz and the default 1200 s window, against about 50 degC/h for a plain first
    difference. On paper A's bench (5 degC steps over an hour) the bias is below
    0.001 degC/h; a kink in the temperature is smeared over one window. A shorter window
    follows faster changes at the cost of noise.

    Irregular sampling is handled by interpolating onto a uniform grid at the median
    interval, differentiating there, and interpolating back. A window longer than
    ``MAX_WINDOW_SAMPLES`` samples (a fast log: 10^7 rows at 270 Hz) is differentiated on
    means over bins of ``window_s / MAX_WINDOW_SAMPLES`` (the same noise reduction, a
    smoothing far inside the window) and interpolated back: the cost stays that of the
    binning, whatever the rate.
    """
    return _rate_and_floors(time_s, temperature_C, window_s)[0]


def grid_plan(time_s: np.ndarray, window_s: float) -> tuple[str, float]:
    """Where the estimator differentiates a log with at least two rows, and the step of
    that grid (s): ``"binned"`` (means over bins of ``window_s / MAX_WINDOW_SAMPLES``),
    ``"uniform"`` (the rows themselves) or ``"interpolated"`` (a uniform grid at the median
    step)."""
    steps = np.diff(time_s)
    step = float(np.median(steps))
    if window_s / step > MAX_WINDOW_SAMPLES:
        return "binned", window_s / MAX_WINDOW_SAMPLES
    if steps.min() >= step * (1 - 1e-6) and steps.max() <= step * (1 + 1e-6):
        return "uniform", step
    return "interpolated", step


def _rate_and_floors(time_s: np.ndarray, temperature_C: np.ndarray, window_s: float,
                     floors: tuple[int, int] | None = None
                     ) -> tuple[np.ndarray, tuple[int, int] | None]:
    """:func:`temperature_rate_deg_c_per_h` and the end windows' degree floors it chose
    (given ``floors``: used, and the estimate is linear in ``temperature_C``)."""
    time_s = np.asarray(time_s, dtype=float)
    temperature_C = np.asarray(temperature_C, dtype=float)
    n = time_s.size
    if n < 2:
        return np.zeros(n), None
    kind, step = grid_plan(time_s, window_s)
    uniform = kind == "uniform"
    if kind == "binned":
        offset = time_s - time_s[0]
        offset /= step  # in place: a 10^7-row log's temporaries are 80 MB each
        bins = offset.astype(np.int64)  # floor: the offsets are not negative
        del offset
        counts = np.bincount(bins)
        full = counts > 0
        centres = (np.bincount(bins, weights=time_s)[full] / counts[full])
        means = _bin_sums(bins, temperature_C, counts.size)[full] / _column(counts[full],
                                                                          temperature_C)
        grid_t = time_s[0] + step * (np.arange(counts.size) + 0.5)
        grid_T = _interp(grid_t, centres, means)
    elif uniform:
        grid_t, grid_T = time_s, temperature_C
    else:
        m = int(np.floor((time_s[-1] - time_s[0]) / step)) + 1
        grid_t = time_s[0] + step * np.arange(m)
        grid_T = _interp(grid_t, time_s, temperature_C)
    half, degree = half_and_degree(window_s, step, grid_t.size)
    if degree < 1:
        slope = (grid_T[-1] - grid_T[0]) / (grid_t[-1] - grid_t[0])
        return np.broadcast_to(slope * 3600.0, temperature_C.shape).copy(), None
    rate, floors = _local_polynomial_slope(grid_T, half, degree, step / 3600.0, floors)
    if uniform:
        return rate, floors
    return _interp(time_s, grid_t, rate), floors


def _column(values: np.ndarray, like: np.ndarray) -> np.ndarray:
    """``values`` shaped to divide the rows of ``like`` (1-D or (n, k))."""
    return values if like.ndim == 1 else values[:, None]


def _bin_sums(bins: np.ndarray, values: np.ndarray, size: int) -> np.ndarray:
    """Sums of ``values`` (1-D or (n, k)) per bin."""
    if values.ndim == 1:
        return np.bincount(bins, weights=values, minlength=size)
    out = np.zeros((size, values.shape[1]))
    np.add.at(out, bins, values)
    return out


def _interp(x: np.ndarray, xp: np.ndarray, fp: np.ndarray) -> np.ndarray:
    """``np.interp`` of each column of ``fp`` (1-D or (n, k))."""
    if fp.ndim == 1:
        return np.interp(x, xp, fp)
    upper = np.clip(np.searchsorted(xp, x, side="right"), 1, xp.size - 1)
    lower = upper - 1
    fraction = np.clip((x - xp[lower]) / (xp[upper] - xp[lower]), 0.0, 1.0)[:, None]
    return fp[lower] * (1.0 - fraction) + fp[upper] * fraction


#: The most rows, and grid points, whose rate estimator :func:`temperature_rate_operator`
#: writes as a matrix.
MAX_OPERATOR_ROWS = 4000


def estimator_grid_size(time_s: np.ndarray, window_s: float) -> int:
    """How many points the rate estimator differentiates on for this clock: the rows of a
    uniform log, else its uniform grid (a log of bursts: the whole span at the bursts'
    step, or bins of ``window_s / MAX_WINDOW_SAMPLES``)."""
    time_s = np.asarray(time_s, dtype=float)
    if time_s.size < 2:
        return time_s.size
    kind, step = grid_plan(time_s, window_s)
    if kind == "uniform":
        return time_s.size
    return int(np.floor((time_s[-1] - time_s[0]) / step)) + 1


def temperature_rate_operator(
    time_s: Float[np.ndarray, " n"],
    temperature_C: Float[np.ndarray, " n"],
    window_s: float = RATE_WINDOW_S,
) -> Float[np.ndarray, "n n"]:
    """The rate estimator on this log as a matrix ``L`` (degC/h per degC): ``L @
    temperature_C`` is :func:`temperature_rate_deg_c_per_h`'s estimate, and ``L @ e`` the
    rate error a thermometer error ``e`` causes. The estimator is linear in the temperature
    once its one data-dependent choice is made (the degree floor of each end window), and
    that choice is the data's. At most :data:`MAX_OPERATOR_ROWS` rows and grid points
    (:func:`estimator_grid_size`; a log of block means)."""
    time_s = np.asarray(time_s, dtype=float)
    n = time_s.size
    grid = estimator_grid_size(time_s, window_s)
    if max(n, grid) > MAX_OPERATOR_ROWS:
        raise ValueError(f"the rate operator of {n} rows on a grid of {grid} (at most "
                         f"{MAX_OPERATOR_ROWS})")
    _, floors = _rate_and_floors(time_s, temperature_C, window_s)
    if n >= 2 and floors is not None:
        kind, step = grid_plan(time_s, window_s)
        if kind == "uniform":
            return _uniform_operator(n, step, *half_and_degree(window_s, step, n), floors)
    return _rate_and_floors(time_s, np.eye(n), window_s, floors)[0]


def _uniform_operator(n: int, step: float, half: int, degree: int, floors: tuple[int, int]
                      ) -> np.ndarray:
    """:func:`temperature_rate_operator` of ``n`` rows on a uniform clock ``step`` s apart,
    written directly: the interior rows are the differentiating kernel on a band, the first
    and last ``half`` rows the end windows' slopes of the identity (O(n x window), where the
    estimator applied to the n columns of the identity costs n FFT convolutions)."""
    width = 2 * half + 1
    x, centre, reference = _slope_kernel(half, degree)
    scale = 1.0 / (half * step / 3600.0)
    out = np.zeros((n, n))
    rows = np.arange(half, n - half)
    out[rows[:, None], rows[:, None] - half + np.arange(width)] = centre * scale
    identity = np.eye(width)
    head, _ = _edge_slopes(identity, x, half, degree, reference, floors[0])
    out[:half, :width] = head * scale
    tail, _ = _edge_slopes(identity, x, half, degree, reference, floors[1])
    # the last window read backwards: row n - 1 - i reads column n - 1 - j as tail[i, j]
    out[n - half:, n - width:] = -tail[::-1, ::-1] * scale
    return out


def lagged_temperature(
    time_h: Float[Array, " n"], temperature_C: Float[Array, " n"], tau_h: Float[Array, ""]
) -> Float[Array, " n"]:
    """First-order lag ``tau dT_lag/dt = T - T_lag`` of a sampled temperature, degC.

    Exact for a temperature that is linear between samples (first-order hold), starting in
    equilibrium (``T_lag[0] = T[0]``). A steady ramp of r degC/h is followed ``r * tau``
    behind. Computed as a linear recurrence (a JAX scan): fast and differentiable
    in ``tau_h``.
    """
    time_h = jnp.asarray(time_h)
    temperature_C = jnp.asarray(temperature_C)
    step = jnp.diff(time_h)
    decay = jnp.exp(-step / tau_h)
    u_prev, u_next = temperature_C[:-1], temperature_C[1:]
    # x_k = a x_{k-1} + b_k with the first-order-hold forcing term b_k.
    slope_term = (u_next - u_prev) * (tau_h / step) * (1.0 - decay)
    forcing = u_next - decay * u_prev - slope_term
    a = jnp.concatenate([jnp.zeros(1), decay])
    b = jnp.concatenate([temperature_C[:1], forcing])
    return linear_recurrence(a, b)
