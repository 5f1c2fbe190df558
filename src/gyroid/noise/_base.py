"""The abstract noise model of a drift log (:class:`NoiseModel`) and a fitted one
(:class:`NoiseEstimate`).

A noise model is what a drift model's residual is, apart from the drift: white noise, or
white noise plus correlated processes. Each kind owns its levels' names, units and priors,
its likelihood (the innovations of a filter, or independent rows), and the covariance of
the means of parts of a log, which the predictive check of a fit and of a compensation
compare with the data. The likelihood and the parts' covariance come from one model, so
the check tests what the fit assumed.

To add a kind: a final subclass with the class variables and the abstract methods below,
and its name in :data:`gyroid.noise._kinds.NOISE_MODELS` if the command line is to offer
it; the densities, fits, checks, compensation and reports read it through this interface.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.models._priors import Prior


@dataclass(frozen=True)
class RowClock:
    """Where a log's rows sit in time, as a filter reads them: ``steps_s`` the time since
    the previous row (the first: the median step), ``step_s`` that median, ``gap_s`` for
    rows that are means over one step (block means) the pause before each (else None),
    ``weight`` 1 for a row learnt from and 0 for one predicted through (None: all)."""

    steps_s: Float[Array, " n"]
    step_s: float
    gap_s: Float[Array, " n"] | None = None
    weight: Float[Array, " n"] | None = None


class NoiseModel(eqx.Module):
    """A drift log's noise model. Levels are by name in natural units (``values``); the
    white level comes first in :attr:`level_names` and is not sampled when the log gives
    each row's sd (``sigma_deg_h``)."""

    #: The name in ``--noise`` and in fit.json.
    name: eqx.AbstractClassVar[str]
    #: The sampled levels (natural units; sampled as logs), the white level first.
    level_names: eqx.AbstractClassVar[tuple[str, ...]]
    units: eqx.AbstractClassVar[dict[str, str]]
    #: Whether the rows are correlated (a filter gives the likelihood).
    correlated: eqx.AbstractClassVar[bool]
    #: Whether a long log is fitted as block means (the likelihood exact on means).
    on_block_means: eqx.AbstractClassVar[bool]
    #: What a failed predictive check advises (codes of :mod:`gyroid.inference`'s checks).
    remedies: eqx.AbstractClassVar[tuple[str, ...]]

    def names(self, sigma_known: bool) -> tuple[str, ...]:
        """The sampled levels' names: without the white level when the log gives it."""
        return self.level_names[1:] if sigma_known else self.level_names

    def rows_as_means(self, rows_per_mean: int) -> bool:
        """Whether the likelihood reads each row as the mean over its step (block means,
        ``rows_per_mean`` samples each) rather than as a sample."""
        del rows_per_mean
        return False

    def for_log(self, step_s: float, duration_s: float) -> NoiseModel:
        """This model set up for a log of rows ``step_s`` apart lasting ``duration_s``."""
        del step_s, duration_s
        return self

    def with_rate_error(self, process) -> NoiseModel:
        """This model carrying the thermometer's noise through the dT/dt estimator as one
        more process of its filter (:class:`~gyroid.noise._rate_error_process.
        RateErrorProcess`, set up on the log's rows read as block means)."""
        raise ValueError(f"the {self.name} noise model carries the thermometer's noise in "
                         "its own way (errors in variables: a covariance over the rows)")

    @abc.abstractmethod
    def default_priors(self, level_deg_h: float, step_s: float, rows_per_mean: int
                       ) -> dict[str, Prior]:
        """Priors scaled to a log whose samples' high-frequency noise is ``level_deg_h``
        (a sample's sd, deg/h), samples ``step_s / rows_per_mean`` seconds apart."""

    @abc.abstractmethod
    def fog_priors(self) -> dict[str, Prior]:
        """Paper A's navigation-grade FOG priors (``--priors paper_a_fog``)."""

    @abc.abstractmethod
    def row_white_sd(self, values: Mapping, *, step_s: float, row_scale: float):
        """The white sd of a row (deg/h; traceable) when the log does not give it: rows
        ``step_s`` apart, each the mean of ``1 / row_scale**2`` samples."""

    def known_white(self, sigma: Float[Array, " n"]):
        """The white sd the likelihood uses when the log gives each row's (``sigma``)."""
        return sigma

    @abc.abstractmethod
    def start_levels(self, residual: np.ndarray, white: float, *, step_s: float,
                     row_scale: float, dof: int) -> tuple[dict[str, float], dict[str, float]]:
        """Where a mode-finder starts: each level (natural units) guessed from the
        residual of a white fit (``white``: its rows' sd, deg/h; ``dof`` its degrees of
        freedom), and a rough variance of its log."""

    @abc.abstractmethod
    def sample_white_sd(self, values: Mapping, sample_s: float) -> float:
        """A sample's white sd (deg/h) at a sample interval of ``sample_s``."""

    @abc.abstractmethod
    def innovations(self, observed, white, values: Mapping, clock: RowClock):
        """The innovations of ``observed`` (rows; trailing columns filtered alike) and
        their variances under this model, white sd ``white``; None for independent rows."""

    @abc.abstractmethod
    def part_covariance(self, time_s: np.ndarray, part: np.ndarray, n_parts: int,
                        step_s: float, white_var: np.ndarray, values: Mapping, *,
                        block_means: bool = False, after_s: float | None = None
                        ) -> np.ndarray:
        """The covariance ((deg/h)^2) of the means of parts of a log's rows (``part``: each
        row's part, -1 for none; parts contiguous and in time order; rows ``step_s``
        apart): ``white_var`` each part's white variance, plus the correlated processes as
        the likelihood reads them (``block_means``: the rows are block means). With
        ``after_s``, the parts are of a new log that follows the fitted one (of that span,
        s): a level the model lets wander without bound (a random walk) has moved since
        the fitted log's mean."""


class RowFilter(eqx.Module):
    """A noise model set on a log's rows: from its levels' sampling coordinates (logs) to
    each row's white sd and the levels by name, and the innovations of what it filters.
    It holds no drift model, so fits of different models to the same rows (a discrepancy
    search's candidates) share its compiled programs."""

    noise: NoiseModel
    steps_s: Float[Array, " n"]
    sigma: Float[Array, " n"] | None = None  # the log's own sd of each row, deg/h
    gap_s: Float[Array, " n"] | None = None
    weight: Float[Array, " n"] | None = None
    step_s: float = eqx.field(static=True, default=1.0)
    #: A row's white sd per sample's (1/sqrt(m) for the mean of m samples).
    row_scale: float = eqx.field(static=True, default=1.0)

    @property
    def names(self) -> tuple[str, ...]:
        """The sampled levels' names."""
        return self.noise.names(self.sigma is not None)

    @property
    def clock(self) -> RowClock:
        return RowClock(self.steps_s, self.step_s, self.gap_s, self.weight)

    def levels_of(self, noise_u: Float[Array, " k"]):
        """The white sd a row's likelihood uses (deg/h; per row or one) and every level by
        name (natural units), from the levels' sampling coordinates ``noise_u``."""
        values = dict(zip(self.names, jnp.exp(noise_u), strict=True))
        if self.sigma is not None:
            return self.noise.known_white(self.sigma), values
        return self.noise.row_white_sd(values, step_s=self.step_s,
                                       row_scale=self.row_scale), values

    def innovations(self, observed, white, values: Mapping):
        """:meth:`NoiseModel.innovations` on these rows (None for independent rows)."""
        return self.noise.innovations(observed, white, values, self.clock)


def parts_mean_covariance(row_covariance: np.ndarray, part: np.ndarray, n_parts: int
                          ) -> np.ndarray:
    """The covariance of parts' means given the rows' covariance ``row_covariance``
    (``part``: each row's part, -1 for none): ``A C A'``, ``A`` averaging each part's
    rows."""
    rows = np.asarray(part)
    kept = rows >= 0
    counts = np.bincount(rows[kept], minlength=n_parts).astype(float)
    average = np.zeros((n_parts, rows.size))
    average[rows[kept], np.flatnonzero(kept)] = 1.0 / counts[rows[kept]]
    return average @ np.asarray(row_covariance) @ average.T


def predictive_level(summary: Mapping) -> float:
    """A noise level for predicting new data from its posterior ``summary`` (``mean`` and,
    from a posterior, ``sd``): the root mean square ``sqrt(mean^2 + sd^2)``. Every noise
    covariance is linear in the squares of its levels, so the predictive variance averaged
    over the posterior is the covariance at these; at the posterior mean instead, a level the
    log barely resolves (a walk's K known to within its own size) would be taken as known,
    and a new run's bands drawn too narrow (a FOG's second run held 58-85 % of its
    10-minute means in them)."""
    mean = float(summary["mean"])
    sd = float(summary.get("sd") or 0.0)
    return math.sqrt(mean**2 + sd**2)


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
