"""Where and with what a model's residuals disagree with a bench log: the regressors
residuals may follow (by the names effects give as signatures), the windows with the
largest standardised mean residual, the quantity an added effect explains, and the
"unexplained" test: a flexible function of time against the final model.
"""

from __future__ import annotations

import math

import numpy as np

from gyroid.io._logs import BenchLog
from gyroid.models._inputs import DriftInputs
from gyroid.workflows._discrepancy_report import NoiseLevels, Unexplained

REGRESSOR_UNITS = {
    "temperature": "degC from t0", "temperature^2": "degC^2", "temperature^3": "degC^3",
    "dT/dt": "degC/h", "d2T/dt2": "degC/h^2", "elapsed time": "h",
    "start-up transient": "exp(-t / 20 min)", "Hx": "H/H0", "Hy": "H/H0", "Hz": "H/H0",
    "sign of the last Hx change": "+/-1", "sign of the last Hy change": "+/-1",
    "sign of the last Hz change": "+/-1", "ax": "g", "ay": "g", "az": "g", "ax^2": "g^2",
    "ay^2": "g^2", "az^2": "g^2", "sign of the last temperature change": "+/-1",
}


def regressors(x: DriftInputs) -> dict[str, np.ndarray]:
    """Quantities residuals may line up with, by the names effects give as signatures."""
    time_h = np.asarray(x.time_h)
    t = np.asarray(x.t_rel)
    out = {
        "temperature": t,
        "temperature^2": t**2,
        "temperature^3": t**3,
        "dT/dt": np.asarray(x.rate_C_h),
        "d2T/dt2": np.gradient(np.asarray(x.rate_C_h), time_h) if time_h.size > 1 else t * 0,
        "elapsed time": time_h,
        "start-up transient": np.exp(-time_h / 0.33),
    }
    if x.field_rel is not None:
        for k, axis in enumerate("xyz"):
            out[f"H{axis}"] = np.asarray(x.field_rel[:, k])
            if x.field_sign is not None:
                out[f"sign of the last H{axis} change"] = np.asarray(x.field_sign[:, k])
    if x.temperature_sign is not None:
        out["sign of the last temperature change"] = np.asarray(x.temperature_sign)
    if x.accel_g is not None:
        for k, axis in enumerate("xyz"):
            out[f"a{axis}"] = np.asarray(x.accel_g[:, k])
            out[f"a{axis}^2"] = np.asarray(x.accel_g[:, k]) ** 2
    if x.extra is not None:
        for k, name in enumerate(x.extra_names):
            out[name] = np.asarray(x.extra[:, k])
    return out


def where_largest(
    time_s, residual, inputs: DriftInputs, noise: NoiseLevels, log: BenchLog, top: int = 3
) -> list[dict]:
    """Time windows with the largest standardised mean residual."""
    span = time_s[-1] - time_s[0]
    window = max(span / 40.0, 60.0)
    # Whole windows only: the log's last samples join the last window (a window of one
    # sample at the very end would otherwise rank by its noise alone).
    last = max(int(span // window) - 1, 0)
    index = np.minimum(np.floor((time_s - time_s[0]) / window).astype(int), last)
    out = []
    for k in np.unique(index):
        inside = index == k
        count = int(inside.sum())
        expected = math.sqrt(noise.white**2 / count + noise.gm**2)
        mean = float(residual[inside].mean())
        row = {
            "start_s": float(time_s[inside][0]),
            "end_s": float(time_s[inside][-1]),
            "mean_residual_deg_h": mean,
            "z": mean / expected,
        }
        if log.has("temperature_C"):
            row["temperature_C"] = float(np.mean(log.columns["temperature_C"][inside]))
            row["dT_dt_C_h"] = float(np.mean(np.asarray(inputs.rate_C_h)[inside]))
        for c in ("Hx_uT", "Hy_uT", "Hz_uT", "ax_g", "ay_g", "az_g"):
            if log.has(c):
                row[c] = float(np.mean(log.columns[c][inside]))
        out.append(row)
    out.sort(key=lambda r: -abs(r["z"]))
    return out[:top]




#: Below this |correlation| (on 60 s means) a regressor is not offered as what the residuals
#: follow.
MIN_FOLLOW_R = 0.2


#: Cosines of elapsed time, cos(k pi tau) for k = 1..FLEXIBLE_TERMS over the log (tau from
#: 0 to 1): the flexible term that stands for structure no catalogued effect describes.
#: Twelve resolve features of about a twelfth of the log. Such slow structure is seen
#: through the log's 60 s means, not its samples, so their dBIC penalty is 12 log(number
#: of 60 s means): 12 log n would ask a slow effect to beat white noise sample by sample,
#: which the Gauss-Markov part of the noise model already soaks (a 0.1 deg/h two-hour
#: oscillation gave 2 dlogL = 115 on 12 terms, p ~ 1e-18, and dBIC -11 with log n).
FLEXIBLE_TERMS = 12


FLEXIBLE_BLOCK_S = 60.0


#: A Gauss-Markov correlation time above this, s, is slow structure being called noise: a
#: FOG's bias instability sits at seconds to tens of minutes, and a process as slow as the
#: log is indistinguishable from a slow effect (a trend, a warm-up).
SLOW_NOISE_TAU_S = 1800.0


def flexible_columns(time_s: np.ndarray) -> dict[str, np.ndarray]:
    """The flexible term's columns by name: cos(k pi tau), k = 1..FLEXIBLE_TERMS, tau the
    elapsed time over the log's span (0 to 1)."""
    tau = (time_s - time_s[0]) / max(float(time_s[-1] - time_s[0]), 1e-9)
    return {f"flexible_cos_{k}": np.cos(np.pi * k * tau)
            for k in range(1, FLEXIBLE_TERMS + 1)}


def find_unexplained(time_s: np.ndarray, residual: np.ndarray, noise: NoiseLevels,
                     regs: dict[str, np.ndarray], threshold: float,
                     flexible: tuple[float, np.ndarray]) -> Unexplained | None:
    """Structure the final model leaves: ``flexible`` holds twice the log-likelihood the
    flexible term (:func:`flexible_columns`, fitted with the final model, its noise levels
    its own) adds and its fitted curve (deg/h), scored by dBIC on the candidates' scale.
    None unless it beats ``threshold`` or the final model's noise is slower than
    :data:`SLOW_NOISE_TAU_S` (slow structure taken for noise); then where it is and what
    it lines up with."""
    time_s, residual = np.asarray(time_s), np.asarray(residual)
    gain, curve = flexible
    blocks = max((time_s[-1] - time_s[0]) / FLEXIBLE_BLOCK_S, FLEXIBLE_TERMS + 2.0)
    score = gain - FLEXIBLE_TERMS * math.log(min(blocks, residual.size))
    too_slow = noise.tau_s > SLOW_NOISE_TAU_S
    if score <= threshold and not too_slow:
        return None
    span = time_s[-1] - time_s[0]
    window = max(span / 40.0, 60.0)
    index = np.minimum(np.floor((time_s - time_s[0]) / window).astype(int),
                       max(int(span // window) - 1, 0))
    # Where: the flexible curve's stretches when it won; else (the noise slower than bias
    # instability) the final residual's own slow part.
    shape = curve if score > threshold else residual
    means = np.bincount(index, weights=shape) / np.maximum(np.bincount(index), 1)
    strong = np.flatnonzero(np.abs(means) >= 0.5 * np.abs(means).max())
    where = []
    for k in strong:  # merge neighbouring windows into stretches, h
        start, end = float(k * window / 3600.0), float(min((k + 1) * window, span) / 3600.0)
        if where and abs(where[-1][1] - start) < 1e-9:
            where[-1][1] = end
        else:
            where.append([start, end])
    correlations = {name: float(np.corrcoef(_block_means(shape, time_s),
                                            _block_means(values, time_s))[0, 1])
                    for name, values in regs.items() if np.ptp(values) > 0}
    best = max(correlations, key=lambda k: abs(correlations[k]), default=None)
    lines_up = best if best is not None and abs(correlations[best]) >= 0.5 else None
    if score > threshold:
        found = (f"a smooth function of time ({FLEXIBLE_TERMS} cosines) explains structure "
                 f"that no catalogued effect does: dBIC = {score:.1f} over the final model "
                 f"(penalty on the number of 60 s means; threshold {threshold:g})")
    else:
        found = (f"the noise model's correlation time is {noise.tau_s:.0f} s, beyond "
                 f"{SLOW_NOISE_TAU_S:g} s (Gauss-Markov sd {noise.gm:.3g} deg/h): structure "
                 "slower than bias instability is being called noise (a smooth function "
                 f"of time scores dBIC = {score:.1f}; a step or a jump is not smooth)")
    evidence = (
        found + "; it is largest at " + ", ".join(f"{a:.2f}-{b:.2f} h" for a, b in where[:3])
        + (f" and lines up with {lines_up} (r = {correlations[lines_up]:.2f} on 60 s means)"
           if lines_up else " and lines up with no logged quantity")
        + ". The named effects, if any, may be stand-ins for it: log the quantity that "
          "drives it, or offer it with --extra-columns")
    return Unexplained(evidence, score, where, lines_up, bool(too_slow), FLEXIBLE_TERMS)


def correlations(residual: np.ndarray, regs: dict[str, np.ndarray]) -> dict[str, float]:
    out = {}
    for name, values in regs.items():
        if np.ptp(values) > 0:
            out[name] = float(np.corrcoef(residual, values)[0, 1])
    return dict(sorted(out.items(), key=lambda kv: -abs(kv[1])))


def _block_means(values: np.ndarray, time_s: np.ndarray, window_s: float = 60.0) -> np.ndarray:
    index = np.floor((time_s - time_s[0]) / window_s).astype(int)
    counts = np.bincount(index)
    keep = counts > 0
    return np.bincount(index, weights=values)[keep] / counts[keep]


def explaining_regressor(residual: np.ndarray, change: np.ndarray,
                          regs: dict[str, np.ndarray], time_s: np.ndarray, signature: str):
    """The regressor that best matches what the added effect changed (its fitted
    contribution), and its correlation with the residual; both on 60 s means (averaging
    first keeps white noise from hiding the relation). Ties go to the effect's signature."""
    residual_m = _block_means(residual, time_s)
    change_m = _block_means(change, time_s)
    if signature in regs and np.ptp(regs[signature]) > 0:
        # The quantity the chosen effect's form reads is the one to name.
        values_m = _block_means(regs[signature], time_s)
        return signature, float(np.corrcoef(residual_m, values_m)[0, 1])
    best = (signature, 0.0, -1.0)
    for name, values in regs.items():
        values_m = _block_means(values, time_s)
        if np.ptp(values_m) == 0 or np.ptp(change_m) == 0:
            continue
        match = abs(float(np.corrcoef(change_m, values_m)[0, 1]))
        if name.startswith(signature.split(" ")[0]) or name == signature:
            match += 1e-6
        if match > best[2]:
            best = (name, float(np.corrcoef(residual_m, values_m)[0, 1]), match)
    return best[0], best[1]
