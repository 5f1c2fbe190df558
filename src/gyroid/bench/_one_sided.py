"""Where a carried thermometer's one-sided rows need their exact error.

A fit carrying the thermometer's noise through dT/dt reads the rows within half a window of
either end exactly (:class:`~gyroid.noise._rate_error_rows.OneSidedRows`): some twenty more
columns for the block filter, which made a warm fit of a FOG bench 3.5x slower (12-19 s
against 4-5 s) where those rows move almost nothing (``experiments/rate_error_edges.py``:
leaving the thermometer out entirely moved its coefficients a median 0.02 sd). Whether they
do is weighed at the noise levels' marginal mode, with the gyro's whole noise there: the
rms shift of the generalised least-squares coefficients, in their sds, were the one-sided
rows read by the interior's process like every other row
(:func:`~gyroid.noise._rate_error_rows.coefficient_shift`).
At most :data:`~gyroid.noise._rate_error_rows.ONE_SIDED_TOLERANCE`, the process reads them;
else they stay exact. The shift is recorded either way (``one_sided_shift_sd`` in fit.json).

The dT/dt window search compares two windows by their marginal modes, three BFGS starts
each: on the exact form it took 5.6 s of a 13 s FOG fit (1.2 s on main's single
oscillator). So its windows are all built in the form the shift picks at the noise model's
own guess of the levels (:func:`windows_in_one_form`), and the chosen window is weighed
again at its mode, the mode found again where the form changes. The guess puts flicker
and a walk above the mode's, so the shift there was 0.064-0.072 sd on the FOG bench
(0.046-0.066 at the mode) and 0.12-0.24 on paper A's with a 0.01 degC thermometer
(0.18-0.30 at the mode; seeds 0-3).

Measured (``experiments/rate_error_edges.py``, 20 seeds per case): on paper A's bench the
weighed shift was 0.16-0.39 sd with a 0.01 degC thermometer and 0.48-1.07 with 0.05 degC
(every log kept exact); on the FOG bench of ``experiments/fog_thermal_bench.py`` (flicker,
a walk, 0.01 degC) 0.025-0.078, and every log's one-sided rows went to the process, its
coefficients then a median 0.018-0.025 sd and at most 0.083 from the exact covariance's,
the z-scores' sds within 0.01 of the exact's.

A model with positive parameters (a warm-up's time constant) keeps its one-sided rows
exact, unweighed. Weighed at its profiled mode (the real coefficients' columns at its time
constants) on the FOG bench with a 0.05 deg/h warm-up, seeds 0-4, the shift was 0.156,
0.095, 0.078, 0.156 and 0.116 sd: a warm-up lives on the log's first rows, the very rows
that are one-sided. Three of five stayed exact, one only after a second profile on the
exact form (the guess had picked the process), and warm fits took 7.8-32.7 s against
7.3-13.1 s unweighed (2026-12-01, one process, in turn).
"""

from __future__ import annotations

from collections.abc import Callable

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from gyroid.bench._density import BenchDensity
from gyroid.bench._point import correlated_levels, noise_guess
from gyroid.inference._collapsed import filtered_form
from gyroid.inference._marginal_mode import marginal_mode
from gyroid.inference._mode import Optimum
from gyroid.noise._rate_error_rows import ONE_SIDED_TOLERANCE, coefficient_shift


def one_sided_shift(density: BenchDensity, noise_u: np.ndarray) -> float:
    """The largest rms shift of a coefficient, in its sd, from reading ``density``'s carried
    one-sided rows by the interior's process, at the noise levels ``noise_u`` (sampling
    coordinates): the gyro's noise there written out over the rows, dense."""
    term = density.noise.carried_process
    if term is None or term.ends is None:
        raise ValueError("one_sided_shift: the density carries no exact one-sided rows")
    white, values = density.levels_of(jnp.asarray(noise_u))
    n = density.n
    time_s = np.asarray(density.inputs.time_h) * 3600.0
    white_var = np.broadcast_to(np.asarray(white, dtype=float) ** 2, (n,))
    gyro = density.noise.without_rate_error().part_covariance(
        time_s, np.arange(n), n, density.step_s, white_var,
        {k: float(v) for k, v in values.items()}, block_means=True)
    everywhere = _weighed(density, float("nan"), True).noise.carried_process
    assert everywhere is not None  # weighed, the carried term is kept
    return coefficient_shift(np.asarray(density.model.design(density.inputs)),
                             term.row_covariance(), everywhere.row_covariance(), gyro)


def windows_in_one_form(density_at: Callable[[float], BenchDensity], first_s: float
                        ) -> tuple[Callable[[float], BenchDensity],
                                   Callable[[float], BenchDensity]]:
    """The densities a fit's dT/dt window search compares, all in one form, and the exact
    ones (each built once): the one-sided rows read by the process at every window where,
    at the noise model's guess of its levels on the first window (``first_s``, s), that
    moves no coefficient by more than the tolerance (the search's modes are then found on
    the cheaper form); else exact. The fit then weighs them at its mode
    (:func:`weigh_one_sided`). ``density_at``: the exact density at a window (s)."""
    built: dict[float, BenchDensity] = {}

    def exact_at(window_s: float) -> BenchDensity:
        if window_s not in built:
            built[window_s] = density_at(window_s)
        return built[window_s]

    first = exact_at(first_s)
    term = first.noise.carried_process
    by_process = (term is not None and term.ends is not None
                  and filtered_form(first) is not None
                  and one_sided_shift(first, noise_guess(first)[0]) <= ONE_SIDED_TOLERANCE)

    def at(window_s: float) -> BenchDensity:
        exact = exact_at(window_s)
        return _weighed(exact, float("nan"), True) if by_process else exact

    return at, exact_at


def weigh_one_sided(density: BenchDensity, exact: BenchDensity, noise_mode: Optimum | None
                    ) -> tuple[BenchDensity, Optimum | None]:
    """The density a fit reads at its window: ``exact`` (the density there with the
    one-sided rows exact) with those rows read by the interior's process where that moves
    no coefficient by more than :data:`~gyroid.noise._rate_error_rows.ONE_SIDED_TOLERANCE`
    of its sd at the noise levels' marginal mode, and that mode. ``density``: the form the
    window search found the mode ``noise_mode`` on (found here on it when None); where the
    weighing takes the other form, the mode is found again on it from that one (module
    docstring). ``density`` unchanged where nothing is carried exactly or the model is not
    linear in every coefficient (no marginal: carried exactly)."""
    term = exact.noise.carried_process
    if term is None or term.ends is None or filtered_form(exact) is None:
        return density, noise_mode
    correlated = correlated_levels(exact)
    if noise_mode is None:
        noise_mode, _ = marginal_mode(filtered_form(density), noise_guess(density)[0],
                                      correlated, lanes=1 + len(correlated))
    shift = one_sided_shift(exact, noise_mode.value)
    by_process = shift <= ONE_SIDED_TOLERANCE
    weighed = _weighed(exact, shift, by_process)
    carried = density.noise.carried_process
    if carried is not None and (carried.ends is None) == by_process:
        return weighed, noise_mode  # the mode is this form's
    again, _ = marginal_mode(filtered_form(weighed), noise_mode.value, (),
                             lanes=1 + len(correlated))
    return weighed, again


def _weighed(exact: BenchDensity, shift_sd: float, by_process: bool) -> BenchDensity:
    """``exact`` with its one-sided rows weighed (:meth:`~gyroid.noise.NoiseModel.
    one_sided_weighed`)."""
    span, gap = _spans(exact)
    return eqx.tree_at(lambda d: d.noise, exact, exact.noise.one_sided_weighed(
        shift_sd, by_process, span_s=span, gap_s=gap))


def _spans(density: BenchDensity) -> tuple[np.ndarray, np.ndarray]:
    """The rows' spans and the gaps before them (s), as the density's filter reads them."""
    n = density.n
    gap = np.zeros(n) if density.gap_s is None else np.asarray(density.gap_s)
    return np.full(n, density.step_s), gap
