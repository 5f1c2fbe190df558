"""Where every mode-finder starts: a grid over a drift model's positive parameters.

A time constant (a warm-up's, a thermal lag's) or a step's time enters the drift
nonlinearly, and its profile likelihood often has several maxima (a short time constant
that fits the first minutes, a long one that fits the trend). Each mode-finder therefore
evaluates the profile (the real parameters solved exactly for fixed positive ones) on one
grid, and refines the best points locally:

* a positive parameter's candidates are its own values from the log where it has them
  (``Parameter.start_values``: a bias step's time at the largest jumps of the 60 s means),
  else ``START_MULTIPLES`` of its registry median (the physical scale, whatever prior the
  fit uses): 0.05 to 15 times, seven values, geometric;
* the grid is the product over positive parameters (7^k points; the catalogue has at most
  two positive parameters per model);
* real parameters start at zero (the profile solves them exactly).

:func:`gyroid.bench._point.point_estimate` starts here (the profile of
:mod:`gyroid.bench._point_profiled`, the discrepancy search's candidates included), as
does the dT/dt window's least squares of a model with positive parameters
(:mod:`gyroid.bench._rate_window`); :func:`best_least_squares` compares the points.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Iterator

import numpy as np

from gyroid.models._effects import Parameter
from gyroid.models._inputs import DriftInputs
from gyroid.models._priors import LogNormal

#: Multiples of a time constant's registry median tried as starting values.
START_MULTIPLES = (0.05, 0.15, 0.4, 1.0, 2.5, 6.0, 15.0)


def log_candidates(parameter: Parameter, inputs: DriftInputs) -> np.ndarray:
    """A positive parameter's starting values, as logs."""
    if parameter.start_values is not None:
        return np.log(np.asarray(parameter.start_values(inputs), dtype=float))
    prior = parameter.prior
    if not isinstance(prior, LogNormal):  # a positive parameter is sampled as its log
        raise TypeError(f"{parameter.name}: a positive parameter needs a log-normal prior")
    return math.log(prior.median) + np.log(START_MULTIPLES)


def start_grid(parameters: tuple[Parameter, ...], inputs: DriftInputs) -> list[np.ndarray]:
    """Per positive parameter (in model order) its log candidates."""
    return [log_candidates(p, inputs) for p in parameters if p.positive]


def grid_points(grid: list[np.ndarray]) -> Iterator[np.ndarray]:
    """Every point of a :func:`start_grid` as a vector of the positive parameters' logs
    (one empty vector for a model without positive parameters)."""
    for combo in itertools.product(*grid):
        yield np.asarray(combo, dtype=float)


def best_least_squares(stacks: Iterable[np.ndarray]
                       ) -> tuple[int, float, np.ndarray | None, np.ndarray | None]:
    """Of candidates given as column stacks ``[target, design...]`` (n x (1 + r) each: a
    grid point's model columns), the one whose least squares fits best: its index, residual
    sum of squares, coefficients and residual (-1, inf, None, None where no stack is
    finite)."""
    best: tuple[int, float, np.ndarray | None, np.ndarray | None] = (-1, math.inf, None, None)
    for index, stack in enumerate(stacks):
        if not np.all(np.isfinite(stack)):
            continue
        target, design = stack[:, 0], stack[:, 1:]
        coefficients, *_ = np.linalg.lstsq(design, target, rcond=None)
        residual = target - design @ coefficients
        rss = float(residual @ residual)
        if rss < best[1]:
            best = (index, rss, coefficients, residual)
    return best
