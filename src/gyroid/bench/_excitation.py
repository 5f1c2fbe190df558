"""Excitation, not range: does the log move a coefficient's regressor in a way that a bias
step could not imitate?

A regressor that changes in one step (or two or three), most often while the log is paused
(the Astro Pi unit turned by 90 deg during an 11.9 h gap, so its field components jumped
once), spans a range but identifies nothing: a bias step at that moment (handling, a
restart, a turn) fits the drift as well, and the coefficient then carries whatever the
bias did. For each linear coefficient other than the bias, its regressor is regressed on a
constant and steps at the ``MAX_STEPS`` largest of its abrupt changes (from one sample to the
next, across a gap or not, by at least ``JUMP_FRACTION`` of its range); when those steps
explain all but ``LEFT_FRACTION`` of its variation, the log does not identify the
coefficient (an error). A staircase of many levels (paper A's coils, a burst log's cooling)
is excitation: its steps are small, and three explain only part of it; so is a slow ramp
sampled in bursts.

The overload coefficients are exempt, as the field-change signs are: a tumble test changes the
specific force in steps by design, and what its orientations leave undetermined is judged
from the orientations themselves (:mod:`gyroid.models._orientations`, in the
identifiability check). A tumble's answer assumes the bias does not step when the unit is
turned; more orientations than coefficients (six for four) leave the residuals a test of it.
"""

from __future__ import annotations

import numpy as np

from gyroid.inference._check_report import Check
from gyroid.models._drift import DriftModel
from gyroid.models._inputs import ACCEL_COLUMNS

#: Steps tried, the jump (a fraction of the regressor's range) that counts as abrupt, and the
#: share of the regressor's variation that must be left beyond the steps.
MAX_STEPS = 3
JUMP_FRACTION = 0.2
LEFT_FRACTION = 0.1
#: Rows the test reads at most (longer logs every k-th row: steps survive thinning).
MAX_ROWS = 1_000_000


def excitation(model: DriftModel, inputs, time_s: np.ndarray,
               segments: tuple[tuple[int, int], ...]) -> Check:
    """The excitation check of a linear model's coefficients (see the module docstring)."""
    linear = [e for e in model.effects if e.linear]
    names = [p.name for e in linear for p in e.parameters]
    regressor = {p.name: p.regressor for e in linear for p in e.parameters}
    if not linear or names == ["w0"]:
        return Check("excitation", True, "error", None, LEFT_FRACTION,
                     "no coefficient but the bias")
    every = max(1, -(-len(time_s) // MAX_ROWS))
    design = np.concatenate([np.asarray(x) for _, x in model.design_blocks(
        inputs, linear)])[::every]
    time_h = (np.asarray(time_s, dtype=float)[::every] - float(time_s[0])) / 3600.0
    gaps = np.array([a for a, _ in segments[1:]], dtype=int) // every
    poor, least = [], 1.0
    for j, name in enumerate(names):
        x = design[:, j]
        if (name == "w0" or regressor[name] in ACCEL_COLUMNS
                or np.unique(x[: min(x.size, 100_000)]).size <= 3):
            continue  # the bias, and regressors that are step functions by design (signs,
            # orientations)
        left, steps = _left_after_steps(x, gaps)
        least = min(least, left)
        if left < LEFT_FRACTION:
            across = [f"{time_h[k]:.3g} h" + (" (across a gap)" if k in gaps else "")
                      for k in steps]
            poor.append(f"{name} ({regressor[name] or 'its regressor'} changes in "
                        f"{len(steps)} step(s), at {', '.join(across)}: "
                        f"{100 * (1 - left):.0f} % of its variation)")
    if not poor:
        return Check("excitation", True, "error", least, LEFT_FRACTION,
                     "every coefficient's regressor varies beyond a few steps")
    return Check("excitation", False, "error", least, LEFT_FRACTION,
                 f"this log does not identify {'; '.join(poor)}: a bias step at those times "
                 "(handling, a turn, a restart) would fit the drift as well; use a log in which "
                 "the regressor varies back and forth, or drop the term")


def _left_after_steps(x: np.ndarray, gaps: np.ndarray) -> tuple[float, list[int]]:
    """The share of ``x``'s variance left after a constant and steps at its largest changes
    across gaps and abrupt jumps, and where those steps are (row of each step's start)."""
    change = np.abs(np.diff(x))
    candidates = np.flatnonzero(change >= JUMP_FRACTION * np.ptp(x)) + 1  # gaps included
    if candidates.size == 0:
        return 1.0, []
    steps = sorted(candidates[np.argsort(-change[candidates - 1])][:MAX_STEPS].tolist())
    columns = [np.ones(x.size)] + [(np.arange(x.size) >= k).astype(float) for k in steps]
    basis = np.column_stack(columns)
    fitted = basis @ np.linalg.lstsq(basis, x, rcond=None)[0]
    variance = float(np.var(x))
    return (float(np.var(x - fitted)) / variance if variance > 0 else 1.0), steps
