"""The figures' shared style (black and white, units on every axis), saving, and thinning long
logs to at most 5000 drawn points."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import matplotlib
import numpy as np
from cycler import cycler
from matplotlib.figure import Figure

from gyroid.io._logs import gap_threshold

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType  # matplotlib >= 3.9

#: Figures are drawn inside this style and saved after it (:func:`save`), at the figure's
#: own resolution: ``figure.dpi`` (a savefig.dpi here would never apply).
STYLE: dict[RcKeyType, Any] = {
    "figure.dpi": 110,
    "axes.grid": True,
    "grid.linestyle": ":",
    "grid.color": "0.7",
    "axes.prop_cycle": cycler(color=["0.0", "0.45", "0.65"])
    + cycler(linestyle=["-", "--", ":"]),
    "font.size": 9,
}


def subplots(*args, figsize: tuple[float, float],
             layout: Literal["constrained", "compressed", "tight"] | None = None, **kwargs):
    """A figure and its axes, as ``pyplot.subplots`` makes them but without pyplot: no
    backend is chosen and no global figure registry is kept (a figure is a plain object,
    freed when dropped, and saved by :func:`save`)."""
    fig = Figure(figsize=figsize, layout=layout)
    return fig, fig.subplots(*args, **kwargs)


def figure_style(overrides: dict[RcKeyType, Any] | None = None):
    """The context in which every gyroid figure is drawn (:data:`STYLE`, with
    ``overrides``)."""
    return matplotlib.rc_context(STYLE | (overrides or {}))


def save(fig: Figure, path: Path, *, pdf: bool = False) -> list[Path]:
    """Save a figure as PNG (at the figure's 110 dpi) and, with ``pdf``, as PDF; returns the
    written paths."""
    path = Path(path)
    written = [path.with_suffix(".png")]
    fig.savefig(written[0], bbox_inches="tight")
    if pdf:
        written.append(path.with_suffix(".pdf"))
        fig.savefig(written[1], bbox_inches="tight")
    return written


def _break_gaps(hours: np.ndarray, *series: np.ndarray) -> tuple[np.ndarray, ...]:
    """Insert NaN rows where the log pauses (:func:`gyroid.io.gap_threshold`), so that lines
    are not drawn across a gap (e.g. the magnetic bench's azimuth turn)."""
    hours = np.asarray(hours, dtype=float)
    if hours.size < 2:
        return (hours, *series)
    cut = np.flatnonzero(np.diff(hours) > gap_threshold(hours * 3600.0) / 3600.0) + 1
    return tuple(np.insert(np.asarray(x, dtype=float), cut, np.nan) for x in (hours, *series))


#: Most points a line in a figure draws; longer logs are drawn every k-th sample.
MAX_PLOTTED_POINTS = 5000


def plot_step(n: int) -> int:
    """Draw every k-th of ``n`` samples, so that at most ``MAX_PLOTTED_POINTS`` are drawn."""
    return max(1, -(-n // MAX_PLOTTED_POINTS))


def _every(n: int, thinned_by: int = 1) -> tuple[slice, str]:
    """The samples to draw of ``n`` (themselves every ``thinned_by``-th of the log's) and a
    label suffix saying so when thinned."""
    step = plot_step(n)
    total = step * thinned_by
    return slice(None, None, step), ("" if total == 1 else f", every {ordinal(total)} sample drawn")


def ordinal(k: int) -> str:
    """2 -> '2nd', 3 -> '3rd', 11 -> '11th', 21 -> '21st'."""
    suffix = "th" if 10 <= k % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return f"{k}{suffix}"


def moving_mean(values: np.ndarray, window: int) -> np.ndarray:
    """Centred moving mean over ``window`` samples (shorter at the ends), by cumulative sums:
    O(n) whatever the window."""
    values = np.asarray(values, dtype=float)
    n = values.size
    half = window // 2
    total = np.concatenate([[0.0], np.cumsum(values)])
    lo = np.clip(np.arange(n) - half, 0, n)
    hi = np.clip(np.arange(n) - half + window, 0, n)
    return (total[hi] - total[lo]) / (hi - lo)


def _rate_label(time_s: np.ndarray, thinned_by: int = 1) -> str:
    """The log's sample rate (of ``time_s``, every ``thinned_by``-th sample of the log)."""
    step = float(np.median(np.diff(time_s))) / thinned_by if time_s.size > 1 else 1.0
    return f"{1.0 / step:.3g} Hz" if step <= 1.0 else f"{step:.3g} s samples"
