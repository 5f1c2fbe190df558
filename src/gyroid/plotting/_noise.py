"""The noise fit's figure: the Allan deviation the fit read, its model and each term."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from gyroid.plotting._style import figure_style, subplots

_TERM_STYLES = {"Q": (0, (1, 1)), "N": ":", "B": "--", "K": "-.", "R": (0, (5, 1, 1, 1, 1, 1))}


def noise_allan_figure(result) -> Figure:
    """Log-log Allan deviation of a :class:`~gyroid.inference.NoiseFit`: the log's (per
    averaging time, with its chi-square 68 % interval), the model-averaged fit's median and
    90 % band, and each resolved term at its median amplitude."""
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
        for name in result.terms:
            ax.loglog(grid, np.sqrt(result.term_avar(name, grid)), ls=_TERM_STYLES[name],
                      color="0.35", lw=0.9, label=f"{name}: {_value(result, name)}")
        ax.set_ylim(0.5 * min(adev.min(), low.min()), 2.0 * max(adev.max(), high.max()))
        ax.set_xlabel("averaging time tau, s")
        ax.set_ylabel("Allan deviation, deg/h")
        ax.legend(frameon=False, loc="best", fontsize=7)
        return fig


def _value(result, name: str) -> str:
    entry = result.term_summaries()[name]
    lo, hi = entry["ci90"]
    return f"{entry['mean']:.3g} [{lo:.3g}, {hi:.3g}] {entry['unit']}"
