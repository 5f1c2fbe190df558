"""Paper B's closed forms (eqs. 1-9) and its printed numbers, recomputed.

Units: rates in deg/s, angles in deg, times in s, relative errors dimensionless; the
lateral error in metres. ``G`` is standard gravity.
"""

from __future__ import annotations

import math

import numpy as np

G = 9.80665  # m/s^2
DEG = math.pi / 180.0

#: Paper B's Table 1 (roll gyro) and stabiliser data, as printed.
SINS_SF_ERROR = 600e-6  # D1, 1 sigma
SINS_BIAS_DEG_H = 100.0  # bias instability, 1 sigma
MEMS_RANGE_DEG_S = 300.0
MEMS_BIAS_REPEATABILITY_DEG_H = 10.0
MEMS_BIAS_STABILITY_DEG_H = 7.0
MEMS_SF_ERROR = 280e-6  # D1gs
#: Encoder (Avago AEDB-9340) position error: 20 arc-min, which the paper computes with as
#: 0.33 deg.
ENCODER_ERROR_DEG = 0.33
#: Paper B rounds D0gs = 12.2 deg/h to 3.3e-3 deg/s in its tables.
D0GS_PRINTED_DEG_S = 3.3e-3
TABLE_TIMES_S = (10.0, 60.0, 120.0)
TABLE2_ROLL_RATE_DEG_S = 3600.0
TABLE2_DPSI_PRINTED_DEG = (21.6, 129.6, 259.2)
TABLE2_DRZ_PRINTED = (21.25, 4590.0, 36730.0)  # unit printed as km
TABLE_GS_D0GS_T_PRINTED_DEG = (0.033, 0.198, 0.396)
TABLE_GS_DPSI_PRINTED_DEG = (0.363, 0.528, 0.726)
WORKED = {"dt_s": 5.0, "roll_rate_deg_s": 900.0, "uncompensated_deg_s": 300.0}
WORKED_DK_PRINTED = 0.093


def mems_bias_deg_s() -> float:
    """D0gs: the two uncorrelated MEMS bias terms combined, deg/s (12.2 deg/h)."""
    return math.hypot(MEMS_BIAS_REPEATABILITY_DEG_H, MEMS_BIAS_STABILITY_DEG_H) / 3600.0


def roll_angle_error_deg(sf_error: float, roll_rate_deg_s: float, t_s):
    """Eq. 4: the uncorrected SINS roll-angle error ``D1 w_x t``, deg."""
    return sf_error * roll_rate_deg_s * np.asarray(t_s, dtype=float)


def gs_angle_error_deg(d0gs_deg_s: float, encoder_deg: float, t_s):
    """Eq. 9: ideal stabiliser's angle error ``D0gs t + Denc``, deg."""
    return d0gs_deg_s * np.asarray(t_s, dtype=float) + encoder_deg


def dk_ideal(d0gs_deg_s: float, encoder_deg: float, roll_rate_deg_s: float, dt_s: float):
    """Eq. 5: relative error of the correction coefficient with an ideal stabiliser."""
    return (d0gs_deg_s * dt_s + encoder_deg) / (roll_rate_deg_s * dt_s)


def dk_overloaded(d0gs_deg_s: float, d1gs: float, uncompensated_deg_s: float,
                  encoder_deg: float, roll_rate_deg_s: float, dt_s: float):
    """Eq. 7: the same with an overloaded stabiliser (uncompensated rate ``w_H``)."""
    return ((d0gs_deg_s + d1gs * uncompensated_deg_s) / roll_rate_deg_s
            + encoder_deg / (roll_rate_deg_s * dt_s))


def lateral_error_eq8_m(sf_error: float, roll_rate_deg_s: float, t_s):
    """Eq. 8 in SI: ``g D1 w_x t^3 / 6`` with ``w_x`` in rad/s, m (small-angle)."""
    t = np.asarray(t_s, dtype=float)
    return G * sf_error * roll_rate_deg_s * DEG * t**3 / 6.0


def lateral_error_exact_m(sf_error: float, roll_rate_deg_s: float, t_s):
    """``g sin(dpsi)`` integrated twice for ``dpsi = D1 w_x t``: ``g (t/w - sin(w t)/w^2)``.

    Never exceeds ``g t^2 / 2``.
    """
    t = np.asarray(t_s, dtype=float)
    omega = sf_error * roll_rate_deg_s * DEG
    if omega == 0.0:
        return np.zeros_like(t)
    return G * (t / omega - np.sin(omega * t) / omega**2)


def lateral_error_bound_m(t_s):
    """The largest lateral error gravity can cause in ``t`` seconds: ``g t^2 / 2``, m."""
    t = np.asarray(t_s, dtype=float)
    return G * t**2 / 2.0


def table2() -> dict[str, dict[str, float]]:
    """Paper B's Table 2 (w_x = 3600 deg/s, D1 = 600 ppm) recomputed, per time."""
    out = {}
    for t, dpsi_printed, drz_printed in zip(TABLE_TIMES_S, TABLE2_DPSI_PRINTED_DEG,
                                            TABLE2_DRZ_PRINTED, strict=True):
        w = TABLE2_ROLL_RATE_DEG_S
        out[f"{t:g}"] = {
            "dpsi_deg": float(roll_angle_error_deg(SINS_SF_ERROR, w, t)),
            "dpsi_printed_deg": dpsi_printed,
            "dr_z_m_eq8": float(lateral_error_eq8_m(SINS_SF_ERROR, w, t)),
            "dr_z_m_exact": float(lateral_error_exact_m(SINS_SF_ERROR, w, t)),
            "dr_z_bound_m": float(lateral_error_bound_m(t)),
            "dr_z_printed": drz_printed,
            # What the printed number matches: g D1 w_x t^3, w_x in deg/s, no 1/6, in km.
            "dr_z_printed_reconstruction": float(G * SINS_SF_ERROR * w * t**3 / 1000.0),
        }
    return out


def table_gs() -> dict[str, dict[str, float]]:
    """Paper B's ideal-stabiliser table (eq. 9) recomputed, per time."""
    out = {}
    exact = mems_bias_deg_s()
    for t, d0t, dpsi in zip(TABLE_TIMES_S, TABLE_GS_D0GS_T_PRINTED_DEG,
                            TABLE_GS_DPSI_PRINTED_DEG, strict=True):
        out[f"{t:g}"] = {
            "d0gs_t_deg": float(D0GS_PRINTED_DEG_S * t),
            "d0gs_t_printed_deg": d0t,
            "dpsi_gs_deg": float(gs_angle_error_deg(D0GS_PRINTED_DEG_S, ENCODER_ERROR_DEG, t)),
            "dpsi_gs_unrounded_deg": float(gs_angle_error_deg(exact, ENCODER_ERROR_DEG, t)),
            "dpsi_gs_printed_deg": dpsi,
        }
    return out


def dk_worked() -> dict[str, float]:
    """Paper B's worked dK (non-ideal stabiliser), printed and recomputed by eq. 7."""
    recomputed = dk_overloaded(D0GS_PRINTED_DEG_S, MEMS_SF_ERROR, WORKED["uncompensated_deg_s"],
                               ENCODER_ERROR_DEG, WORKED["roll_rate_deg_s"], WORKED["dt_s"])
    rate_term = (D0GS_PRINTED_DEG_S + MEMS_SF_ERROR * WORKED["uncompensated_deg_s"])
    return {
        "printed": WORKED_DK_PRINTED,
        "recomputed": float(recomputed),
        "rate_term": float(rate_term / WORKED["roll_rate_deg_s"]),
        "encoder_term": float(ENCODER_ERROR_DEG / (WORKED["roll_rate_deg_s"] * WORKED["dt_s"])),
        "fraction_of_D1": float(recomputed / SINS_SF_ERROR),
        # The printed 0.093 is matched by dropping both divisions by w_x (and w_x dt) and
        # taking the encoder error in radians: D0gs + D1gs w_H + Denc[rad].
        "printed_reconstruction": float(rate_term + ENCODER_ERROR_DEG * DEG),
    }
