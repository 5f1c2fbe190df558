"""Figures (matplotlib, Agg): black-and-white readable, units on every axis."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from gyroid.inputs import FIELD_COLUMNS  # noqa: E402
from gyroid.logs import BenchLog  # noqa: E402

STYLE = {
    "figure.dpi": 110,
    "savefig.dpi": 150,
    "axes.grid": True,
    "grid.linestyle": ":",
    "grid.color": "0.7",
    "axes.prop_cycle": matplotlib.cycler(color=["0.0", "0.45", "0.65"])
    + matplotlib.cycler(linestyle=["-", "--", ":"]),
    "font.size": 9,
}


def save(fig: plt.Figure, path: Path, *, pdf: bool = False) -> list[Path]:
    """Save a figure as PNG (and PDF) and close it; returns the written paths."""
    path = Path(path)
    written = [path.with_suffix(".png")]
    fig.savefig(written[0], bbox_inches="tight")
    if pdf:
        written.append(path.with_suffix(".pdf"))
        fig.savefig(written[1], bbox_inches="tight")
    plt.close(fig)
    return written


def thermal_run(
    log: BenchLog, rate_C_h: np.ndarray, true_drift: np.ndarray | None = None
) -> plt.Figure:
    """Paper A Fig. 1 style: drift, temperature and its rate against time."""
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(3, 1, figsize=(6.5, 6.5), sharex=True)
        hours = (log.time_s - log.time_s[0]) / 3600.0
        axes[0].plot(hours, log.drift_deg_h, color="0.6", lw=0.4, ls="-", label="logged (1 Hz)")
        if true_drift is not None:
            axes[0].plot(hours, true_drift, color="0.0", lw=1.2, ls="-", label="true drift")
        axes[0].set_ylabel("drift, deg/h")
        axes[0].legend(loc="upper left", frameon=False)
        axes[1].plot(hours, log.columns["temperature_C"], color="0.0", lw=1.0)
        axes[1].set_ylabel("temperature, degC")
        axes[2].plot(hours, rate_C_h, color="0.0", lw=1.0)
        axes[2].set_ylabel("dT/dt, degC/h")
        axes[2].set_xlabel("time since start, h")
        fig.align_ylabels(axes)
        return fig


def magnetic_sweep(log: BenchLog) -> plt.Figure:
    """Field projections and drift against time for a Helmholtz sweep log."""
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(2, 1, figsize=(6.5, 4.8), sharex=True)
        hours = (log.time_s - log.time_s[0]) / 3600.0
        axes[0].plot(hours, log.drift_deg_h, color="0.5", lw=0.4, ls="-")
        axes[0].set_ylabel("drift, deg/h")
        for name in FIELD_COLUMNS:
            if log.has(name):
                axes[1].plot(hours, log.columns[name], lw=1.0, label=name.split("_")[0])
        axes[1].set_ylabel("field, uT")
        axes[1].set_xlabel("time since start, h")
        axes[1].legend(loc="upper right", frameon=False, ncol=3)
        fig.align_ylabels(axes)
        return fig
