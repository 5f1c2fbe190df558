"""Figures (matplotlib, Agg): black-and-white readable, units on every axis. One module per
kind of figure; every figure function is importable from here.
"""

from gyroid._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "_bench": [
        "allan_figure", "compensation_figure", "discrepancy_figure", "fit_overview",
        "magnetic_sweep", "overload_run", "pair_plot", "thermal_run",
    ],
    "_flight": ["dk_distribution", "roll_discrepancy_figure", "roll_fit_figure", "sobol_bars"],
    "_noise": ["noise_allan_figure", "unit_noise_figure"],
    "_papers": ["paper_a_table", "paper_b_lateral", "paper_b_stabiliser"],
    "_style": ["MAX_PLOTTED_POINTS", "STYLE", "moving_mean", "plot_step", "save"],
})
