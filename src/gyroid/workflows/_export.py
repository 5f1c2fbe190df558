"""A fit's temperature model as a flight controller's parameters (docs/formats.md section 5).

gyroid's temperature polynomial ``w0 + w1 t + w2 t^2 + w3 t^3`` (``t = T - t0``, deg/h) is
re-centred exactly on the target's reference temperature: with ``u = T - Tref`` and
``d = Tref - t0``, ``c_k = sum_(j >= k) binom(j, k) w_j d^(j - k)``. Every posterior draw is
re-centred, so the exported coefficients carry their posterior sd and covariance.

* PX4: ``offset [rad/s] = sum_k X_k (T - TREF)^k`` (k = 0..3) with ``T`` clipped to
  [TMIN, TMAX], subtracted from the gyro's output; ``TREF`` the fitted range's midpoint.
* ArduPilot: ``v -= p(T - 35) - p(T_cal - 35)``, ``p(u) = (c1 u + c2 u^2 + c3 u^3) 1e-6``
  rad/s with ``INS_TCALn_GYRk = c_k * 1e6``: no constant term (the start-up calibration
  at ``T_cal`` removes the constant), ``T`` clipped to [TMIN, TMAX].

Terms neither can represent (dT/dt, lag, warm-up, magnetic field, steps) are left out; the
drift they leave, their summed contribution's RMS about its mean over the fitted rows, is
stated (a constant is the start-up calibration's), with the terms' names.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._fitted import FittedDrift

#: gyroid's temperature polynomial: effect -> (power, coefficient).
POLYNOMIAL = {"bias": (0, "w0"), "temperature": (1, "w1"), "temperature_sq": (2, "w2"),
              "temperature_cubic": (3, "w3")}
DEG_H_TO_RAD_S = math.pi / 180.0 / 3600.0
ARDUPILOT_TREF_C = 35.0
ARDUPILOT_SCALE = 1e6
TARGETS = ("px4", "ardupilot", "json")
#: Parameter types in a QGroundControl parameter file.
INT32, FLOAT = 6, 9


def recentre(draws: np.ndarray, shift_C: float) -> np.ndarray:
    """Coefficients (m, 4) of powers 0..3 of ``T - t0`` re-expanded in powers of
    ``T - Tref``, ``shift_C = Tref - t0`` (exact)."""
    out = np.zeros_like(draws)
    for k in range(4):
        for j in range(k, 4):
            out[:, k] += math.comb(j, k) * draws[:, j] * shift_C ** (j - k)
    return out


@dataclass(frozen=True)
class AxisPolynomial:
    """One axis's fitted temperature polynomial: draws (m, 4) of the coefficients of powers
    0..3 of ``T - t0`` (deg/h per degC^k), the fitted temperature range (degC), the terms
    left out and the RMS drift they leave (deg/h; None when the fit did not record it)."""

    axis: str | None
    draws: np.ndarray
    t0_C: float
    range_C: tuple[float, float]
    left_out: tuple[str, ...]
    truncation_rms_deg_h: float | None
    trustworthy: bool = True  # the fit's own verdict


def axis_polynomial(axis: str | None, fitted: FittedDrift) -> AxisPolynomial:
    """The temperature polynomial of one axis's fit (see the module docstring)."""
    terms = fitted.model.terms
    if "temperature" not in terms:
        raise GyroidInputError(f"the fit{'' if axis is None else f' of axis {axis}'} has no "
                               "temperature term: a firmware's thermal calibration needs one "
                               "(fit with --terms thermal or bias,temperature,...)")
    if "temperature_C" not in fitted.input_ranges:
        raise GyroidInputError("the fit records no temperature range (fit.json has no "
                               "input_ranges): fit the log again")
    names = fitted.model.parameter_names
    draws = np.zeros((fitted.draws.shape[0], 4))
    for effect, (power, name) in POLYNOMIAL.items():
        if effect in terms:
            draws[:, power] = fitted.draws[:, names.index(name)]
    left_out = tuple(t for t in terms if t not in POLYNOMIAL)
    return AxisPolynomial(axis, draws, fitted.t0_C, _low_high(fitted.input_ranges["temperature_C"]),
                          left_out, _truncation(fitted, left_out), fitted.trustworthy)


def _truncation(fitted: FittedDrift, left_out: tuple[str, ...]) -> float | None:
    if not left_out:
        return 0.0
    effects = fitted.contributions.get("effects", {})
    if not all(name in effects for name in left_out):
        return None
    total = np.sum([np.asarray(effects[name], dtype=float) for name in left_out], axis=0)
    return float(np.sqrt(np.mean((total - total.mean()) ** 2)))


@dataclass(frozen=True)
class FirmwareExport:
    """Parameters for one target: ``parameters`` (name, value, QGC type), ``record``
    (``export.json``) and the parameter file's name and text."""

    target: str
    parameters: tuple[tuple[str, float, int], ...]
    record: dict
    file_name: str
    comments: tuple[str, ...]

    @property
    def trustworthy(self) -> bool:
        """Whether every exported axis's fit passed its own checks."""
        return all(a["source_trustworthy"] for a in self.record["axes"].values())

    def text(self) -> str:
        """The parameter file: QGroundControl's tab-separated rows for PX4, ``NAME,VALUE``
        lines for ArduPilot (Mission Planner and MAVProxy read them), ``#`` comments."""
        lines = [f"# {c}" for c in self.comments]
        if self.target == "px4":
            lines.append("# Vehicle-Id Component-Id Name Value Type")
            lines += [f"1\t1\t{name}\t{_number(value, kind)}\t{kind}"
                      for name, value, kind in self.parameters]
        else:
            lines += [f"{name},{_number(value, kind)}" for name, value, kind in self.parameters]
        return "\n".join(lines) + "\n"


def _number(value: float, kind: int) -> str:
    return str(int(value)) if kind == INT32 else repr(float(value))


def export_fit(polynomials: dict[str | None, AxisPolynomial], target: str, *,
               instance: int = 0, device_id: int | None = None) -> FirmwareExport:
    """The parameters of ``target`` (px4, ardupilot or json) for a fit's axes (x, y, z; an
    axis the fit lacks gets zero coefficients, said in the file)."""
    if target not in TARGETS:
        raise GyroidInputError(f"--to {target!r}: use one of {', '.join(TARGETS)} (kalibr and "
                               "openvins take a noise fit: gyroid noise)")
    low = min(p.range_C[0] for p in polynomials.values())
    high = max(p.range_C[1] for p in polynomials.values())
    tref = ARDUPILOT_TREF_C if target == "ardupilot" else (
        0.5 * (low + high) if target == "px4" else next(iter(polynomials.values())).t0_C)
    by_axis = _by_axis(polynomials)
    scale = {"px4": DEG_H_TO_RAD_S, "ardupilot": DEG_H_TO_RAD_S * ARDUPILOT_SCALE,
             "json": 1.0}[target]
    coefficients = {axis: recentre(p.draws, tref - p.t0_C) * scale
                    for axis, p in by_axis.items()}
    record = _record(target, polynomials, coefficients, tref, (low, high), by_axis)
    if target == "px4":
        record["device_id"] = int(device_id or 0)
    comments = _comments(target, polynomials, tref, by_axis)
    if target == "px4":
        parameters = _px4(coefficients, instance, device_id, tref, low, high)
        name = "gyro_thermal.params"
    elif target == "ardupilot":
        parameters = _ardupilot(coefficients, instance, low, high)
        name = "gyro_thermal.parm"
    else:
        parameters, name = (), ""
    return FirmwareExport(target, parameters, record, name, comments)


def _by_axis(polynomials: dict[str | None, AxisPolynomial]) -> dict[str, AxisPolynomial]:
    """The fit's axes as x, y, z (a fit of one drift column is taken as x and said so)."""
    if None in polynomials:
        return {"x": polynomials[None]}
    unknown = [a for a in polynomials if a not in ("x", "y", "z")]
    if unknown:
        raise GyroidInputError(f"axis {unknown[0]!r}: a firmware's gyro has axes x, y, z; "
                               "name the fit's axes so (drift_x_deg_h, ...)")
    return {axis: p for axis, p in polynomials.items() if axis is not None}


def _px4(coefficients, instance, device_id, tref, low, high):
    g = f"TC_G{instance}"
    out = [(f"{g}_ID", float(device_id or 0), INT32), (f"{g}_TMAX", high, FLOAT),
           (f"{g}_TMIN", low, FLOAT), (f"{g}_TREF", tref, FLOAT)]
    for k in range(4):
        for a, axis in enumerate("xyz"):
            value = float(coefficients[axis][:, k].mean()) if axis in coefficients else 0.0
            out.append((f"{g}_X{k}_{a}", value, FLOAT))
    return tuple(sorted(out))


def _ardupilot(coefficients, instance, low, high):
    n = instance + 1
    out = [(f"INS_TCAL{n}_ENABLE", 1.0, INT32), (f"INS_TCAL{n}_TMIN", low, FLOAT),
           (f"INS_TCAL{n}_TMAX", high, FLOAT)]
    for k in (1, 2, 3):
        for axis in "xyz":
            value = float(coefficients[axis][:, k].mean()) if axis in coefficients else 0.0
            out.append((f"INS_TCAL{n}_GYR{k}_{axis.upper()}", value, FLOAT))
    return tuple(out)


_UNITS = {"px4": "rad/s per degC^k", "ardupilot": "1e-6 rad/s per degC^k",
          "json": "deg/h per degC^k"}


def _record(target, polynomials, coefficients, tref, range_C, by_axis) -> dict:
    powers = (0, 1, 2, 3) if target != "ardupilot" else (1, 2, 3)
    axes = {}
    for axis, values in coefficients.items():
        p = by_axis[axis]
        chosen = values[:, list(powers)]
        cov = np.atleast_2d(np.cov(chosen, rowvar=False))
        axes[axis] = {
            "coefficients": {f"c{k}": {"mean": float(values[:, k].mean()),
                                       "sd": float(values[:, k].std(ddof=1))} for k in powers},
            "covariance": cov.tolist(),
            "fitted_range_C": list(p.range_C),
            "left_out_terms": list(p.left_out),
            "truncation_rms_deg_h": p.truncation_rms_deg_h,
            "source_trustworthy": p.trustworthy,
        }
    return {"target": target, "reference_C": tref, "range_C": list(range_C),
            "units": _UNITS[target], "powers": list(powers),
            "formula": {"px4": "offset = sum_k X_k (T - TREF)^k, T clipped to [TMIN, TMAX]",
                        "ardupilot": "v -= p(T - 35) - p(T_cal - 35), p(u) = 1e-6 "
                                     "(c1 u + c2 u^2 + c3 u^3), T clipped to [TMIN, TMAX]",
                        "json": "drift [deg/h] = sum_k c_k (T - t0)^k"}[target],
            "axes": axes,
            "truncation_rms_note": "RMS about its mean, over the fitted rows, of the terms "
                                   "the target cannot represent (a constant is the firmware's "
                                   "start-up calibration); null: the fit did not record them"}


def _comments(target, polynomials, tref, by_axis) -> tuple[str, ...]:
    out = [f"gyroid thermal calibration for {target}: the fitted temperature polynomial "
           f"re-centred on {tref:.6g} degC",
           "posterior sd, covariance and the fitted range: export.json beside this file"]
    for axis, p in by_axis.items():
        if p.left_out:
            rms = ("unknown" if p.truncation_rms_deg_h is None else
                   f"{p.truncation_rms_deg_h:.3g} deg/h RMS")
            out.append(f"axis {axis}: left out {', '.join(p.left_out)} (not representable): "
                       f"{rms} of drift stays uncorrected over the fitted range")
        if not p.trustworthy:
            out.append(f"axis {axis}: its fit is NOT trustworthy (fit.json checks): refit "
                       "before flying these parameters")
    missing = [a for a in "xyz" if a not in by_axis]
    if missing:
        out.append(f"axes {', '.join(missing)} not in the fit: their coefficients are zero")
    if None in polynomials:
        out.append("the fit is of one drift column, exported as the x axis")
    return tuple(out)


def _low_high(pair: list[float]) -> tuple[float, float]:
    """A [low, high] list (fit.json's input ranges) as a pair."""
    low, high = pair
    return float(low), float(high)
