"""Whether a compensated log is the fitted run's own power-on or another's.

A gyro's bias changes at every power-on (turn-on to turn-on repeatability: a datasheet's
"initial bias error", a pool's between-run sd). A fit of one run states its own bias,
however long the run; what another run's bias will be it cannot know. So compensating
another run with a single run's fit needs the turn-on spread from outside (a datasheet,
an earlier lot: ``sd_deg_h``, the spread of each power-on's bias about the unit's mean;
the fitted run's bias is one such draw, so another run's differs from it by ``sqrt(2)``
times the spread, which is added to the bias's draws), or a pool of several runs,
whose predictive for a new run carries the spread it measured; without either, its bands
for the new run are bands for the fitted run, and the compensation is refused. Or the
new log sets its own bias, as a firmware's start-up calibration does (``rezero_s``: its
first seconds at rest, :class:`StartUp`): the model then predicts the drift's change from
that mean, and the bands its uncertainty and the noise of both means.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.inference._checks import Check
from gyroid.io._fitted import FittedDrift

#: The coefficient a turn-on spread adds to: the bias.
BIAS = "w0"


@dataclass(frozen=True)
class TurnOn:
    """What a compensated log is to the fitted one: the same power-on (``another_run``
    False: the run continued, or a part of it held out), or another; for another, the
    spread of the bias from one power-on to the next (``sd_deg_h``, 1 sigma, deg/h) when
    known from outside the fit."""

    another_run: bool = False
    sd_deg_h: float | None = None
    #: The log's first seconds at rest, whose mean sets its bias (a start-up calibration).
    rezero_s: float | None = None

    def __post_init__(self) -> None:
        if self.sd_deg_h is not None and not (np.isfinite(self.sd_deg_h)
                                               and self.sd_deg_h >= 0):
            raise GyroidInputError(f"the turn-on bias sd must be a finite number >= 0 deg/h, "
                                   f"not {self.sd_deg_h!r}")
        if self.rezero_s is not None and not (np.isfinite(self.rezero_s)
                                               and self.rezero_s > 0):
            raise GyroidInputError(f"the start-up calibration's length must be a positive "
                                   f"number of seconds, not {self.rezero_s!r}")
        if self.rezero_s is not None and self.sd_deg_h is not None:
            raise GyroidInputError("a start-up calibration sets the new run's bias, so a "
                                   "turn-on spread has nothing to add to: give one of them")

    def to_json(self) -> dict:
        return {"another_run": self.another_run or self.sd_deg_h is not None,
                "sd_deg_h": self.sd_deg_h, "rezero_s": self.rezero_s}


@dataclass(frozen=True)
class StartUp:
    """A log's start-up calibration: its rows in the first ``seconds`` (``rows``, a mask),
    at rest, whose measured mean (``mean_deg_h``) sets the run's bias."""

    rows: np.ndarray
    mean_deg_h: float
    seconds: float

    @classmethod
    def of(cls, time_s: np.ndarray, drift_deg_h: np.ndarray, seconds: float) -> StartUp:
        rows = time_s < time_s[0] + seconds
        if rows.sum() < 2 or rows.all():
            raise GyroidInputError(
                f"the start-up calibration of {seconds:g} s holds {int(rows.sum())} of the "
                f"log's {rows.size} rows: give a length that holds at least two rows and "
                "leaves some after it")
        return cls(rows, float(np.mean(drift_deg_h[rows])), float(seconds))

    def relabelled(self, part: np.ndarray) -> np.ndarray:
        """Parts for the noise covariance of parts' means less the start-up mean: the
        start-up rows part 0 (the earliest), every other part one up (one part more)."""
        out = np.where(part >= 0, part + 1, -1)
        out[self.rows] = 0
        return out

    @staticmethod
    def contrasted(covariance: np.ndarray) -> np.ndarray:
        """The covariance of each part's mean less the start-up part's (part 0 of
        :meth:`relabelled`'s) from that of the means themselves."""
        c = np.atleast_2d(covariance)
        return c[1:, 1:] - c[1:, :1] - c[:1, 1:] + c[0, 0]


#: The default: the compensated log is the fitted run's own power-on.
SAME_RUN = TurnOn()


def is_new_run_predictive(fitted: FittedDrift) -> bool:
    """Whether ``fitted`` is a pool's predictive for a new run (its draws hold the runs'
    spread) rather than one run's posterior."""
    return fitted.source.startswith("pool")


def with_turn_on(fitted: FittedDrift, turn_on: TurnOn, draws: np.ndarray,
                 rng: np.random.Generator) -> np.ndarray:
    """``draws`` (m, p) of ``fitted``'s coefficients with another run's offset from the
    fitted run added to the bias: normal, sd ``sqrt(2)`` times the turn-on spread (both
    runs' biases are draws about the unit's mean), antithetic (their mean is zero, the
    model's mean unchanged); the draws themselves when no spread is given."""
    if turn_on.sd_deg_h is None:
        return draws
    if is_new_run_predictive(fitted):
        raise GyroidInputError(
            "the fit is a pool's predictive for a new run, which already carries the runs' "
            "spread of the bias: leave out the turn-on bias sd")
    names = fitted.model.parameter_names
    if BIAS not in names:
        raise GyroidInputError(
            f"a turn-on bias sd adds to the bias {BIAS}, and the fit has none (terms: "
            f"{', '.join(fitted.model.terms)}): refit with the bias among --terms")
    m = draws.shape[0]
    half = rng.standard_normal(m // 2)
    shifts = np.concatenate([half, -half, np.zeros(m % 2)])
    out = np.array(draws, dtype=float, copy=True)
    out[:, names.index(BIAS)] += math.sqrt(2.0) * turn_on.sd_deg_h * shifts
    return out


def turn_on_check(fitted: FittedDrift, turn_on: TurnOn) -> Check:
    """An error when the log is another run's, the fit one run's, and no turn-on spread is
    given: the bands would be the fitted run's."""
    name = "turn_on_bias"
    if turn_on.rezero_s is not None:
        return Check(name, True, "error", None, None,
                     f"the log's first {turn_on.rezero_s:g} s set its bias (a start-up "
                     "calibration, at rest): the model predicts the drift's change from their "
                     "mean, so the run's turn-on bias does not enter")
    if is_new_run_predictive(fitted):
        return Check(name, True, "error", None, None,
                     "the fit is a pool's predictive for a new run: its draws carry the runs' "
                     "spread of the bias from one power-on to the next")
    if not (turn_on.another_run or turn_on.sd_deg_h is not None):
        return Check(name, True, "error", None, None,
                     "this log is taken to be the fitted run's own power-on (the run "
                     "continued, or a part held out); for another run's, say so "
                     "(--another-run) and say how its bias is known (a pool, --turn-on-sd "
                     "or --rezero)")
    if turn_on.sd_deg_h is not None:
        return Check(name, True, "error", turn_on.sd_deg_h, None,
                     f"another run: a turn-on spread of the bias of {turn_on.sd_deg_h:.3g} "
                     "deg/h (1 sigma about the unit's mean, given; sqrt(2) times that "
                     "between two runs) is in the model's draws and every band")
    return Check(name, False, "error", None, None,
                 "this log is another run's and the fit is of one run, whose bias it states "
                 "for that power-on only: another power-on's bias differs by the gyro's "
                 "turn-on repeatability, which one run cannot measure, so the bands are the "
                 "fitted run's; fit several runs together (gyroid pool) and compensate "
                 "with the pool, give the spread (--turn-on-sd, e.g. a datasheet's "
                 "initial bias error), or let the log's first seconds at rest set its bias "
                 "(--rezero SECONDS, a start-up calibration)")
