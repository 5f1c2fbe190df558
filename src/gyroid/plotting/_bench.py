"""Figures of bench logs and their fits: thermal run, Helmholtz sweep, fit overview, posterior
pairs, discrepancy, compensation and Allan deviation."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from gyroid.io._logs import BenchLog
from gyroid.models._inputs import ACCEL_COLUMNS, FIELD_COLUMNS
from gyroid.plotting._style import (
    _break_gaps,
    _every,
    _rate_label,
    figure_style,
    moving_mean,
    subplots,
)


def thermal_run(
    log: BenchLog, rate_C_h: np.ndarray, true_drift: np.ndarray | None = None,
    rate_window_s: float | None = None, thinned_by: int = 1,
) -> Figure:
    """Paper A Fig. 1 style: drift, temperature and its rate against time. The logged
    drift is drawn over the true drift (when known); its noise is shown in its own panel,
    because at the heating peaks' scale it is thinner than a line. ``rate_C_h`` is dT/dt as
    gyroid estimates it from the logged temperature (window ``rate_window_s``). ``log``
    may be every ``thinned_by``-th sample of the log (one too long to hold)."""
    with figure_style():
        rows = 4 if true_drift is not None else 3
        fig, axes = subplots(rows, 1, figsize=(6.5, 1.9 * rows + 0.8), sharex=True)
        shown, thinned = _every(log.n, thinned_by)
        hours = ((log.time_s - log.time_s[0]) / 3600.0)[shown]
        drift = np.asarray(log.drift_deg_h)[shown]
        temperature = np.asarray(log.columns["temperature_C"])[shown]
        rate_C_h = np.asarray(rate_C_h)[shown]
        true_drift = None if true_drift is None else np.asarray(true_drift)[shown]
        axes[0].plot(hours, drift, color="0.6", lw=0.5, ls="-",
                     label=f"logged ({_rate_label(log.time_s, thinned_by)}{thinned})")
        if true_drift is not None:
            axes[0].plot(hours, true_drift, color="0.0", lw=0.7, ls="-", label="true drift")
        axes[0].set_ylabel("drift, deg/h")
        axes[0].legend(loc="upper right", frameon=False)
        k = 1
        if true_drift is not None:
            axes[1].plot(hours, drift - true_drift, color="0.4", lw=0.3, ls="-")
            axes[1].set_ylabel("logged - true,\ndeg/h")
            k = 2
        axes[k].plot(hours, temperature, color="0.0", lw=1.0)
        axes[k].set_ylabel("temperature, degC")
        axes[k + 1].plot(hours, rate_C_h, color="0.0", lw=1.0)
        window = f", {rate_window_s / 60:.0f} min window" if rate_window_s else ""
        axes[k + 1].set_ylabel(f"dT/dt, degC/h\n(estimated{window})")
        axes[k + 1].set_xlabel("time since start, h")
        fig.align_ylabels(axes)
        return fig


def magnetic_sweep(log: BenchLog, model_deg_h: np.ndarray | None = None) -> Figure:
    """Field projections and drift against time for a Helmholtz sweep log, with a fitted
    model's drift over the data when given. Lines break at gaps (the azimuth turn)."""
    return _drift_over(log, model_deg_h, FIELD_COLUMNS, "field, uT")


def overload_run(log: BenchLog, model_deg_h: np.ndarray | None = None) -> Figure:
    """Specific force and drift against time for an overload (orientation) log, with a
    fitted model's drift when given."""
    return _drift_over(log, model_deg_h, ACCEL_COLUMNS, "specific force, g")


def _drift_over(log: BenchLog, model_deg_h: np.ndarray | None, names: tuple[str, ...],
                ylabel: str) -> Figure:
    """Drift (top) and three logged components (bottom, solid, dashed, dotted) against
    time."""
    with figure_style():
        fig, axes = subplots(2, 1, figsize=(6.5, 5.0), sharex=True)
        shown, thinned = _every(log.n)
        hours = ((log.time_s - log.time_s[0]) / 3600.0)[shown]
        h, drift = _break_gaps(hours, np.asarray(log.drift_deg_h)[shown])
        axes[0].plot(h, drift, color="0.6", lw=0.4, ls="-", label="logged drift" + thinned)
        if model_deg_h is not None:
            axes[0].plot(h, _break_gaps(hours, np.asarray(model_deg_h)[shown])[1], color="0.0",
                         lw=1.2, ls="-", label="fitted model")
        if model_deg_h is not None or thinned:
            axes[0].legend(loc="upper left", frameon=False, ncol=2)
        axes[0].set_ylabel("drift, deg/h")
        styles = (("-", 1.0), ("--", 1.0), (":", 1.6))
        for name, (ls, lw) in zip(names, styles, strict=True):
            if log.has(name):
                values = np.asarray(log.columns[name])[shown]
                axes[1].plot(h, _break_gaps(hours, values)[1], color="0.0", lw=lw,
                             ls=ls, label=name.split("_")[0])
        axes[1].set_ylabel(ylabel)
        axes[1].set_xlabel("time since start, h")
        axes[1].legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False, ncol=3)
        fig.align_ylabels(axes)
        return fig


def _minute_mean(time_s: np.ndarray, values: np.ndarray) -> np.ndarray | None:
    """``values``' moving mean over 60 s of samples, or None when a sample already spans
    that long (or the log is shorter)."""
    window = max(1, int(round(60.0 / max(np.median(np.diff(time_s)), 1e-9))))
    return moving_mean(values, window) if 1 < window < np.asarray(values).size else None


def fit_overview(time_s: np.ndarray, drift: np.ndarray, predictions: np.ndarray,
                 point_prediction: np.ndarray, data_label: str = "logged drift") -> Figure:
    """Data with the modelled drift; the posterior 95 % band of the model about its point
    estimate (at the data's scale it is thinner than a line, so it has its own panel); and
    the residuals against time; ``data_label`` says what the fitted rows are (block
    means...). ``predictions`` are draws of the model at every
    :func:`plot_step`-th sample (what
    :meth:`~gyroid.bench.BenchFit.predict_draws` gives with that ``every``); long
    logs are drawn thinned the same way."""
    shown, thinned = _every(np.asarray(time_s).size)
    with figure_style():
        fig, axes = subplots(3, 1, figsize=(6.5, 6.4), sharex=True,
                                 gridspec_kw={"height_ratios": [2, 1, 1]})
        hours = ((time_s - time_s[0]) / 3600.0)[shown]
        point = np.asarray(point_prediction)[shown]
        lo, hi = np.percentile(predictions, [2.5, 97.5], axis=0)
        axes[0].plot(hours, np.asarray(drift)[shown], color="0.65", lw=0.4, ls="-",
                     label=data_label + thinned)
        axes[0].plot(hours, point, color="0.0", lw=0.9, ls="-",
                     label="model at the point estimate")
        axes[0].set_ylabel("drift, deg/h")
        axes[0].legend(loc="best", frameon=False)
        axes[1].fill_between(hours, lo - point, hi - point, color="0.6", lw=0)
        axes[1].axhline(0.0, color="0.0", lw=0.6, ls=":")
        axes[1].set_ylabel("model - point\nestimate, deg/h")
        axes[1].set_title("the model's 95 % posterior band about its point estimate",
                          fontsize=8, loc="left")
        residual = np.asarray(drift) - np.asarray(point_prediction)
        axes[2].plot(hours, residual[shown], color="0.55", lw=0.4, ls="-")
        smooth = _minute_mean(time_s, residual)
        if smooth is not None:
            axes[2].plot(hours, smooth[shown], color="0.0", lw=1.0, ls="-", label="60 s mean")
            axes[2].legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), frameon=False)
        axes[2].axhline(0.0, color="0.0", lw=0.6, ls=":")
        axes[2].set_ylabel("residual, deg/h")
        axes[2].set_xlabel("time since start, h")
        fig.align_ylabels(axes)
        return fig


def pair_plot(draws: np.ndarray, names: list[str], units: dict[str, str],
              truth: dict[str, float] | None = None, max_points: int = 1500) -> Figure:
    """Corner plot of posterior draws (n, d): histograms and pairwise scatter."""
    d = len(names)
    rng = np.random.default_rng(0)
    pick = rng.choice(draws.shape[0], size=min(max_points, draws.shape[0]), replace=False)
    with figure_style({"axes.grid": False, "font.size": 7}):
        # the lower triangle and the diagonal only: an axes costs ~10 ms to make and draw
        fig = Figure(figsize=(1.6 * d + 1, 1.6 * d + 1))
        grid = fig.add_gridspec(d, d, wspace=0.08, hspace=0.08)
        for i in range(d):
            for j in range(i + 1):
                ax = fig.add_subplot(grid[i, j])
                if i == j:
                    ax.hist(draws[:, i], bins=40, color="0.5", histtype="stepfilled")
                    ax.set_yticks([])
                    if truth and names[i] in truth:
                        ax.axvline(truth[names[i]], color="0.0", ls="--", lw=1.0)
                else:
                    ax.plot(draws[pick, j], draws[pick, i], ".", color="0.2", ms=1.0, alpha=0.4)
                    if truth and names[i] in truth and names[j] in truth:
                        ax.plot(truth[names[j]], truth[names[i]], "x", color="0.0", ms=6)
                if i == d - 1:
                    ax.set_xlabel(f"{names[j]}, {units.get(names[j], '')}")
                else:
                    ax.set_xticklabels([])
                if j == 0 and i > 0:
                    ax.set_ylabel(f"{names[i]}, {units.get(names[i], '')}")
                elif j > 0:
                    ax.set_yticklabels([])
                ax.tick_params(labelsize=6)
                for label in ax.get_xticklabels():
                    label.set_rotation(45)
        return fig


def discrepancy_figure(report, regressor_values: np.ndarray | None, regressor_name: str
                       ) -> Figure:
    """Residuals before/after against time, the regressor that explains them, RMS per step."""
    time_s = np.asarray(report.time_s)
    window = max(60.0, (time_s[-1] - time_s[0]) / 400.0)
    index = np.floor((time_s - time_s[0]) / window).astype(int)
    counts = np.bincount(index)
    keep = counts >= 0.5 * np.median(counts[counts > 0])  # drop a short last block

    def means(values):
        return np.bincount(index, weights=np.asarray(values))[keep] / counts[keep]

    hours = means((time_s - time_s[0]) / 3600.0)
    before, after = means(report.residual_before), means(report.residual_after)
    with figure_style():
        fig = Figure(figsize=(7.5, 6.0))
        grid = fig.add_gridspec(2, 2, height_ratios=[1.2, 1])
        ax = fig.add_subplot(grid[0, :])
        h, b, a = _break_gaps(hours, before, after)
        ax.plot(h, b, color="0.6", lw=1.0, ls="-", label="baseline model")
        ax.plot(h, a, color="0.0", lw=1.0, ls="-", label="after adding: "
                + (", ".join(report.added) or "nothing"))
        ax.axhline(0.0, color="0.0", lw=0.5, ls=":")
        ax.set_xlabel("time since start, h")
        ax.set_ylabel(f"residual ({window:.0f} s means), deg/h")
        ax.legend(frameon=False, loc="best")
        ax2 = fig.add_subplot(grid[1, 0])
        if report.added:
            # what the added effects explain, whatever axes and regressors they read
            explained = means(np.asarray(report.residual_before)
                              - np.asarray(report.residual_after))
            ax2.plot(explained, before, ".", color="0.2", ms=2.5)
            span = [float(min(explained.min(), before.min())),
                    float(max(explained.max(), before.max()))]
            ax2.plot(span, span, color="0.0", lw=0.8, ls="--", label="1:1")
            ax2.legend(frameon=False, loc="upper left")
            ax2.set_xlabel(f"explained by {', '.join(report.added)}, deg/h")
        else:
            from gyroid.workflows._residual_structure import REGRESSOR_UNITS

            if regressor_values is not None:
                x = means(regressor_values)
                ax2.plot(x, before, ".", color="0.2", ms=2.5)
                levels = np.unique(np.round(x, 9))
                if levels.size <= 5:  # a sign or a step: its values, not a continuum
                    ax2.set_xticks(levels)
            ax2.set_xlabel(f"{regressor_name}, {REGRESSOR_UNITS.get(regressor_name, '-')}")
        ax2.set_ylabel(f"baseline residual ({window:.0f} s means), deg/h")
        # The structure an effect explains shows in the block means; per sample the white
        # noise dominates (quoted in the labels). Bars from zero: the gap is not inflated.
        ax3 = fig.add_subplot(grid[1, 1])
        rms_means = [float(np.sqrt(np.mean(before**2))), float(np.sqrt(np.mean(after**2)))]
        # A fast log was searched on means of several samples: say what the RMS is of.
        unit = report.rms_unit.partition("(of ")[2].rstrip(")") or "sample"
        per = f"per {unit.removesuffix('s')}" if unit != "sample" else "per sample"
        labels = [f"baseline\n({report.rms_baseline:#.3g} {per})",
                  ("+ " + ", ".join(report.added) if report.added else "nothing added")
                  + f"\n({report.rms_final:#.3g} {per})"]
        ax3.bar([0, 1], rms_means, width=0.5, color=["0.6", "0.0"])
        ax3.set_xticks([0, 1], labels, fontsize=7)
        ax3.set_ylim(0.0, 1.15 * max(rms_means))
        ax3.set_ylabel(f"RMS of the {window:.0f} s means, deg/h")
        fig.tight_layout()
        return fig


def compensation_figure(time_s: np.ndarray, before: np.ndarray, after: np.ndarray
                        ) -> Figure:
    """The logged drift, and below it on its own scale the compensated drift (samples and
    their 60 s means): at the logged drift's scale what compensation leaves is a line at
    zero."""
    time_s = np.asarray(time_s, dtype=float)
    shown, thinned = _every(time_s.size)
    hours = ((time_s - time_s[0]) / 3600.0)[shown]
    with figure_style():
        fig, axes = subplots(2, 1, figsize=(6.5, 5.0), sharex=True,
                             gridspec_kw={"height_ratios": [1, 1]})
        axes[0].plot(hours, np.asarray(before)[shown], color="0.4", lw=0.5, ls="-")
        axes[0].set_ylabel("logged drift, deg/h")
        axes[0].set_title("logged drift" + thinned, fontsize=9, loc="left")
        after = np.asarray(after, dtype=float)
        axes[1].plot(hours, after[shown], color="0.65", lw=0.4, ls="-", label="samples")
        smooth = _minute_mean(time_s, after)
        if smooth is not None:
            axes[1].plot(hours, smooth[shown], color="0.0", lw=1.0, ls="-",
                         label="60 s mean")
        axes[1].axhline(0.0, color="0.0", lw=0.6, ls=":")
        axes[1].set_ylabel("compensated drift, deg/h")
        axes[1].set_xlabel("time since start, h")
        axes[1].set_title("after compensation (own scale)", fontsize=9, loc="left")
        axes[1].legend(frameon=False, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=2)
        fig.align_ylabels(axes)
        fig.tight_layout()
        return fig


def allan_figure(before, after) -> Figure:
    """Log-log Allan deviation before and after, with the after-curve's angle random walk
    (slope -1/2 through its shortest tau) and, where resolved, its floor drawn as
    references: the compensated residual's floor, what the compensation leaves, not the
    gyro's bias instability (the before-curve of a thermal run is the drift itself, not
    noise: no slope fits it)."""
    with figure_style():
        fig, ax = subplots(figsize=(5.5, 4.0))
        for adev, style, label in ((before, "s", "before"), (after, "o", "after")):
            ax.fill_between(adev.tau_s, adev.lower_deg_h, adev.upper_deg_h, color="0.85", lw=0)
            ax.loglog(adev.tau_s, adev.adev_deg_h, style + "-", color="0.0" if label == "after"
                      else "0.5", ms=3, lw=1.0, label=f"{label} compensation")
        tau = after.tau_s
        level_arw = after.arw()
        level, at_s, resolved = after.floor(level_arw)
        ax.loglog(tau, level_arw * 60.0 / np.sqrt(tau), ":", color="0.2", lw=0.9,
                  label=f"angle random walk {level_arw:.2g} deg/sqrt(h) (-1/2)")
        if resolved:
            ax.axhline(level, color="0.2", lw=0.9, ls="--",
                       label=f"residual's floor {level:.2g} deg/h at {at_s:.3g} s")
        ax.set_xlabel("averaging time tau, s")
        ax.set_ylabel("Allan deviation, deg/h")
        ax.legend(frameon=False, loc="upper left", fontsize=7)
        return fig
