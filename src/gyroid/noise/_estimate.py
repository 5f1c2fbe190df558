"""A fitted noise model (:class:`NoiseEstimate`): what a compensation's predictive check, a
pool's new-run prediction and an export read of a fit's noise."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from gyroid.noise._model import NoiseModel


@dataclass(frozen=True)
class NoiseEstimate:
    """A noise model with its fitted levels (natural units; each the root mean square over
    the posterior, :func:`predictive_level`): what a compensation's predictive check and
    an export read of a fit.

    ``white_sd_deg_h`` is a sample's white sd at the sample interval ``white_sample_s`` (s;
    None when unknown, e.g. a fit of segment means); ``span_s`` the fitted log's duration
    (s; None when unknown, an old fit record); ``centred``: a new log's bias is the
    model's own for that log (a pool's predictive for a new run, whose bias is a run's mean
    over its log), so a walk wanders about the new log's mean, as in the likelihood, rather
    than on from the fitted log's."""

    model: NoiseModel
    levels: Mapping[str, float]
    white_sd_deg_h: float
    white_sample_s: float | None = None
    span_s: float | None = None
    centred: bool = False

    def __post_init__(self) -> None:
        # the gyro's noise: a fit's carried rate error is its own log's thermometer
        object.__setattr__(self, "model", self.model.without_rate_error())

    def white_sd_at(self, step_s: float) -> float:
        """A sample's white sd (deg/h) at sample interval ``step_s``: a rate averaged over
        its sample, whose variance scales as one over the interval."""
        sample_s = self.white_sample_s if self.white_sample_s is not None else step_s
        return self.white_sd_deg_h * math.sqrt(sample_s / step_s)

    def part_covariance(self, time_s: np.ndarray, part: np.ndarray, n_parts: int,
                        step_s: float, white_var: np.ndarray) -> np.ndarray:
        """The covariance of parts' means of a new log's rows (:meth:`NoiseModel.
        part_covariance`, rows as samples, the log after the fitted one; ``centred``: the
        walk about this log's own mean)."""
        return self.model.part_covariance(time_s, part, n_parts, step_s, white_var,
                                          self.levels,
                                          after_s=None if self.centred else self.span_s or 0.0)

    @classmethod
    def of_runs(cls, runs: Sequence[NoiseEstimate]) -> NoiseEstimate:
        """A new run's noise from the estimates of several runs of one gyro type (one
        noise model): each level and the white sd (at the first run's sample interval) the
        root mean square over the runs, as :func:`predictive_level` averages a variance over
        a posterior. Centred: a new run's bias is its own log's mean, drawn from the runs'
        between-run spread (a pool's), and its walk wanders about it, not on from the last
        fitted log."""
        first = runs[0]
        if any(r.model.name != first.model.name or set(r.levels) != set(first.levels)
               for r in runs):
            raise ValueError("the runs' noise estimates are of different models")
        step = first.white_sample_s

        def rms(values: list[float]) -> float:
            return math.sqrt(sum(v * v for v in values) / len(values))

        white = rms([r.white_sd_at(step) if step is not None else r.white_sd_deg_h
                     for r in runs])
        return cls(first.model, {n: rms([r.levels[n] for r in runs]) for n in first.levels},
                   white, step, centred=True)

    def to_json(self) -> dict:
        out = {"model": self.model.name, "white_sd_deg_h": self.white_sd_deg_h,
               **self.levels}
        if self.white_sample_s is not None:
            out["white_sample_s"] = self.white_sample_s
        if self.span_s is not None:
            out["span_s"] = self.span_s
        return out
