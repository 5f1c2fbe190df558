"""The forest plot of a pooled fit: each run's own estimate and its pooled (shrunk)
coefficient, the population mean and a new run's predictive, one panel per coefficient."""

from __future__ import annotations

import math

import numpy as np

from gyroid.plotting._style import figure_style, subplots

#: Two-sided 95 % normal quantile (the runs' own intervals: estimate +/- 1.96 sd).
_Z95 = 1.959964


def forest_plot(result, *, units: dict[str, str] | None = None, title: str | None = None,
                truth: dict | None = None):
    """Runs against the population (a :class:`~gyroid.pool.PoolFit`).

    Per run: its own least-squares estimate (open circle, thin line, +/- 1.96 sd) and its
    pooled coefficient (filled square, thick line, central 95 % of the posterior). Below:
    the population mean (filled diamond) and a new run's predictive (open diamond, dashed),
    which is what compensating an untested unit must assume. ``truth`` (a simulated lot's:
    ``per_run`` and ``population_mean`` coefficients): each run's true value (cross) and
    the population's true mean (dashed line)."""
    names = result.coefficient_names
    labels = result.run_labels
    units = units or {}
    columns = min(len(names), 2 if len(names) == 4 else 3)
    rows = math.ceil(len(names) / columns)
    height = 0.6 + 0.28 * (len(labels) + 3)
    with figure_style():
        fig, axes = subplots(rows, columns, figsize=(3.4 * columns, height * rows),
                                 squeeze=False, sharey=True)
        y_runs = np.arange(len(labels))[::-1] + 3.0
        for k, name in enumerate(names):
            ax = axes[k // columns][k % columns]
            own, own_sd = result.own_mean[:, k], result.own_sd[:, k]
            ok = np.isfinite(own) & np.isfinite(own_sd)
            ax.errorbar(own[ok], y_runs[ok] + 0.18, xerr=_Z95 * own_sd[ok], fmt="o",
                        mfc="white", mec="0.3", ecolor="0.3", ms=4, lw=0.8, capsize=0,
                        label="run's own estimate")
            pooled = result.run_draws[:, :, k]
            lo, mid, hi = np.percentile(pooled, [2.5, 50, 97.5], axis=0)
            ax.errorbar(mid, y_runs - 0.18, xerr=[mid - lo, hi - mid], fmt="s", color="0.0",
                        ms=4, lw=1.8, capsize=0, label="pooled")
            population = result.mean_draws[..., k].reshape(-1)
            lo, mid, hi = np.percentile(population, [2.5, 50, 97.5])
            ax.errorbar([mid], [1.0], xerr=[[mid - lo], [hi - mid]], fmt="D", color="0.0",
                        ms=5, lw=1.8, capsize=0, label="population mean")
            if truth is not None:
                runs = [truth["per_run"].get(label, {}).get(name, np.nan) for label in labels]
                ax.plot(runs, y_runs, "x", color="0.0", ms=6, mew=1.2, ls="none",
                        label="true value")
                if name in truth.get("population_mean", {}):
                    ax.axvline(truth["population_mean"][name], color="0.0", lw=0.8, ls="--",
                               label="true population mean")
            new = result.new_run_draws[:, k]
            lo, mid, hi = np.percentile(new, [2.5, 50, 97.5])
            bar = ax.errorbar([mid], [0.0], xerr=[[mid - lo], [hi - mid]], fmt="D",
                              mfc="white", mec="0.0", ecolor="0.0", ms=5, lw=1.2,
                              capsize=2, label="new run (predictive)")
            bar[-1][0].set_linestyle("--")
            unit = units.get(name, "")
            ax.set_xlabel(f"{name} ({unit})" if unit else name)
            ax.axhline(2.0, color="0.8", lw=0.6)
        for k in range(len(names), rows * columns):
            axes[k // columns][k % columns].axis("off")
        ticks = list(y_runs) + [1.0, 0.0]
        for row in axes:
            row[0].set_yticks(ticks, list(labels) + ["population", "new run"])
            row[0].set_ylim(-0.8, y_runs[0] + 0.8)
        handles, texts = axes[0][0].get_legend_handles_labels()
        # the estimates first, the truths (drawn first, under them) last
        order = sorted(range(len(texts)), key=lambda i: texts[i].startswith("true"))
        handles, texts = [handles[i] for i in order], [texts[i] for i in order]
        fig.legend(handles, texts, loc="lower center", ncol=4, frameon=False,
                   bbox_to_anchor=(0.5, 1.0))
        fig.tight_layout()
        legend_rows = math.ceil(len(texts) / 4)
        if title:  # above the legend (about 0.3 inch a row)
            fig.suptitle(title, y=1.0 + (0.1 + 0.3 * legend_rows) / fig.get_figheight(),
                         va="bottom")
    return fig
