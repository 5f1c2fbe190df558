"""Figures of paper B's loop: dK distribution, its drivers, roll-fit and roll-discrepancy
residuals."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from gyroid.plotting._style import (
    figure_style,
    subplots,
)


def dk_distribution(dk: np.ndarray, recomputed: float, printed: float) -> Figure:
    """Distribution of dK with paper B's recomputed (eq. 7) and printed values marked."""
    with figure_style():
        fig, ax = subplots(figsize=(5.5, 3.6))
        scaled = dk * 1e6
        lo, hi = np.percentile(scaled, [0.5, 99.5])
        counts, _, _ = ax.hist(scaled[(scaled >= lo) & (scaled <= hi)], bins=60, color="0.6",
                               histtype="stepfilled", label="propagated (draws x periods)")
        ax.set_ylim(0, 1.3 * max(float(np.max(counts)), 1.0))  # room for the labels above
        ax.axvline(recomputed * 1e6, color="0.0", ls="--", lw=1.2,
                   label=f"eq. 7 recomputed: {recomputed * 1e6:.0f} ppm")
        # The printed value is far off this scale: named in the legend, no line.
        ax.plot([], [], " ", label=f"printed {printed:g} = {printed * 1e6:.0f} ppm: off scale")
        ax.set_xlabel("dK, relative error of the correction coefficient, ppm")
        ax.set_ylabel("draws, count")
        ax.legend(frameon=False, loc="upper left", fontsize=7)
        return fig


def sobol_bars(first: dict[str, float], total: dict[str, float],
               interactions: dict | None = None) -> Figure:
    """First-order and total Sobol indices of dK, with the share left to interactions."""
    names = list(first)
    y = np.arange(len(names))
    with figure_style():
        fig, ax = subplots(figsize=(5.5, 0.5 * len(names) + 1.2))
        ax.barh(y + 0.2, [first[n] for n in names], height=0.4, color="0.2", label="first order")
        ax.barh(y - 0.2, [total[n] for n in names], height=0.4, color="white", edgecolor="0.0",
                hatch="//", label="total")
        ax.set_yticks(y, names)
        ax.set_xlim(0.0, 1.0)
        ax.set_xlabel("share of the variance of dK, fraction")
        ax.legend(frameon=False, loc="lower right")
        if interactions is not None:
            who = " x ".join(interactions["involving"]) or "none above 0.05"
            ax.set_title(f"{interactions['share']:.2f} of the variance is interactions "
                         f"({who})", fontsize="medium")
        return fig


def roll_fit_figure(time_s: np.ndarray, measured_deg: np.ndarray, predicted_deg: np.ndarray
                    ) -> Figure:
    """The stabiliser angle with the fitted loop's prediction against time, and below it on
    its own scale their difference."""
    t = np.asarray(time_s) - time_s[0]
    measured, predicted = np.asarray(measured_deg), np.asarray(predicted_deg)
    with figure_style():
        fig, axes = subplots(2, 1, figsize=(6.5, 5.0), sharex=True)
        axes[0].plot(t, measured, color="0.6", lw=1.6, ls="-", label="stabiliser angle")
        axes[0].plot(t, predicted, color="0.0", lw=0.7, ls="--",
                     label="fitted loop's prediction")
        axes[0].set_ylabel("angle, deg")
        axes[0].legend(frameon=False, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=2)
        axes[1].plot(t, measured - predicted, color="0.3", lw=0.5, ls="-")
        axes[1].axhline(0.0, color="0.0", lw=0.6, ls=":")
        axes[1].set_xlabel("time since start, s")
        axes[1].set_ylabel("stabiliser angle - model, deg")
        fig.align_ylabels(axes)
        fig.tight_layout()
        return fig


def roll_discrepancy_figure(report) -> Figure:
    """Stabiliser-angle residuals before/after the added roll effects, and RMS per step
    (bars from zero)."""
    with figure_style():
        fig, (ax, ax2) = subplots(1, 2, figsize=(8.0, 3.4),
                                      gridspec_kw={"width_ratios": [2, 1]})
        t = report.time_s
        ax.plot(t, report.residual_before, color="0.6", lw=0.6, ls="-", label="baseline")
        ax.plot(t, report.residual_after, color="0.0", lw=0.6, ls="-",
                label="after adding: " + (", ".join(report.added) or "nothing"))
        ax.set_xlabel("time since start, s")
        ax.set_ylabel("stabiliser angle - model, deg")
        ax.legend(frameon=False, fontsize=7)
        rms = [report.rms_baseline, *[s.rms_after for s in report.steps]]
        ax2.bar(range(len(rms)), rms, color="0.5", edgecolor="0.0", width=0.6)
        ax2.set_xticks(range(len(rms)), ["baseline", *report.added], rotation=20, fontsize=7)
        ax2.set_ylim(0.0, 1.15 * max(rms))
        ax2.set_ylabel("RMS residual, deg")
        ax2.set_xlabel("model step")
        fig.tight_layout()
        return fig
