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
At most :data:`~gyroid.noise._rate_error_rows.ONE_SIDED_TOLERANCE`, the process reads them
and the mode is found again on that density from the one found; else they stay exact. The
shift is recorded either way (``one_sided_shift_sd`` in fit.json).

Measured (``experiments/rate_error_edges.py``, 20 seeds per case): on paper A's bench the
weighed shift was 0.16-0.39 sd with a 0.01 degC thermometer and 0.48-1.07 with 0.05 degC
(every log kept exact); on the FOG bench of ``experiments/fog_thermal_bench.py`` (flicker,
a walk, 0.01 degC) 0.024-0.079, and every log's one-sided rows went to the process, its
coefficients then a median 0.018-0.025 sd and at most 0.077 from the exact covariance's,
the z-scores' sds within 0.01 of the exact's.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from gyroid.inference._bench_density import BenchDensity
from gyroid.inference._collapsed import filtered_form
from gyroid.inference._marginal_mode import marginal_mode
from gyroid.inference._mode import Optimum
from gyroid.inference._point import correlated_levels, noise_guess
from gyroid.noise._rate_error_process import RateErrorProcess
from gyroid.noise._rate_error_rows import ONE_SIDED_TOLERANCE, coefficient_shift


def one_sided_shift(density: BenchDensity, noise_u: np.ndarray) -> float:
    """The largest rms shift of a coefficient, in its sd, from reading ``density``'s carried
    one-sided rows by the interior's process, at the noise levels ``noise_u`` (sampling
    coordinates): the gyro's noise there written out over the rows, dense."""
    term = density.noise.carried
    if term is None or term.ends is None:
        raise ValueError("one_sided_shift: the density carries no exact one-sided rows")
    white, values = density.levels_of(jnp.asarray(noise_u))
    n = density.n
    time_s = np.asarray(density.inputs.time_h) * 3600.0
    white_var = np.broadcast_to(np.asarray(white, dtype=float) ** 2, (n,))
    gyro = density.noise.without_rate_error().part_covariance(
        time_s, np.arange(n), n, density.step_s, white_var,
        {k: float(v) for k, v in values.items()}, block_means=True)
    everywhere = RateErrorProcess.of(np.asarray(term.process.oscillators), *_spans(density))
    return coefficient_shift(np.asarray(density.model.design(density.inputs)),
                             term.row_covariance(), everywhere.row_covariance(), gyro)


def weigh_one_sided(density: BenchDensity, noise_mode: Optimum | None
                    ) -> tuple[BenchDensity, Optimum | None]:
    """``density`` with its carried thermometer's one-sided rows read by the interior's
    process where that moves no coefficient by more than :data:`~gyroid.noise.
    _rate_error_rows.ONE_SIDED_TOLERANCE` of its sd at the noise levels' marginal mode
    (``noise_mode``, found here when None), and that mode, found again on the density
    returned (module docstring). Unchanged where nothing is carried exactly or the model
    is not linear in every coefficient (no marginal: carried exactly)."""
    term = density.noise.carried
    collapsed = filtered_form(density)
    if term is None or term.ends is None or collapsed is None:
        return density, noise_mode
    correlated = correlated_levels(density)
    if noise_mode is None:
        noise_mode, _ = marginal_mode(collapsed, noise_guess(density)[0], correlated,
                                      lanes=1 + len(correlated))
    shift = one_sided_shift(density, noise_mode.value)
    span, gap = _spans(density)
    by_process = shift <= ONE_SIDED_TOLERANCE
    weighed = eqx.tree_at(lambda d: d.noise, density, density.noise.one_sided_weighed(
        shift, by_process, span_s=span, gap_s=gap))
    if not by_process:
        return weighed, noise_mode
    again, _ = marginal_mode(filtered_form(weighed), noise_mode.value, (),
                             lanes=1 + len(correlated))
    return weighed, again


def _spans(density: BenchDensity) -> tuple[np.ndarray, np.ndarray]:
    """The rows' spans and the gaps before them (s), as the density's filter reads them."""
    n = density.n
    gap = np.zeros(n) if density.gap_s is None else np.asarray(density.gap_s)
    return np.full(n, density.step_s), gap
