"""The noise fit's figure: the Allan deviation the fit read, its model and each term."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from gyroid.plotting._style import figure_style, subplots

_TERM_STYLES = {"Q": (0, (1, 1)), "N": ":", "B": "--", "K": "-.", "R": (0, (5, 1, 1, 1, 1, 1)),
                "G": (0, (8, 2))}


def noise_allan_figure(result) -> Figure:
    """Log-log Allan deviation of a :class:`~gyroid.allan.NoiseFit`: the log's (per
    averaging time, with its chi-square 68 % interval; the shortest ones a prefilter shapes,
    left out of the fit, in grey), its overlapping Allan deviation with the 99 % interval
    the ``allan_interval`` check reads (filled where the model's band misses it; the band's
    top with any one unresolved term at its bound marked where that raises it), the
    model-averaged fit's median and 90 % band, and each resolved term at its median
    amplitude."""
    from scipy import stats as st

    data = result.stats
    tau = data.tau_s
    grid = np.geomspace(tau[0], tau[-1], 200)
    avar = result.model_avar(grid)
    low, mid, high = np.sqrt(np.quantile(avar, [0.05, 0.5, 0.95], axis=0))
    dof = data.count
    lower = np.sqrt(data.avar * dof / st.chi2.ppf(0.84, dof))
    upper = np.sqrt(data.avar * dof / st.chi2.ppf(0.16, dof))
    with figure_style():
        fig, ax = subplots(figsize=(5.5, 4.0))
        ax.fill_between(grid, low, high, color="0.85", lw=0, label="model, 90 % band")
        ax.loglog(grid, mid, "-", color="0.0", lw=1.2, label="model (median)")
        adev = np.sqrt(data.avar)
        ax.errorbar(tau, adev, yerr=[adev - lower, upper - adev], fmt="o", ms=3.5,
                    mfc="white", mec="0.0", ecolor="0.3", elinewidth=0.8, capsize=2,
                    label="log (Haar, 68 % interval)")
        overlapping = result.overlapping
        if overlapping is not None and overlapping.tau_s.size:
            x, y = overlapping.tau_s * 1.08, overlapping.adev_deg_h  # beside the Haar points
            ax.errorbar(x, y, yerr=[y - overlapping.lower_deg_h, overlapping.upper_deg_h - y],
                        fmt="D", ms=3.0, mfc="0.5", mec="0.0", ecolor="0.0", elinewidth=1.4,
                        capsize=0, label="log (overlapping, 99 % interval)")
            raised = overlapping.model_high_deg_h > 1.05 * np.interp(
                overlapping.tau_s, grid, high)
            if raised.any():  # the band's top, any one unresolved term at its bound
                ax.loglog(overlapping.tau_s[raised], overlapping.model_high_deg_h[raised],
                          "_", ms=9, mew=1.2, color="0.3",
                          label="model's top, any unresolved term at its bound")
            missed = overlapping.outside
            if missed.any():
                ax.loglog(x[missed], y[missed], "D", ms=5.0, color="0.0",
                          label="model misses (allan_interval)")
        if result.left_out is not None:  # shaped by a prefilter: shown, not fitted
            shaped = np.sqrt(result.left_out.avar)
            ax.loglog(result.left_out.tau_s, shaped, "s", ms=3.5, color="0.55",
                      label="log, left out (prefilter)")
            adev = np.concatenate([adev, shaped])
        for name in (n for n in result.terms if n != "F"):  # F lowers, is no curve
            ax.loglog(grid, np.sqrt(result.term_avar(name, grid)), ls=_TERM_STYLES[name],
                      color="0.35", lw=0.9, label=f"{name}: {_value(result, name)}")
        ax.set_ylim(0.5 * min(adev.min(), low.min()), 2.0 * max(adev.max(), high.max()))
        ax.set_xlabel("averaging time tau, s")
        ax.set_ylabel("Allan deviation, deg/h")
        ax.legend(frameon=False, loc="best", fontsize=7)
        return fig


def _value(result, name: str) -> str:
    entry = result.gauss_markov() if name == "G" else result.term_summaries()[name]
    lo, hi = entry["ci90"]
    when = f", {entry['tau_s']:.3g} s" if name == "G" else ""
    return f"{entry['mean']:.3g} [{lo:.3g}, {hi:.3g}] {entry['unit']}{when}"


def unit_noise_figure(result) -> Figure:
    """A unit's terms over its runs (:class:`~gyroid.allan.UnitNoise`), one panel per
    pooled term: each run's median and 90 % interval, the unit's median and 90 % interval,
    and the 90 % interval a new run should land in (shaded)."""
    names = list(result.terms)
    heights = [1.0 + 0.3 * len(result.terms[n].runs) for n in names]
    with figure_style():
        fig, axes = subplots(len(names), 1, figsize=(6.0, sum(heights) + 0.6), squeeze=False,
                             gridspec_kw={"height_ratios": heights}, layout="constrained")
        for ax, name in zip(axes[:, 0], names, strict=True):
            item = result.terms[name]
            y = np.arange(len(item.runs))
            lo = [m - c[0] for m, c in zip(item.run_median, item.run_ci90, strict=True)]
            hi = [c[1] - m for m, c in zip(item.run_median, item.run_ci90, strict=True)]
            ax.axvspan(*item.new_run_ci90, color="0.9", lw=0, label="a new run, 90 %")
            ax.axvspan(*item.unit_ci90, color="0.7", lw=0, label="the unit, 90 %")
            ax.axvline(item.unit_median, color="0.0", lw=1.0, ls="--", label="the unit")
            ax.errorbar(item.run_median, y, xerr=[lo, hi], fmt="o", ms=4, mfc="white",
                        mec="0.0", ecolor="0.2", capsize=2, label="each run, 90 %")
            ax.set_yticks(y, list(item.runs), fontsize=7)
            ax.set_ylim(-0.6, len(item.runs) - 0.4)
            ax.set_xlabel(f"{name}, {_UNITS.get(name, '')} (run to run x{item.spread_median:.3g})")
        handles, labels = axes[0, 0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncol=4, frameon=False,
                   fontsize=7)
        return fig


_UNITS = {"Q": "deg", "N": "deg/sqrt(h)", "B": "deg/h", "K": "deg/h/sqrt(h)", "R": "deg/h^2"}
