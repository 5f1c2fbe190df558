"""The dT/dt estimator's window under correlated noise, by the fit's own likelihood.

:func:`~gyroid.bench._rate_window.choose_rate_window` picks the window with the least
residual sum of squares: the likelihood under white noise, which weighs every row's misfit
alike. Under correlated noise (IEEE 952's flicker and walk, a Gauss-Markov bias) that
choice is too long: the smearing of dT/dt over a kink in the temperature (a raised-cosine
transition's ends, a heater switched) is a slow, hour-scale error, which such a noise model
takes in as a large random walk, while a shorter window's extra thermometer noise, fast,
costs little (its thermometer noise is carried, :mod:`gyroid.noise._rate_error_process`).
On a FOG bench with raised-cosine transitions (10 h at 1 Hz, fitted on 36 s block means;
``experiments/fog_thermal_bench.py``) least squares takes 864 s, and the marginal
prefers 396-585 s, by more than 50 on one such log (``tests/test_rate_window_marginal.py``).
Each window is scored with its own density (its dT/dt, and the thermometer's noise
through it): scored with least squares' window's thermometer process, one seed's search
had found a mode with flicker 11x its truth, 12 nats below the right one, and the fit
then refused.

So a linear model under correlated noise takes the window whose collapsed marginal
posterior (the coefficients integrated out, :mod:`gyroid.inference._collapsed`), maximised
over the noise levels, is highest: among :data:`CANDIDATES` windows spaced geometrically
from the shortest the estimator allows on the fitted rows (``2 * degree + 1`` of them) up to
the least-squares choice, tried from the longest down until the marginal falls (two
windows on a smooth schedule, where the least-squares choice stands). The noise levels at
each window are found as the fit's own mode
finds them (BFGS from the noise model's guess and from each correlated level raised: the
marginal has a mode for each way of explaining slow wander, and one start alone compared
windows on different ones). The same likelihood is then fitted:
this is the window as a hyperparameter at its marginal maximum (type-II maximum
likelihood), as least squares is under white noise.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from gyroid._config import compute_threads
from gyroid.bench._point import correlated_levels, noise_from_residual, noise_guess
from gyroid.bench._point_profiled import collapsed_at_white_start
from gyroid.inference._collapsed import filtered_form
from gyroid.inference._marginal_mode import marginal_mode
from gyroid.inference._mode import Optimum
from gyroid.inference._model_columns import split_parameters
from gyroid.models._derived import RATE_POLY_DEGREE

#: Windows compared, the least-squares choice included.
CANDIDATES = 3


def _collapsed(density):
    """The density's collapsed form, the noise levels' guess and the indices of its
    correlated levels; for a model with positive parameters (time constants, a step's
    time), the form at the start grid's best white least-squares point (those held there:
    the windows are compared as for a linear model); None without correlated noise."""
    collapsed = filtered_form(density)
    if collapsed is not None:
        return (collapsed, *noise_guess(density))
    if not density.noise.correlated or not split_parameters(density)[1].size:
        return None
    form, guess = collapsed_at_white_start(
        density, lambda residual, white: noise_from_residual(density, residual, white))
    return form, guess, correlated_levels(density)


def marginal_window(density_at: Callable[[float], object], least_squares_s: float,
                    step_s: float) -> tuple[float, dict[float, float], Optimum] | None:
    """The window (s) of highest collapsed marginal posterior, that maximum per window
    tried (the last, lower one included), and the noise levels' marginal mode there (the
    fit's own: for a linear model the search's best start is the mode); None where the
    density has no collapsed form (:func:`_collapsed`: a white fit) or no shorter window
    exists. ``density_at``: the
    bench density at a window (s; its dT/dt, and the thermometer's noise through it when
    carried, are the window's); ``step_s``: the rows' median step."""
    density = density_at(least_squares_s)
    form = _collapsed(density)
    if form is None:
        return None
    collapsed, guess, correlated = form
    shortest = (2 * RATE_POLY_DEGREE + 1) * step_s
    if least_squares_s <= shortest * 1.01:
        return None
    windows = np.geomspace(shortest, least_squares_s, CANDIDATES)[::-1]

    def mode_at(window: float):
        if window == least_squares_s:
            return marginal_mode(collapsed, guess, correlated)
        other = _collapsed(density_at(float(window)))
        if other is None:  # a window changes dT/dt's values, never the density's kind
            raise ValueError(f"the density at a {window:.0f} s window has no collapsed form")
        return marginal_mode(other[0], guess, correlated)

    # the first two windows are always compared: their searches run side by side
    with ThreadPoolExecutor(min(2, compute_threads())) as pool:
        first = list(pool.map(mode_at, windows[:2]))
    scores: dict[float, float] = {}
    modes: dict[float, Optimum] = {}
    for i, window in enumerate(windows):
        solution, value = first[i] if i < len(first) else mode_at(window)
        falling = bool(scores) and value < max(scores.values())
        scores[float(window)], modes[float(window)] = value, solution
        if falling:
            break  # past the maximum: the smearing's cost only falls as the window shortens
    if not scores or not np.isfinite(max(scores.values())):
        return None
    best = max(scores, key=lambda w: scores[w])
    return best, scores, modes[best]
