"""The terms a gyro's rate noise is made of, for a drift log's likelihood and for a static
log's Allan variance (``gyroid noise``): one vocabulary.

A term of a drift log's noise (:class:`AbstractNoiseTerm`) owns its levels' names, units and
priors, where a mode-finder starts them, and its states in the one block filter
(:mod:`gyroid.noise._block_filter`): stationary Gauss-Markov processes (``processes``), a
random walk's diffusion (``diffusion``), or the rate error's process and one-sided
rows (beside white noise alone, the rows' exact covariance instead). A noise model
(:class:`~gyroid.noise._model.NoiseModel`) is a tuple of them, its white term first.

N, B, K and G are also terms of a static log's Allan variance
(:mod:`gyroid.noise._allan_terms`, whose table gives every term's shape): the static fit's
amplitude is the drift likelihood's level (G's its stationary sd, its correlation time
chosen per static log). A new term is one final subclass, here or in a user's own file
(``tests/test_noise_models.py`` defines one).
"""

from __future__ import annotations

import abc
import math
from collections.abc import Mapping
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.models._priors import LogNormal, Prior
from gyroid.noise._allan_terms import (
    AbstractAllanTerm,
    Prefilter,
    Quantisation,
    RateRamp,
    finite_reach,
    flicker_haar_covariance,
    gauss_markov_avar,
    gauss_markov_haar_covariance,
    second_differenced,
)
from gyroid.noise._block_filter import Processes, flicker_times
from gyroid.noise._rate_error_eigenbasis import RowEigenbasis
from gyroid.noise._rate_error_process import RateErrorProcess
from gyroid.noise._rate_error_rows import OneSidedRows


def high_frequency_sd(residual: np.ndarray) -> float:
    """A residual's white level from its first differences (slow parts cancel), deg/h."""
    return float(np.std(np.diff(residual)) / math.sqrt(2.0)) if residual.size > 2 else 0.0


class AbstractNoiseTerm(eqx.Module):
    """One term of a drift log's noise: its levels (natural units, sampled as logs), their
    priors and starts, and its states in the block filter."""

    #: The term's letter (IEEE 952's and ``gyroid noise``'s: N, B, K; G for a bias).
    code: eqx.AbstractClassVar[str]
    level_names: eqx.AbstractClassVar[tuple[str, ...]]
    units: eqx.AbstractClassVar[dict[str, str]]
    #: Whether the filter reads every row as the mean over its step (a term whose value at
    #: a sample instant is not what a sample averages: flicker, a walk), not only rows
    #: that are means of several samples.
    over_spans: eqx.AbstractClassVar[bool]
    #: Whether it carries a level's wander at hour scales (flicker, a walk): a log of
    #: bursts is read as it is, the wander between bursts being the term's.
    wanders: eqx.AbstractClassVar[bool]

    @abc.abstractmethod
    def default_priors(self, level_deg_h: float, step_s: float, rows_per_mean: int
                       ) -> dict[str, Prior]:
        """Priors scaled to a log whose rows' high-frequency noise is ``level_deg_h`` (a
        row's sd, deg/h), rows ``step_s`` apart, each the mean of ``rows_per_mean``
        samples."""

    @abc.abstractmethod
    def fog_priors(self) -> dict[str, Prior]:
        """Paper A's navigation-grade FOG priors (``--priors paper_a_fog``)."""

    @abc.abstractmethod
    def start(self, residual: np.ndarray, white: float, *, step_s: float, row_scale: float,
              dof: int, alone: bool) -> tuple[dict[str, float], dict[str, float]]:
        """Where a mode-finder starts each level (natural units), guessed from the residual
        of a white fit (``white``: its rows' sd, deg/h; ``dof`` its degrees of freedom;
        ``alone``: the white term is the model's only one), and a rough variance of its
        log."""

    def for_log(self, step_s: float, duration_s: float) -> AbstractNoiseTerm:
        """This term set up for a log of rows ``step_s`` apart lasting ``duration_s``."""
        del step_s, duration_s
        return self

    def processes(self, values: Mapping) -> Processes | None:
        """The stationary Gauss-Markov processes this term adds to the filter at levels
        ``values`` (:data:`~gyroid.noise._block_filter.Processes`); None for none.
        Traceable."""
        del values
        return None

    def part_processes(self, values: Mapping, *, step_s: float, span_s: float
                       ) -> Processes | None:
        """The same for the means of parts of a log of rows ``step_s`` apart spanning
        ``span_s`` (s): the processes as the likelihood reads them on that log."""
        del step_s, span_s
        group = self.processes(values)
        return None if group is None else (np.asarray(group[0], dtype=float),
                                           float(group[1]), group[2])

    def diffusion(self, values: Mapping) -> Array | float | None:
        """A random walk's diffusion ((deg/h)^2 per s) at levels ``values``, or None."""
        del values
        return None

    @property
    def static_fit(self) -> dict[str, str]:
        """Its level that a static noise fit (``gyroid noise``) and a datasheet state in the
        same units, by the static fit's letter: the one level of a term that is also a
        term of a static log's Allan variance (N, B, K); none otherwise (a sample's sd, G's
        two levels, the rate error)."""
        if isinstance(self, AbstractAllanTerm) and len(self.level_names) == 1:
            return {self.level_names[0]: self.code}
        return {}


class AbstractWhiteTerm(AbstractNoiseTerm):
    """The white noise every model has, first among its terms. A log that gives each row's
    sd (``sigma_deg_h``) does not sample it."""

    over_spans: ClassVar[bool] = False
    wanders: ClassVar[bool] = False

    @abc.abstractmethod
    def row_white_sd(self, values: Mapping, *, step_s: float | Array,
                     row_scale: float | Array) -> Array:
        """The white sd of a row (deg/h; traceable): rows ``step_s`` apart, each the mean
        of ``1 / row_scale**2`` samples."""

    @abc.abstractmethod
    def sample_white_sd(self, values: Mapping, sample_s: float) -> float:
        """A sample's white sd (deg/h) at a sample interval of ``sample_s``."""


class SampleWhite(AbstractWhiteTerm):
    """White noise as a sample's sd, ``sigma_deg_h`` (also when the rows are means)."""

    code: ClassVar[str] = "N"
    level_names: ClassVar[tuple[str, ...]] = ("sigma_deg_h",)
    units: ClassVar[dict[str, str]] = {"sigma_deg_h": "deg/h"}

    def default_priors(self, level_deg_h, step_s, rows_per_mean):
        return {"sigma_deg_h": LogNormal(level_deg_h * math.sqrt(rows_per_mean), 3.0)}

    def fog_priors(self):
        return {"sigma_deg_h": LogNormal(1.0, 3.0)}

    def start(self, residual, white, *, step_s, row_scale, dof, alone):
        level = white if alone else high_frequency_sd(residual)
        return {"sigma_deg_h": level / row_scale}, {"sigma_deg_h": 1.0 / (2.0 * dof)}

    def row_white_sd(self, values, *, step_s, row_scale):
        return values["sigma_deg_h"] * row_scale

    def sample_white_sd(self, values, sample_s):
        return float(values["sigma_deg_h"])


class AngleRandomWalk(AbstractWhiteTerm, AbstractAllanTerm):
    """IEEE 952's white rate noise as its angle random walk ``N_deg_sqrt_h`` (a density,
    independent of the sample rate): a row's mean over a step ``L`` has sd ``60 N /
    sqrt(L)``."""

    code: ClassVar[str] = "N"
    level_names: ClassVar[tuple[str, ...]] = ("N_deg_sqrt_h",)
    description: ClassVar[str] = "angle random walk"
    unit: ClassVar[str] = "deg/sqrt(h)"
    unresolved_hint: ClassVar[str] = "another process dominates the shortest averaging times"

    def allan_variance(self, tau_s, tau0_s, tc_s):
        return 3600.0 / tau_s

    def haar_covariance(self, lag_s, tau_s, tc_s):
        return finite_reach(second_differenced(lambda u: -1800.0 * u, lag_s, tau_s),
                            lag_s, tau_s)
    units: ClassVar[dict[str, str]] = {"N_deg_sqrt_h": "deg/sqrt(h)"}

    def default_priors(self, level_deg_h, step_s, rows_per_mean):
        """About the log's white density (deg/h sqrt(s), over 60)."""
        density = level_deg_h * math.sqrt(max(step_s, 1e-9))
        return {"N_deg_sqrt_h": LogNormal(density / 60.0, 3.0)}

    def fog_priors(self):
        return {"N_deg_sqrt_h": LogNormal(0.01, 3.0)}

    def start(self, residual, white, *, step_s, row_scale, dof, alone):
        level = white if alone else high_frequency_sd(residual)
        return ({"N_deg_sqrt_h": level * math.sqrt(step_s) / 60.0},
                {"N_deg_sqrt_h": 1.0 / (2.0 * dof)})

    def row_white_sd(self, values, *, step_s, row_scale):
        return 60.0 * values["N_deg_sqrt_h"] / jnp.sqrt(step_s)

    def sample_white_sd(self, values, sample_s):
        return float(60.0 * values["N_deg_sqrt_h"] / math.sqrt(sample_s))


def _ieee_default(level_deg_h: float, step_s: float) -> LogNormal:
    """B's and K's default prior: a median a thousandth of the log's white density (deg/h
    sqrt(s)) and a log-sd of 3: negligible a priori, real values two log-sds up still
    plain (a FOG's B of 0.01 deg/h is 33x its median, a MEMS gyro's 6 deg/h 330x). Medians
    a tenth of it, as before, put the posterior of a white log's B and K at the largest
    values the log cannot rule out, and widened its coefficients' intervals 1.2-1.8x over
    white noise's (two 10 h FOG benches); a thousandth, 1.0-1.2x, while a bench with a FOG's
    flicker and walk still widens them 1.7-2.7x."""
    return LogNormal(level_deg_h * math.sqrt(max(step_s, 1e-9)) / 1000.0, 3.0)


class Flicker(AbstractNoiseTerm, AbstractAllanTerm):
    """IEEE 952's bias instability ``B_deg_h``: flicker as a sum of Gauss-Markov processes
    whose correlation times :meth:`for_log` spreads over the log
    (:func:`~gyroid.noise._block_filter.flicker_times`)."""

    tau_s: Float[Array, " j"] | None = None
    #: Each process's variance per unit ``B**2`` (an array once set up for a log: logs of
    #: one shape share their compiled programs whatever their step).
    unit_var: Float[Array, ""] | float = 0.0

    code: ClassVar[str] = "B"
    level_names: ClassVar[tuple[str, ...]] = ("B_deg_h",)
    description: ClassVar[str] = "bias instability"
    unit: ClassVar[str] = "deg/h"
    unresolved_hint: ClassVar[str] = "white noise or a random walk covers the flicker floor"

    def allan_variance(self, tau_s, tau0_s, tc_s):
        return np.full_like(tau_s, 2.0 * math.log(2.0) / math.pi)

    def haar_covariance(self, lag_s, tau_s, tc_s):
        return flicker_haar_covariance(lag_s, tau_s)
    units: ClassVar[dict[str, str]] = {"B_deg_h": "deg/h"}
    over_spans: ClassVar[bool] = True
    wanders: ClassVar[bool] = True

    def default_priors(self, level_deg_h, step_s, rows_per_mean):
        return {"B_deg_h": _ieee_default(level_deg_h, step_s)}

    def fog_priors(self):
        return {"B_deg_h": LogNormal(0.05, 3.0)}

    def start(self, residual, white, *, step_s, row_scale, dof, alone):
        return {"B_deg_h": 0.1 * float(np.std(residual))}, {"B_deg_h": 0.1}

    def for_log(self, step_s, duration_s):
        taus, unit = flicker_times(step_s, duration_s + step_s)
        return Flicker(tau_s=jnp.asarray(taus), unit_var=jnp.asarray(unit))

    def processes(self, values):
        if self.tau_s is None:
            raise ValueError("Flicker.processes: set the model up for the log (for_log)")
        return self.tau_s, values["B_deg_h"], self.unit_var

    def part_processes(self, values, *, step_s, span_s):
        taus, unit = flicker_times(step_s, span_s)
        return taus, float(values["B_deg_h"]), unit


class RateRandomWalk(AbstractNoiseTerm, AbstractAllanTerm):
    """IEEE 952's rate random walk ``K_deg_h_sqrt_h``, diffusing ``(K / 60)**2``
    (deg/h)^2 per second, centred on the log (its mean over the log is the bias)."""

    code: ClassVar[str] = "K"
    level_names: ClassVar[tuple[str, ...]] = ("K_deg_h_sqrt_h",)
    description: ClassVar[str] = "rate random walk"
    unit: ClassVar[str] = "deg/h/sqrt(h)"
    unresolved_hint: ClassVar[str] = "the log is too short for the walk to rise above the floor"

    def allan_variance(self, tau_s, tau0_s, tc_s):
        return (tau_s / 3.0 + tau0_s**2 / (6.0 * tau_s)) / 3600.0

    def haar_covariance(self, lag_s, tau_s, tc_s):
        return finite_reach(second_differenced(lambda u: u**3 / (12.0 * 3600.0), lag_s,
                                               tau_s), lag_s, tau_s)
    units: ClassVar[dict[str, str]] = {"K_deg_h_sqrt_h": "deg/h/sqrt(h)"}
    over_spans: ClassVar[bool] = True
    wanders: ClassVar[bool] = True

    def default_priors(self, level_deg_h, step_s, rows_per_mean):
        return {"K_deg_h_sqrt_h": _ieee_default(level_deg_h, step_s)}

    def fog_priors(self):
        return {"K_deg_h_sqrt_h": LogNormal(0.05, 3.0)}

    def start(self, residual, white, *, step_s, row_scale, dof, alone):
        return {"K_deg_h_sqrt_h": 0.1 * float(np.std(residual))}, {"K_deg_h_sqrt_h": 0.1}

    def diffusion(self, values):
        return (values["K_deg_h_sqrt_h"] / 60.0) ** 2


class GaussMarkovBias(AbstractNoiseTerm, AbstractAllanTerm):
    """A stationary first-order Gauss-Markov (AR(1)) bias of sd ``sigma_gm_deg_h`` and
    correlation time ``tau_gm_s`` (the usual model of a FOG's bias instability)."""

    code: ClassVar[str] = "G"
    level_names: ClassVar[tuple[str, ...]] = ("sigma_gm_deg_h", "tau_gm_s")
    units: ClassVar[dict[str, str]] = {"sigma_gm_deg_h": "deg/h", "tau_gm_s": "s"}
    over_spans: ClassVar[bool] = False
    wanders: ClassVar[bool] = False
    description: ClassVar[str] = "Gauss-Markov bias"
    unit: ClassVar[str] = "deg/h"
    unresolved_hint: ClassVar[str] = ("no bump in the Allan deviation that white noise, "
                                      "flicker and a walk leave")

    def allan_variance(self, tau_s, tau0_s, tc_s):
        return gauss_markov_avar(tau_s, tau0_s, tc_s)

    def haar_covariance(self, lag_s, tau_s, tc_s):
        return gauss_markov_haar_covariance(lag_s, tau_s, tc_s)

    def default_priors(self, level_deg_h, step_s, rows_per_mean):
        return {"sigma_gm_deg_h": LogNormal(level_deg_h / 3.0, 3.0),
                "tau_gm_s": self.fog_priors()["tau_gm_s"]}

    def fog_priors(self):
        return {"sigma_gm_deg_h": LogNormal(0.05, 3.0), "tau_gm_s": LogNormal(300.0, 2.0)}

    def start(self, residual, white, *, step_s, row_scale, dof, alone):
        return ({"sigma_gm_deg_h": 0.3 * float(np.std(residual)), "tau_gm_s": 300.0},
                {"sigma_gm_deg_h": 0.1, "tau_gm_s": 0.1})

    def processes(self, values):
        return jnp.reshape(values["tau_gm_s"], (1,)), values["sigma_gm_deg_h"], 1.0


class AbstractRateError(AbstractNoiseTerm):
    """The thermometer's noise through the dT/dt estimator, times wD (its least-squares
    value, fixed for the log; :mod:`gyroid.noise._rate_error_rows`): no level of its own."""

    code: ClassVar[str] = "T"
    level_names: ClassVar[tuple[str, ...]] = ()
    units: ClassVar[dict[str, str]] = {}
    wanders: ClassVar[bool] = False

    def default_priors(self, level_deg_h, step_s, rows_per_mean):
        return {}

    def fog_priors(self):
        return {}

    def start(self, residual, white, *, step_s, row_scale, dof, alone):
        return {}, {}

    @abc.abstractmethod
    def row_covariance(self) -> np.ndarray:
        """Its covariance over the fitted log's rows, (deg/h)^2, as the likelihood reads it."""


class RateError(AbstractRateError):
    """The rate error beside a correlated term: in the log's interior a process of the
    block filter matched to the estimator's error (:class:`~gyroid.noise.
    _rate_error_process.RateErrorProcess`), on the one-sided rows at its ends the exact
    error and its covariance with every row (:class:`~gyroid.noise._rate_error_rows.
    OneSidedRows`; None where the process read on them too moves no coefficient by more
    than a tolerance: :meth:`~gyroid.noise.NoiseModel.one_sided_weighed`). It makes the
    filter read the rows as block means."""

    process: RateErrorProcess
    ends: OneSidedRows | None
    #: The largest rms shift of a coefficient, in its sd, from reading the one-sided rows by
    #: the process (:func:`~gyroid.noise._rate_error_rows.coefficient_shift`); not a number
    #: where it was not weighed (no coefficients' columns given, or no white floor
    #: measured). An array: logs of one shape share one compilation.
    one_sided_shift_sd: Float[Array, ""]

    over_spans: ClassVar[bool] = True

    def row_covariance(self) -> np.ndarray:
        rows = self.process.row_covariance()
        return rows if self.ends is None else rows + self.ends.covariance()


class ExactRateError(AbstractRateError):
    """The rate error beside white noise alone: the rows' exact covariance, in its
    eigenbasis (:class:`~gyroid.noise._rate_error_eigenbasis.RowEigenbasis`)."""

    rows: RowEigenbasis

    over_spans: ClassVar[bool] = False

    def row_covariance(self) -> np.ndarray:
        return np.asarray(self.rows.covariance)


#: The terms a static log's Allan variance is fitted with (``gyroid noise``), in
#: ``noise.json``'s order.
STATIC_TERMS: tuple[AbstractAllanTerm, ...] = (
    Quantisation(), AngleRandomWalk(), Flicker(), RateRandomWalk(), RateRamp(),
    GaussMarkovBias(), Prefilter())
