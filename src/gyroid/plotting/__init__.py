"""Figures (matplotlib, Agg): black-and-white readable, units on every axis. One module per
kind of figure; every figure function is importable from here."""

from gyroid.plotting._bench import (
    allan_figure,
    compensation_figure,
    discrepancy_figure,
    fit_overview,
    magnetic_sweep,
    pair_plot,
    thermal_run,
)
from gyroid.plotting._flight import (
    dk_distribution,
    roll_discrepancy_figure,
    roll_residual_figure,
    sobol_bars,
)
from gyroid.plotting._papers import (
    paper_a_table,
    paper_b_lateral,
    paper_b_stabiliser,
)
from gyroid.plotting._style import (
    MAX_PLOTTED_POINTS,
    STYLE,
    moving_mean,
    plot_step,
    save,
)

__all__ = [
    "MAX_PLOTTED_POINTS",
    "STYLE",
    "allan_figure",
    "compensation_figure",
    "discrepancy_figure",
    "dk_distribution",
    "fit_overview",
    "magnetic_sweep",
    "moving_mean",
    "pair_plot",
    "paper_a_table",
    "paper_b_lateral",
    "paper_b_stabiliser",
    "plot_step",
    "roll_discrepancy_figure",
    "roll_residual_figure",
    "save",
    "sobol_bars",
    "thermal_run",
]
