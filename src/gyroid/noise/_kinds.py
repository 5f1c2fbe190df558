"""gyroid's noise models (:class:`White`, :class:`GaussMarkov`, :class:`Ieee952`) and their
registry by name (:func:`noise_model`): the one place that spells their names.

* ``white``: independent Gaussian noise of sd ``sigma_deg_h`` (a sample's, also when the
  rows are means);
* ``white+gm``: white noise plus a first-order Gauss-Markov (AR(1)) bias of sd
  ``sigma_gm_deg_h`` and correlation time ``tau_gm_s`` (the usual model of a FOG's bias
  instability), by a Kalman filter on the rows, or on block means integrated over each
  block (:mod:`gyroid.noise._ieee` with one correlation time);
* ``white+flicker+rw``: IEEE Std 952's angle random walk ``N_deg_sqrt_h``, bias
  instability (flicker) ``B_deg_h`` and rate random walk ``K_deg_h_sqrt_h``, each row the
  mean over one sampling step, by the exact block filter of :mod:`gyroid.noise._ieee`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import ClassVar

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.errors import GyroidInputError
from gyroid.models._priors import LogNormal
from gyroid.noise._base import NoiseModel, parts_mean_covariance
from gyroid.noise._ieee import flicker_times, ieee_innovations, ieee_part_covariance
from gyroid.noise._kalman import gauss_markov_innovations, gauss_markov_mean_covariance
from gyroid.noise._rate_error_process import RateErrorProcess

_WHITE_UNITS = {"sigma_deg_h": "deg/h"}
#: Paper A's FOG white level prior (a sample's sd, deg/h; a density on log x).
_FOG_WHITE = LogNormal(1.0, 3.0)


def _high_frequency(residual: np.ndarray) -> float:
    """The residual's white level from its first differences (slow parts cancel), deg/h."""
    return float(np.std(np.diff(residual)) / math.sqrt(2.0)) if residual.size > 2 else 0.0


class White(NoiseModel):
    """Independent Gaussian noise."""

    name: ClassVar[str] = "white"
    level_names: ClassVar[tuple[str, ...]] = ("sigma_deg_h",)
    units: ClassVar[dict[str, str]] = _WHITE_UNITS
    correlated: ClassVar[bool] = False
    on_block_means: ClassVar[bool] = False
    remedies: ClassVar[tuple[str, ...]] = ("noise_model", "segment_means", "discrepancy")

    def default_priors(self, level_deg_h, step_s, rows_per_mean):
        return {"sigma_deg_h": LogNormal(level_deg_h * math.sqrt(rows_per_mean), 3.0)}

    def fog_priors(self):
        return {"sigma_deg_h": _FOG_WHITE}

    def row_white_sd(self, values, *, step_s, row_scale):
        return values["sigma_deg_h"] * row_scale

    def start_levels(self, residual, white, *, step_s, row_scale, dof):
        return {"sigma_deg_h": white / row_scale}, {"sigma_deg_h": 1.0 / (2.0 * dof)}

    def sample_white_sd(self, values, sample_s):
        return float(values["sigma_deg_h"])

    def innovations(self, observed, white, values, clock):
        return None

    def part_covariance(self, time_s, part, n_parts, step_s, white_var, values, *,
                        block_means=False, after_s=None):
        return np.diag(np.asarray(white_var, dtype=float))


class GaussMarkov(NoiseModel):
    """White noise plus a stationary first-order Gauss-Markov bias; with ``rate_error``, the
    thermometer's noise through dT/dt too (its density reads the rows as block means then:
    :meth:`~gyroid.inference._bench_density.BenchDensity.from_log`)."""

    rate_error: RateErrorProcess | None = None

    name: ClassVar[str] = "white+gm"
    level_names: ClassVar[tuple[str, ...]] = ("sigma_deg_h", "sigma_gm_deg_h", "tau_gm_s")
    units: ClassVar[dict[str, str]] = {**_WHITE_UNITS, "sigma_gm_deg_h": "deg/h",
                                       "tau_gm_s": "s"}
    correlated: ClassVar[bool] = True
    on_block_means: ClassVar[bool] = True
    remedies: ClassVar[tuple[str, ...]] = ("noise_terms", "segment_means", "discrepancy")

    def default_priors(self, level_deg_h, step_s, rows_per_mean):
        return {"sigma_deg_h": LogNormal(level_deg_h * math.sqrt(rows_per_mean), 3.0),
                "sigma_gm_deg_h": LogNormal(level_deg_h / 3.0, 3.0),
                "tau_gm_s": self.fog_priors()["tau_gm_s"]}

    def fog_priors(self):
        return {"sigma_deg_h": _FOG_WHITE, "sigma_gm_deg_h": LogNormal(0.05, 3.0),
                "tau_gm_s": LogNormal(300.0, 2.0)}

    def row_white_sd(self, values, *, step_s, row_scale):
        return values["sigma_deg_h"] * row_scale

    def rows_as_means(self, rows_per_mean):
        return rows_per_mean > 1

    def with_rate_error(self, process):
        return GaussMarkov(rate_error=process)

    def known_white(self, sigma):
        return jnp.median(sigma)  # the filter takes one white level

    def start_levels(self, residual, white, *, step_s, row_scale, dof):
        return ({"sigma_deg_h": _high_frequency(residual) / row_scale,
                 "sigma_gm_deg_h": 0.3 * float(np.std(residual)), "tau_gm_s": 300.0},
                {"sigma_deg_h": 1.0 / (2.0 * dof), "sigma_gm_deg_h": 0.1, "tau_gm_s": 0.1})

    def sample_white_sd(self, values, sample_s):
        return float(values["sigma_deg_h"])

    def innovations(self, observed, white, values, clock):
        if clock.gap_s is None:
            return gauss_markov_innovations(observed, clock.steps_s, white,
                                            values["sigma_gm_deg_h"], values["tau_gm_s"],
                                            clock.weight)
        # block means: the process integrated over each block, exactly (one correlation
        # time and no random walk); sampling it at the blocks' centres would be its own
        # approximation
        span = jnp.full_like(clock.steps_s, clock.step_s)
        return ieee_innovations(observed, span, clock.gap_s,
                                jnp.broadcast_to(white**2, span.shape),
                                values["sigma_gm_deg_h"], jnp.zeros(()),
                                jnp.reshape(values["tau_gm_s"], (1,)), 1.0, clock.weight,
                                centred=False, rate_error=self.rate_error)

    def part_covariance(self, time_s, part, n_parts, step_s, white_var, values, *,
                        block_means=False, after_s=None):
        white = np.diag(np.asarray(white_var, dtype=float))
        if block_means:
            return white + ieee_part_covariance(
                time_s, part, n_parts, step_s, np.zeros(n_parts), values["sigma_gm_deg_h"],
                0.0, (np.array([values["tau_gm_s"]]), 1.0)) + _rate_error_parts(
                self.rate_error, part, n_parts, after_s)
        return white + gauss_markov_mean_covariance(time_s, part, n_parts,
                                                    values["sigma_gm_deg_h"],
                                                    values["tau_gm_s"])


class Ieee952(NoiseModel):
    """IEEE Std 952's white noise (N), flicker (B) and rate random walk (K), the flicker a
    sum of Gauss-Markov processes whose correlation times :meth:`for_log` spreads over the
    log (:func:`~gyroid.noise._ieee.flicker_times`)."""

    flicker_tau_s: Float[Array, " j"] | None = None
    flicker_unit_var: float = 0.0
    #: The thermometer's noise through dT/dt, carried by the filter (or None).
    rate_error: RateErrorProcess | None = None

    name: ClassVar[str] = "white+flicker+rw"
    level_names: ClassVar[tuple[str, ...]] = ("N_deg_sqrt_h", "B_deg_h", "K_deg_h_sqrt_h")
    units: ClassVar[dict[str, str]] = {"N_deg_sqrt_h": "deg/sqrt(h)", "B_deg_h": "deg/h",
                                       "K_deg_h_sqrt_h": "deg/h/sqrt(h)"}
    correlated: ClassVar[bool] = True
    on_block_means: ClassVar[bool] = True
    remedies: ClassVar[tuple[str, ...]] = ("segment_means", "discrepancy")

    def rows_as_means(self, rows_per_mean):
        return True

    def for_log(self, step_s, duration_s):
        taus, unit = flicker_times(step_s, duration_s + step_s)
        return Ieee952(flicker_tau_s=jnp.asarray(taus), flicker_unit_var=unit,
                       rate_error=self.rate_error)

    def with_rate_error(self, process):
        return Ieee952(flicker_tau_s=self.flicker_tau_s,
                       flicker_unit_var=self.flicker_unit_var, rate_error=process)

    def default_priors(self, level_deg_h, step_s, rows_per_mean):
        """N about the log's white density; B and K with medians a thousandth of it (deg/h,
        deg/h/sqrt(h)) and a log-sd of 3: negligible a priori, real values two log-sds up
        still plain (a FOG's B of 0.01 deg/h is 33x its median, a MEMS gyro's 6 deg/h
        330x). Medians a tenth of it, as before, put the posterior of a white log's B and K
        at the largest values the log cannot rule out, and widened its coefficients'
        intervals 1.2-1.8x over white noise's (two 10 h FOG benches); a thousandth, 1.0-1.2x,
        while a bench with a FOG's flicker and walk still widens them 1.7-2.7x."""
        density = level_deg_h * math.sqrt(max(step_s, 1e-9))  # deg/h sqrt(s)
        return {"N_deg_sqrt_h": LogNormal(density / 60.0, 3.0),
                "B_deg_h": LogNormal(density / 1000.0, 3.0),
                "K_deg_h_sqrt_h": LogNormal(density / 1000.0, 3.0)}

    def fog_priors(self):
        return {"N_deg_sqrt_h": LogNormal(0.01, 3.0), "B_deg_h": LogNormal(0.05, 3.0),
                "K_deg_h_sqrt_h": LogNormal(0.05, 3.0)}

    def row_white_sd(self, values, *, step_s, row_scale):
        return 60.0 * values["N_deg_sqrt_h"] / math.sqrt(step_s)  # a row's mean over a step

    def start_levels(self, residual, white, *, step_s, row_scale, dof):
        tenth = 0.1 * float(np.std(residual))
        return ({"N_deg_sqrt_h": _high_frequency(residual) * math.sqrt(step_s) / 60.0,
                 "B_deg_h": tenth, "K_deg_h_sqrt_h": tenth},
                {"N_deg_sqrt_h": 1.0 / (2.0 * dof), "B_deg_h": 0.1, "K_deg_h_sqrt_h": 0.1})

    def sample_white_sd(self, values, sample_s):
        return float(60.0 * values["N_deg_sqrt_h"] / math.sqrt(sample_s))

    def innovations(self, observed, white, values, clock):
        if self.flicker_tau_s is None:
            raise ValueError("Ieee952.innovations: set the model up for the log (for_log)")
        span = jnp.full_like(clock.steps_s, clock.step_s)
        gap = jnp.zeros_like(span) if clock.gap_s is None else clock.gap_s
        return ieee_innovations(observed, span, gap, jnp.broadcast_to(white**2, span.shape),
                                values["B_deg_h"], values["K_deg_h_sqrt_h"],
                                self.flicker_tau_s, self.flicker_unit_var, clock.weight,
                                rate_error=self.rate_error)

    def part_covariance(self, time_s, part, n_parts, step_s, white_var, values, *,
                        block_means=False, after_s=None):
        return ieee_part_covariance(time_s, part, n_parts, step_s, white_var,
                                    values["B_deg_h"], values["K_deg_h_sqrt_h"],
                                    after_s=after_s) + _rate_error_parts(
            self.rate_error, part, n_parts, after_s)


def _rate_error_parts(process: RateErrorProcess | None, part: np.ndarray, n_parts: int,
                      after_s: float | None) -> np.ndarray | float:
    """The covariance of parts' means of the fitted log's rows (``part``: each row's) that
    a carried rate error adds; 0 without one, and for a new log (``after_s``: its
    thermometer is not the fitted log's)."""
    if process is None or after_s is not None:
        return 0.0
    rows = np.asarray(part)
    if rows.size != process.mean_noise.shape[0]:
        raise ValueError("the rate error's covariance is of the fitted log's rows: "
                         f"{process.mean_noise.shape[0]} rows, not {rows.size}")
    return parts_mean_covariance(process.row_covariance(), rows, n_parts)


#: The noise models ``--noise`` offers, by name.
NOISE_MODELS: dict[str, NoiseModel] = {m.name: m for m in (White(), GaussMarkov(), Ieee952())}


def noise_model(kind: str | NoiseModel) -> NoiseModel:
    """The noise model named ``kind`` (or ``kind`` itself); a clear error for an unknown
    name."""
    if isinstance(kind, NoiseModel):
        return kind
    if kind not in NOISE_MODELS:
        raise GyroidInputError(f"--noise {kind!r}: use one of {', '.join(NOISE_MODELS)}")
    return NOISE_MODELS[kind]


def recorded_model(record: Mapping) -> NoiseModel:
    """The noise model a fit record's ``noise`` section names (``model``); an old record
    without it had white noise."""
    return noise_model(record.get("model", White.name))
