"""Figures of the papers' reproduced tables."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from gyroid.plotting._style import (
    figure_style,
    subplots,
)


def paper_a_table(reproduce: dict) -> Figure:
    """Paper A's setpoint table with the printed and the refitted quadratic."""
    a = reproduce["paper_a"]
    rows = a["table"]
    setpoints = np.array([float(s) for s in rows])
    dw = np.array([rows[s]["dw_deg_h"] for s in rows])
    sigma = np.array([rows[s]["sigma_deg_h"] for s in rows])
    grid = np.linspace(setpoints.min() - 2, setpoints.max() + 2, 200)
    t = grid - reproduce["constants"]["t0_C"]
    with figure_style():
        fig, ax = subplots(figsize=(5.5, 3.8))
        ax.errorbar(setpoints, dw, yerr=sigma, fmt="o", color="0.0", ms=4, capsize=3,
                    label="paper A's table (+/- sigma)")
        for key, style, label in (("published", "--", "printed w0, w1, w2"),
                                  ("refit", "-", "weighted refit")):
            c = a[key]
            ax.plot(grid, c["w0"] + c["w1"] * t + c["w2"] * t**2, color="0.0", ls=style,
                    lw=1.2, label=f"{label} (chi2 = {c['chi2']:.1f})")
        ax.set_xlabel("thermostat setpoint, degC")
        ax.set_ylabel("drift deviation, deg/h")
        ax.legend(frameon=False, loc="upper left")
        return fig


def paper_b_lateral(reproduce: dict) -> Figure:
    """Paper B Table 2: lateral error by eq. 8, exactly, as printed, and the g t^2/2 bound."""
    from gyroid.models import _paper_b as pb

    times = np.linspace(0.5, 125.0, 300)
    with figure_style():
        fig, ax = subplots(figsize=(5.5, 3.8))
        ax.plot(times, pb.lateral_error_eq8_m(pb.SINS_SF_ERROR, pb.TABLE2_ROLL_RATE_DEG_S, times),
                color="0.0", ls="--", label="eq. 8 in SI (small angle)")
        ax.plot(times, pb.lateral_error_exact_m(pb.SINS_SF_ERROR, pb.TABLE2_ROLL_RATE_DEG_S,
                                                times), color="0.0", ls="-",
                label="g sin(dpsi) integrated twice")
        ax.plot(times, pb.lateral_error_bound_m(times), color="0.5", ls=":", lw=1.5,
                label="bound g t^2 / 2")
        table = reproduce["paper_b"]["table2"]
        ts = np.array([float(t) for t in table])
        printed_km = np.array([table[t]["dr_z_printed"] for t in table])
        ax.plot(ts, printed_km * 1000.0, "s", color="0.0", mfc="white",
                label="printed (km, shown in m)")
        ax.set_yscale("log")
        ax.set_xlabel("time since the start of the flight, s")
        ax.set_ylabel("lateral position error, m")
        ax.legend(frameon=False, loc="lower right", fontsize=7)
        return fig


def paper_b_stabiliser(reproduce: dict) -> Figure:
    """Paper B's ideal-stabiliser angle error (eq. 9): printed, and recomputed."""
    table = reproduce["paper_b"]["table_gs"]
    ts = np.array([float(t) for t in table])
    with figure_style():
        fig, ax = subplots(figsize=(5.0, 3.4))
        ax.plot(ts, [table[t]["dpsi_gs_printed_deg"] for t in table], "o", color="0.0",
                label="printed")
        ax.plot(ts, [table[t]["dpsi_gs_deg"] for t in table], "-", color="0.0",
                label="eq. 9, D0gs = 3.3e-3 deg/s")
        ax.plot(ts, [table[t]["dpsi_gs_unrounded_deg"] for t in table], "--", color="0.4",
                label="eq. 9, D0gs = 12.21 deg/h unrounded")
        ax.set_xlabel("time, s")
        ax.set_ylabel("stabiliser angle error, deg")
        ax.legend(frameon=False)
        return fig
