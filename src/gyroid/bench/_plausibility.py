"""Units sanity: does a log read as a gyro and a thermometer can be?

A column in the wrong unit under a contract name passes every shape check and gives a
confident, wrong answer (a drift in deg/s read as deg/h is 3600 times small everywhere; a
temperature in degF shifts and rescales every temperature coefficient; a clock in ms makes
a 2 h log last 83 days). This check compares what the log implies with what any gyro (a
navigation FOG to a consumer MEMS) or a test bench can be, and names the likely mistake:

* angle random walk ``N = sigma * sqrt(dt) / 60`` deg/sqrt(h) (``sigma`` a sample's white
  noise, deg/h, from first differences; ``dt`` the median step, s) below ``BEST_ARW`` (the
  best strategic-grade FOGs) suggests deg/s read as deg/h; above ``WORST_ARW`` (worse than
  any consumer MEMS) a rate already in deg/h converted again;
* a typical drift beyond ``MAX_RATE_DEG_H`` (2000 deg/s, a consumer gyro's full scale);
* temperatures outside a bench's ``TEMPERATURE_RANGE_C``, or a room's 15..40 degC read in
  degF (59..104);
* a step of ``SLOW_STEP_S`` or more, or a log lasting more than ``MAX_DAYS`` days at a step of
  a second or more: a clock in ms.

It is a warning (the log may be unusual, not wrong), printed with the fit's result.
"""

from __future__ import annotations

import math

import numpy as np

from gyroid.inference._check_report import Check

BEST_ARW = 1e-4  # deg/sqrt(h)
WORST_ARW = 100.0
MAX_RATE_DEG_H = 2000.0 * 3600.0
TEMPERATURE_RANGE_C = (-60.0, 120.0)
ROOM_IN_DEGF = (59.0, 104.0)
MAX_DAYS = 30.0
SLOW_STEP_S = 100.0


def units_sanity(log) -> Check:
    """The units check of a bench log (see the module docstring)."""
    findings = [*_rate_findings(log), *_temperature_findings(log), *_clock_findings(log)]
    if not findings:
        return Check("units", True, "warning", None, None,
                     "the log reads as a gyro and a thermometer can be")
    return Check("units", False, "warning", None, None, "; ".join(findings))


def _rate_findings(log) -> list[str]:
    drift = np.asarray(log.drift_deg_h, dtype=float)
    time_s = np.asarray(log.time_s, dtype=float)
    out = []
    if drift.size > 16:
        step = float(np.median(np.diff(time_s)))
        sigma = 1.4826 * float(np.median(np.abs(np.diff(drift) - np.median(np.diff(drift)))))
        arw = sigma / math.sqrt(2.0) * math.sqrt(step) / 60.0
        if 0 < arw < BEST_ARW:
            out.append(f"the drift's noise implies an angle random walk of {arw:.2g} "
                       "deg/sqrt(h), better than any gyro's (the best FOGs: about 1e-4): if "
                       "the column holds deg/s, read it with --map drift_deg_h=COLUMN:deg/s")
        elif arw > WORST_ARW:
            out.append(f"the drift's noise implies an angle random walk of {arw:.3g} "
                       "deg/sqrt(h), worse than any gyro's: check the drift's unit (a column "
                       "already in deg/h converted again?)")
    typical = float(np.median(np.abs(drift))) if drift.size else 0.0
    if typical > MAX_RATE_DEG_H:
        out.append(f"the drift is typically {typical:.3g} deg/h, beyond any gyro's range "
                   "(2000 deg/s): check its unit")
    return out


def _temperature_findings(log) -> list[str]:
    if not log.has("temperature_C"):
        return []
    temperature = np.asarray(log.columns["temperature_C"], dtype=float)
    low, high = float(np.min(temperature)), float(np.max(temperature))
    median = float(np.median(temperature))
    out = []
    if low < TEMPERATURE_RANGE_C[0] or high > TEMPERATURE_RANGE_C[1]:
        out.append(f"temperatures from {low:.4g} to {high:.4g} degC leave any test bench's "
                   f"{TEMPERATURE_RANGE_C[0]:g}..{TEMPERATURE_RANGE_C[1]:g} degC: check the "
                   "unit (degF? K?)")
    elif ROOM_IN_DEGF[0] <= low and high <= ROOM_IN_DEGF[1] and median > 50.0:
        out.append(f"temperatures of {low:.4g}..{high:.4g} degC are a hot chamber's, or a "
                   "room's in degF: if the column holds degF, read it with "
                   "--map temperature_C=COLUMN:degF")
    return out


def _clock_findings(log) -> list[str]:
    time_s = np.asarray(log.time_s, dtype=float)
    if time_s.size < 2:
        return []
    days = float(time_s[-1] - time_s[0]) / 86400.0
    step = float(np.median(np.diff(time_s)))
    if step >= SLOW_STEP_S or (days > MAX_DAYS and step >= 1.0):
        return [f"the log lasts {days:.3g} days at a step of {step:.3g} s: if time_s holds "
                "milliseconds, read it with --map time_s=COLUMN:ms"]
    return []


#: An effect whose fitted contribution spans this many times the drift's own observed span
#: is being cancelled by another effect's.
CANCELLING_FACTOR = 10.0


def _span(values: np.ndarray) -> float:
    """The robust span of a series: its 1st to 99th percentile."""
    low, high = np.percentile(values, [1.0, 99.0])
    return float(high - low)


def effect_sizes(model, values: dict[str, float], inputs, drift: np.ndarray) -> Check:
    """Sizes no gyro has: an effect whose fitted contribution spans more than
    ``CANCELLING_FACTOR`` times the drift's observed span (1st to 99th percentile) can only
    fit the data by cancelling another effect's (inputs that move together: the Astro Pi's
    field and temperature). The sizes are then not physical even when each is "significant";
    a warning, naming the effect."""
    import jax.numpy as jnp

    observed = _span(np.asarray(drift, dtype=float))
    params = {name: jnp.asarray(value) for name, value in values.items()}
    findings = []
    for effect in model.effects:
        if effect.signature == "constant":
            continue
        size = _span(np.asarray(effect.contribution(params, inputs)))
        if size > CANCELLING_FACTOR * max(observed, 1e-300):
            findings.append(f"{effect.name}'s fitted contribution spans {size:.3g} deg/h")
    if not findings:
        return Check("effect_sizes", True, "warning", None, CANCELLING_FACTOR,
                     "no effect's fitted contribution is larger than the drift itself")
    return Check("effect_sizes", False, "warning", None, CANCELLING_FACTOR,
                 f"{'; '.join(findings)}, while the drift itself spans {observed:.3g} deg/h: "
                 "effects cancel one another (their inputs move together), so their sizes "
                 "are not physical; fit fewer terms, or a log whose inputs vary "
                 "independently", ("discrepancy",))
