"""The dT/dt estimator's own error, named: where the temperature's curvature changes faster
than the estimator's window follows (a raised-cosine transition's ends, a heater switched),
the slope of the local polynomial is biased, and ``wD`` times that bias is drift the model
puts there that the gyro did not make; its rows then show as misfit or outliers.

The bias is not observed, but its symptom is: the rate estimated over the window and over half
the window agree within their noise wherever the temperature is locally a polynomial of the
estimator's degree (both are unbiased there), and disagree where it is not. The half window's
noise dominates the difference; for white thermometer noise of ``s`` degC at ``d`` s over
``N`` samples an estimate's sd is ``s 3600 sqrt(229.7 / (d^2 N^3))`` degC/h
(:func:`~gyroid.models._derived.temperature_rate_deg_c_per_h`), ``s`` read from the
temperature's second differences (robustly). Rows where the two differ by more than
``DISAGREE_SD`` of that are named, with ``|wD|`` times the difference: a bound of the
drift the estimator may have made there, in deg/h. A warning: the coefficients stand, but the
rows named carry the estimator's error.
"""

from __future__ import annotations

import math

import numpy as np

from gyroid.inference._check_report import Check
from gyroid.models._derived import temperature_rate_deg_c_per_h

#: Disagreement (in sd of the two estimates' difference) that names a row.
DISAGREE_SD = 5.0
#: Largest share of the rows that may disagree before the warning is given.
DISAGREE_FRACTION = 0.01


def rate_estimate(time_s: np.ndarray, temperature_C: np.ndarray, window_s: float,
                  wD: float | None, drift_noise_deg_h: float,
                  rate_C_h: np.ndarray | None = None) -> Check:
    """The check (see the module docstring); ``wD`` None: the model has no dT/dt term;
    ``drift_noise_deg_h``: the sd of the drift's mean over a window, below which the
    estimator's error is not worth a word; ``rate_C_h``: the rate over ``window_s`` when the
    caller has it (a fit's inputs), else estimated here."""
    name = "rate_estimate"
    if wD is None:
        return Check(name, True, "warning", None, DISAGREE_FRACTION, "no dT/dt term")
    time_s = np.asarray(time_s, dtype=float)
    temperature = np.asarray(temperature_C, dtype=float)
    step = float(np.median(np.diff(time_s))) if time_s.size > 1 else 1.0
    samples = window_s / 2.0 / step
    if time_s.size < 8 or samples < 12:
        return Check(name, True, "warning", None, DISAGREE_FRACTION,
                     "the window is too short to halve")
    if step * (time_s.size - 1) < 0.9 * (time_s[-1] - time_s[0]):
        return Check(name, True, "warning", None, DISAGREE_FRACTION,
                     "not judged on a log with pauses (the estimator's noise there is not "
                     "that of evenly spaced samples)")
    full = (temperature_rate_deg_c_per_h(time_s, temperature, window_s) if rate_C_h is None
            else np.asarray(rate_C_h, dtype=float))
    half = temperature_rate_deg_c_per_h(time_s, temperature, window_s / 2.0)
    second = np.diff(temperature, 2)
    noise_C = 1.4826 * float(np.median(np.abs(second - np.median(second)))) / math.sqrt(6.0)
    # a thermometer quantised coarser than its noise: at least a quantum's uniform noise
    levels = np.diff(np.unique(temperature[: min(temperature.size, 100_000)]))
    quantum = float(np.min(levels)) if levels.size else 0.0
    noise_C = max(noise_C, quantum / math.sqrt(12.0), 1e-9)
    sd = noise_C * 3600.0 * math.sqrt(229.7 / (step**2 * samples**3))
    disagree = np.abs(half - full) > DISAGREE_SD * sd
    fraction = float(np.mean(disagree))
    error_deg_h = abs(wD) * np.abs(half - full)
    worst = float(error_deg_h[disagree].max()) if disagree.any() else 0.0
    if fraction <= DISAGREE_FRACTION or worst <= drift_noise_deg_h:
        return Check(name, True, "warning", fraction, DISAGREE_FRACTION,
                     "the dT/dt estimate follows the temperature (its window and half its "
                     "window agree within their noise" + (
                         f" but at {100 * fraction:.1f} % of the rows, where |wD| x their "
                         f"difference is at most {worst:.3g} deg/h" if disagree.any() else "")
                     + ")")
    spans = _spans(time_s, disagree, join_h=window_s / 3600.0)
    return Check(name, False, "warning", fraction, DISAGREE_FRACTION,
                 f"at {100 * fraction:.1f} % of the rows ({spans}) the dT/dt estimated over "
                 f"{window_s:.0f} s and over {window_s / 2:.0f} s differ beyond {DISAGREE_SD:g} "
                 f"sd of their noise: the temperature's curvature changes faster than the "
                 f"window follows there, and with wD = {wD:.3g} up to {worst:.3g} deg/h of the "
                 "drift those rows are given is the estimator's error, not the gyro's (they "
                 "may show as misfit or outliers); a shorter --rate-window follows such "
                 "changes at the cost of noise")


def _spans(time_s: np.ndarray, mask: np.ndarray, join_h: float, most: int = 3) -> str:
    """The first ``most`` stretches of flagged rows (those closer than ``join_h`` joined),
    as 'a-b h' from the log's start."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    hours = (time_s - time_s[0]) / 3600.0
    pairs: list[list[float]] = []
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        if pairs and hours[a] - pairs[-1][1] < join_h:
            pairs[-1][1] = hours[b - 1]
        else:
            pairs.append([hours[a], hours[b - 1]])
    text = ", ".join(f"{a:.2f}-{b:.2f} h" for a, b in pairs[:most])
    return text + (f" and {len(pairs) - most} more" if len(pairs) > most else "")
