"""Paper A's classic estimators, kept so gyroid can compare them with the Bayesian answer.

* Magnetic: per axis ``K = |dw(+300 uT) - dw(-300 uT)| / 6``, the difference of the mean
  drift at the two extreme field values over the 600 uT span (6 H0).
* Thermal: weighted least squares of ``w0 + w1 t + w2 t^2`` on a setpoint table.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._logs import BenchLog
from gyroid.models._inputs import FIELD_COLUMNS, H0_UT, T0_C


@dataclass(frozen=True)
class MagneticK:
    """Paper A's coefficient along one axis, deg/h per 100 uT."""

    axis: str
    K: float  # |dw(+H) - dw(-H)| / (2 H / H0), as the paper prints it
    signed: float  # (dw(+H) - dw(-H)) / (2 H / H0): the same with its sign, estimates w_axis
    sd: float  # standard error of ``signed`` from the spread within each dwell
    mean_plus_deg_h: float
    mean_minus_deg_h: float


def magnetic_k(
    log: BenchLog, axis: str, *, field_uT: float = 300.0, tol_uT: float = 5.0
) -> MagneticK:
    """Paper A's K along ``axis`` ('x', 'y' or 'z') from a Helmholtz sweep log.

    Rows count as the +H (-H) dwell when the axis' field is within ``tol_uT`` of +H (-H) and
    the other components within ``tol_uT`` of zero.
    """
    k = "xyz".index(axis)
    for name in FIELD_COLUMNS:
        if not log.has(name):
            raise GyroidInputError(f"the magnetic K estimator needs column {name}")
    field = np.column_stack([log.columns[c] for c in FIELD_COLUMNS])
    others = np.delete(field, k, axis=1)
    quiet = np.all(np.abs(others) < tol_uT, axis=1)
    plus = quiet & (np.abs(field[:, k] - field_uT) < tol_uT)
    minus = quiet & (np.abs(field[:, k] + field_uT) < tol_uT)
    if plus.sum() < 2 or minus.sum() < 2:
        raise GyroidInputError(
            f"column {FIELD_COLUMNS[k]} never dwells at +/-{field_uT:g} uT with the other "
            "components near zero; the K estimator needs a Helmholtz sweep log"
        )
    drift = log.drift_deg_h
    up, down = drift[plus].mean(), drift[minus].mean()
    span = 2.0 * field_uT / H0_UT
    sd = np.sqrt(drift[plus].var(ddof=1) / plus.sum() + drift[minus].var(ddof=1) / minus.sum())
    signed = (up - down) / span
    return MagneticK(axis, abs(signed), signed, sd / span, up, down)


@dataclass(frozen=True)
class PolynomialFit:
    """Weighted least squares of ``w0 + w1 t + w2 t^2`` on a setpoint table."""

    coefficients: dict[str, float]
    covariance: np.ndarray
    chi2: float
    dof: int

    @property
    def sd(self) -> dict[str, float]:
        sds = np.sqrt(np.diag(self.covariance))
        return {k: float(s) for k, s in zip(self.coefficients, sds, strict=True)}


def quadratic_design(t_rel: np.ndarray) -> np.ndarray:
    return np.column_stack([np.ones_like(t_rel), t_rel, t_rel**2])


def chi2_of(
    coefficients: dict[str, float], t_rel: np.ndarray, dw: np.ndarray, sigma: np.ndarray
) -> float:
    """Chi-square of given w0, w1, w2 on a table."""
    model = quadratic_design(t_rel) @ np.array([coefficients[k] for k in ("w0", "w1", "w2")])
    return float(np.sum(((dw - model) / sigma) ** 2))


def setpoint_table_fit(
    setpoint_C: np.ndarray, dw_deg_h: np.ndarray, sigma_deg_h: np.ndarray, *, t0_C: float = T0_C
) -> PolynomialFit:
    """Weighted least squares of ``w0 + w1 t + w2 t^2`` with ``t = setpoint - t0``.

    The covariance is the inverse Fisher matrix with the table's sigmas taken as known.
    """
    t_rel = np.asarray(setpoint_C, dtype=float) - t0_C
    X = quadratic_design(t_rel)
    w = 1.0 / np.asarray(sigma_deg_h, dtype=float)
    coef, *_ = np.linalg.lstsq(X * w[:, None], np.asarray(dw_deg_h) * w, rcond=None)
    cov = np.linalg.inv((X * w[:, None]).T @ (X * w[:, None]))
    coefficients = {k: float(v) for k, v in zip(("w0", "w1", "w2"), coef, strict=True)}
    return PolynomialFit(
        coefficients=coefficients,
        covariance=cov,
        chi2=chi2_of(coefficients, t_rel, dw_deg_h, sigma_deg_h),
        dof=int(t_rel.size - 3),
    )


def setpoint_readings(
    log: BenchLog, windows: list[tuple[float, float, float]]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Paper A's readings from a thermal log: for each (level, start, end) window the level,
    the mean drift and the RMS of the drift about it (deg/h)."""
    levels, means, rms = [], [], []
    for level, start, end in windows:
        inside = (log.time_s >= start) & (log.time_s < end)
        if inside.sum() < 2:
            raise GyroidInputError(f"no samples between {start:g} s and {end:g} s")
        values = log.drift_deg_h[inside]
        levels.append(level)
        means.append(values.mean())
        rms.append(values.std(ddof=1))
    return np.array(levels), np.array(means), np.array(rms)
