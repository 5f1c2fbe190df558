"""Public names of :mod:`gyroid.plotting` for type checkers; at run time the package reads this
file (lazy_loader) and imports each name on first use."""

from ._bench import allan_figure as allan_figure
from ._bench import compensation_figure as compensation_figure
from ._bench import discrepancy_figure as discrepancy_figure
from ._bench import fit_overview as fit_overview
from ._bench import magnetic_sweep as magnetic_sweep
from ._bench import overload_run as overload_run
from ._bench import pair_plot as pair_plot
from ._bench import thermal_run as thermal_run
from ._flight import dk_distribution as dk_distribution
from ._flight import roll_discrepancy_figure as roll_discrepancy_figure
from ._flight import roll_fit_figure as roll_fit_figure
from ._flight import sobol_bars as sobol_bars
from ._noise import noise_allan_figure as noise_allan_figure
from ._noise import unit_noise_figure as unit_noise_figure
from ._papers import paper_a_table as paper_a_table
from ._papers import paper_b_lateral as paper_b_lateral
from ._papers import paper_b_stabiliser as paper_b_stabiliser
from ._style import MAX_PLOTTED_POINTS as MAX_PLOTTED_POINTS
from ._style import STYLE as STYLE
from ._style import moving_mean as moving_mean
from ._style import plot_step as plot_step
from ._style import save as save
