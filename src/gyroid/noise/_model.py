"""A drift log's noise model: a named tuple of terms (:mod:`gyroid.noise._terms`), its white
term first, composed into one likelihood (on a log's rows: :mod:`gyroid.noise._row_filter`) and
one covariance of parts' means, so the predictive check tests what the fit assumed; and the
registry of the models ``--noise`` offers by name.

* ``white``: independent Gaussian noise of sd ``sigma_deg_h`` (a sample's, also when the
  rows are means);
* ``white+gm``: white noise plus a first-order Gauss-Markov bias (``sigma_gm_deg_h``,
  ``tau_gm_s``), by a Kalman filter on the rows, or on block means integrated over each
  block;
* ``white+flicker+rw``: IEEE Std 952's angle random walk ``N_deg_sqrt_h``, bias instability
  (flicker) ``B_deg_h`` and rate random walk ``K_deg_h_sqrt_h``, each row the mean over one
  sampling step, by the block filter.

A new model is one line, ``NoiseModel("white+rw", (AngleRandomWalk(), RateRandomWalk()))``
(Kalibr's); a new term is one class (:class:`~gyroid.noise._terms.AbstractNoiseTerm`).
"""

from __future__ import annotations

from collections.abc import Mapping

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

from gyroid.errors import GyroidInputError
from gyroid.models._priors import Prior
from gyroid.noise._base import RowClock, parts_mean_covariance
from gyroid.noise._block_filter import block_innovations
from gyroid.noise._kalman import gauss_markov_innovations, gauss_markov_mean_covariance
from gyroid.noise._mean_covariance import log_span_s, part_covariance
from gyroid.noise._rate_error_eigenbasis import RowEigenbasis
from gyroid.noise._rate_error_process import RateErrorProcess
from gyroid.noise._rate_error_rows import CarriedThermometer, OneSidedRows
from gyroid.noise._terms import (
    AbstractNoiseTerm,
    AbstractRateError,
    AbstractWhiteTerm,
    AngleRandomWalk,
    ExactRateError,
    Flicker,
    GaussMarkovBias,
    RateError,
    RateRandomWalk,
    SampleWhite,
)


class NoiseModel(eqx.Module):
    """A drift log's noise model: ``terms``, the white term first. Levels are by name in
    natural units (``values``); the white level is not sampled when the log gives each
    row's sd (``sigma_deg_h``)."""

    #: The name in ``--noise`` and in fit.json.
    name: str = eqx.field(static=True)
    terms: tuple[AbstractNoiseTerm, ...]

    def __check_init__(self):
        if not self.terms or not isinstance(self.terms[0], AbstractWhiteTerm):
            raise ValueError(f"noise model {self.name!r}: its first term is white noise")
        names = [n for t in self.terms for n in t.level_names]
        if len(set(names)) != len(names):
            raise ValueError(f"noise model {self.name!r}: two terms share a level name")

    # ----- what the model is ------------------------------------------------------------
    @property
    def white(self) -> AbstractWhiteTerm:
        white = self.terms[0]
        assert isinstance(white, AbstractWhiteTerm)
        return white

    @property
    def level_names(self) -> tuple[str, ...]:
        """The sampled levels (natural units; sampled as logs), the white level first."""
        return tuple(n for t in self.terms for n in t.level_names)

    @property
    def units(self) -> dict[str, str]:
        return {n: u for t in self.terms for n, u in t.units.items()}

    @property
    def static_fit(self) -> dict[str, str]:
        """Its levels a static noise fit and a datasheet give, by the static fit's letter."""
        return {n: c for t in self.terms for n, c in t.static_fit.items()}

    @property
    def codes(self) -> tuple[str, ...]:
        """The terms' letters (N, B, K, G; T for a carried rate error)."""
        return tuple(t.code for t in self.terms)

    @property
    def correlated(self) -> bool:
        """Whether the rows are correlated (a filter gives the likelihood). A long log is
        then fitted as block means (the likelihood exact on means)."""
        return len(self.terms) > 1

    @property
    def wanders(self) -> bool:
        """Whether a term carries the wander at hour scales (flicker, a walk): a log of
        bursts is then read as it is, not as its bursts' means."""
        return any(t.wanders for t in self.terms)

    @property
    def remedies(self) -> tuple[str, ...]:
        """What a failed predictive check advises (codes of the checks' remedies): a
        correlated model under white noise, more terms under one short process; a burst
        log's means where this model does not carry the wander between bursts itself (one
        that does fits the samples whatever is asked)."""
        more = (("noise_model",) if not self.without_rate_error().correlated
                else () if {"B", "K"} <= set(self.codes) else ("noise_terms",))
        return (*more, *(() if self.wanders else ("segment_means",)), "discrepancy")

    @property
    def rival(self) -> NoiseModel | None:
        """The noise model a fit under this one is weighed against (what the log allows
        under each, :mod:`gyroid.bench._allowed_noise`): the default, for a correlated
        model of other terms (a Gauss-Markov bias is flat beyond its correlation time, where
        flicker and a walk rise, and a log often cannot tell them apart); None for white
        noise, whose whiteness check tests the rows themselves, and for the default's
        terms."""
        gyro = self.without_rate_error()
        default = noise_model(DEFAULT_NOISE)
        if not gyro.correlated or set(gyro.codes) == set(default.codes):
            return None
        return default

    def names(self, sigma_known: bool) -> tuple[str, ...]:
        """The sampled levels' names: without the white level when the log gives it."""
        return self.level_names[len(self.white.level_names):] if sigma_known \
            else self.level_names

    def rows_as_means(self, rows_per_mean: int) -> bool:
        """Whether the likelihood reads each row as the mean over its step (block means,
        ``rows_per_mean`` samples each) rather than as a sample."""
        if not self.correlated:
            return False
        return rows_per_mean > 1 or any(t.over_spans for t in self.terms)

    def for_log(self, step_s: float, duration_s: float) -> NoiseModel:
        """This model set up for a log of rows ``step_s`` apart lasting ``duration_s``."""
        return NoiseModel(self.name, tuple(t.for_log(step_s, duration_s) for t in self.terms))

    def with_rate_error(self, carried: CarriedThermometer, *, d0: np.ndarray,
                        span_s: np.ndarray, gap_s: np.ndarray, step_s: float) -> NoiseModel:
        """This model carrying the thermometer's noise through the dT/dt estimator
        (``carried``, on the log's rows: each row's white variance per unit level ``d0``,
        spans ``span_s`` after gaps ``gap_s``, ``step_s`` apart) as one more term: beside
        white noise alone the rows' exact covariance (:class:`~gyroid.noise._terms.
        ExactRateError`; :mod:`gyroid.noise._rate_error_eigenbasis` says why a process will not
        do there), beside a correlated term a process of the block filter matched to the
        estimator's interior error, the one-sided rows exact
        (:class:`~gyroid.noise._terms.RateError`; none where the rows are not evenly
        spaced for the process: a log of bursts)."""
        gyro = self.without_rate_error()
        if not gyro.correlated:
            rows = RowEigenbasis.of(carried.covariance(), d0, np.ones(np.size(d0), dtype=bool))
            return NoiseModel(self.name, (*gyro.terms, ExactRateError(rows)))
        autocovariance = carried.autocovariance()
        if autocovariance is None:
            return gyro
        process = RateErrorProcess.matched(autocovariance, step_s, carried.white_var,
                                           span_s, gap_s, observed=~carried.one_sided)
        ends = OneSidedRows.of(carried.operator(), carried.one_sided, process,
                               reach=carried.reach, directions=carried.directions)
        return NoiseModel(self.name, (*gyro.terms, RateError(process, ends, jnp.asarray(np.nan))))

    def one_sided_weighed(self, shift_sd: float, by_process: bool, *, span_s: np.ndarray,
                          gap_s: np.ndarray) -> NoiseModel:
        """This model with its carried rate error's one-sided rows weighed: what their exact
        error moves the coefficients by, ``shift_sd`` (in their sds), recorded, and with
        ``by_process`` those rows read by the interior's process like every other row (on
        rows of spans ``span_s`` after gaps ``gap_s``, s), their exact error dropped
        (:func:`~gyroid.bench._one_sided.weigh_one_sided`)."""
        term = self.carried
        if not isinstance(term, RateError):
            raise ValueError("one_sided_weighed: this model carries no rate error process")
        process, ends = term.process, term.ends
        if by_process:
            process = RateErrorProcess.of(np.asarray(process.oscillators), span_s, gap_s, None,
                                          float(process.divergence),
                                          float(process.divergence_without))
            ends = None
        new = RateError(process, ends, jnp.asarray(shift_sd))
        return NoiseModel(self.name, tuple(new if t is term else t for t in self.terms))

    def without_rate_error(self) -> NoiseModel:
        """This model without a carried rate error (the gyro's noise, not the fitted log's
        thermometer): itself when it carries none."""
        if self.carried is None:
            return self
        return NoiseModel(self.name, tuple(t for t in self.terms
                                           if not isinstance(t, AbstractRateError)))

    def on_rows(self, keep: np.ndarray) -> NoiseModel:
        """This model on the rows ``keep`` of its log (a boolean mask): a carried exact
        rate error's covariance is then the kept rows' (their marginal)."""
        carried = self.carried
        if not isinstance(carried, ExactRateError):
            return self
        return NoiseModel(self.name, (*self.without_rate_error().terms,
                                      ExactRateError(carried.rows.on_rows(keep))))

    @property
    def carried(self) -> AbstractRateError | None:
        """The thermometer's noise this model carries (a term), or None."""
        return next((t for t in self.terms if isinstance(t, AbstractRateError)), None)

    @property
    def carried_process(self) -> RateError | None:
        """The thermometer's noise this model carries as a process of its filter (beside a
        correlated term), or None."""
        carried = self.carried
        return carried if isinstance(carried, RateError) else None

    # ----- priors and starts ------------------------------------------------------------
    def default_priors(self, level_deg_h: float, step_s: float, rows_per_mean: int
                       ) -> dict[str, Prior]:
        """Priors scaled to a log whose rows' high-frequency noise is ``level_deg_h``
        (deg/h), rows ``step_s`` apart, each the mean of ``rows_per_mean`` samples."""
        return {n: p for t in self.terms
                for n, p in t.default_priors(level_deg_h, step_s, rows_per_mean).items()}

    def fog_priors(self) -> dict[str, Prior]:
        """Paper A's navigation-grade FOG priors (``--priors paper_a_fog``)."""
        return {n: p for t in self.terms for n, p in t.fog_priors().items()}

    def start_levels(self, residual: np.ndarray, white: float, *, step_s: float,
                     row_scale: float, dof: int) -> tuple[dict[str, float], dict[str, float]]:
        """Where a mode-finder starts: each level (natural units) guessed from the
        residual of a white fit (``white``: its rows' sd, deg/h; ``dof`` its degrees of
        freedom), and a rough variance of its log."""
        values: dict[str, float] = {}
        variances: dict[str, float] = {}
        for term in self.terms:
            v, var = term.start(residual, white, step_s=step_s, row_scale=row_scale, dof=dof,
                                alone=not self.without_rate_error().correlated)
            values |= v
            variances |= var
        return values, variances

    # ----- the white level --------------------------------------------------------------
    def row_white_sd(self, values: Mapping, *, step_s: float | Array,
                     row_scale: float | Array) -> Array:
        """The white sd of a row (deg/h; traceable) when the log does not give it."""
        return self.white.row_white_sd(values, step_s=step_s, row_scale=row_scale)

    def sample_white_sd(self, values: Mapping, sample_s: float) -> float:
        """A sample's white sd (deg/h) at a sample interval of ``sample_s``."""
        return self.white.sample_white_sd(values, sample_s)

    # ----- likelihood and parts' covariance ---------------------------------------------
    def _at_instants(self, block_means: bool, processes, walk: bool) -> bool:
        """Whether the rows are read as instants: samples (not block means) under a single
        Gauss-Markov process, no walk and no term that needs a row's span (exact there, by
        the scalar filter; the block filter is the general case)."""
        return (not block_means and not walk and len(processes) == 1
                and np.shape(processes[0][0])[0] == 1
                and not any(t.over_spans for t in self.terms))

    def _walk(self, values: Mapping):
        walks = [d for t in self.terms if (d := t.diffusion(values)) is not None]
        return (sum(walks), True) if walks else (0.0, False)

    def filtered(self, observed, white, values: Mapping, clock: RowClock):
        """The filter's innovations of ``observed`` (rows; trailing columns filtered alike)
        and their variances under this model, white sd ``white``, and a carried rate error's
        one-sided rows' loadings filtered alike (rows by ``k``; None without one): the
        rows' covariance is the filter's plus those loadings' low-rank correction
        (:class:`~gyroid.noise._rate_error_rows.OneSidedRows`); None for independent
        rows. Beside white noise alone a carried rate error's rows are their coordinates in
        its covariance's eigenbasis (independent, not in time order)."""
        if not self.correlated:
            return None
        if isinstance(exact_rows := self.carried, ExactRateError):
            return (*exact_rows.rows.innovations(observed, white), None)
        processes = [g for t in self.terms if (g := t.processes(values)) is not None]
        diffusion, centred = self._walk(values)
        if self._at_instants(clock.gap_s is not None, processes, centred):
            taus, level, unit = processes[0]
            return (*gauss_markov_innovations(observed, clock.steps_s, white,
                                              level * jnp.sqrt(unit), taus[0], clock.weight),
                    None)
        span = jnp.full_like(clock.steps_s, clock.step_s)
        gap = jnp.zeros_like(span) if clock.gap_s is None else clock.gap_s
        carried = self.carried_process
        exact = None if carried is None else carried.ends
        columns = observed.reshape(observed.shape[0], -1)
        width = columns.shape[1]
        if exact is not None:
            columns = jnp.concatenate([columns, exact.loadings], axis=1)
        innovation, variance = block_innovations(
            columns, span, gap, jnp.broadcast_to(white**2, span.shape), processes,
            diffusion, clock.weight, centred=centred,
            rate_error=None if carried is None else carried.process,
            early=None if exact is None else exact.early)
        ends = None if exact is None else innovation[:, width:]
        return innovation[:, :width].reshape(observed.shape), variance, ends

    def innovations(self, observed, white, values: Mapping, clock: RowClock):
        """The innovations of ``observed`` (rows; trailing columns filtered alike) and
        their variances under this model, in time order, white sd ``white``; None for
        independent rows. A carried rate error's one-sided rows are filtered as columns
        beside ``observed`` and corrected for after (:meth:`~gyroid.noise.
        _rate_error_rows.OneSidedRows.innovations`); beside white noise alone its rows'
        exact covariance gives its eigenbasis's coordinates instead, not in time order."""
        filtered = self.filtered(observed, white, values, clock)
        if filtered is None:
            return None
        innovation, variance, ends = filtered
        carried = self.carried_process
        if ends is None or carried is None or carried.ends is None:
            return innovation, variance
        update = jnp.ones_like(variance) if clock.weight is None else clock.weight
        data = innovation.reshape(innovation.shape[0], -1)
        corrected, variance = carried.ends.innovations(data, ends, variance, update)
        return corrected.reshape(innovation.shape), variance

    def part_covariance(self, time_s: np.ndarray, part: np.ndarray, n_parts: int,
                        step_s: float, white_var: np.ndarray, values: Mapping, *,
                        block_means: bool = False, after_s: float | None = None
                        ) -> np.ndarray:
        """The covariance ((deg/h)^2) of the means of parts of a log's rows (``part``: each
        row's part, -1 for none; parts contiguous and in time order; rows ``step_s``
        apart): ``white_var`` each part's white variance, plus the correlated terms as the
        likelihood reads them (``block_means``: the rows are block means). With
        ``after_s``, the parts are of a new log that follows the fitted one (of that span,
        s): a walk has moved since the fitted log's mean, and the fitted log's
        thermometer is not the new log's."""
        white = np.diag(np.asarray(white_var, dtype=float))
        if not self.without_rate_error().correlated:
            return white + self._rate_error_parts(part, n_parts, after_s)
        span = log_span_s(time_s, step_s)
        processes = [g for t in self.terms
                     if (g := t.part_processes(values, step_s=step_s, span_s=span)) is not None]
        diffusion, walk = self._walk(values)
        if self._at_instants(block_means, processes, walk):
            taus, level, unit = processes[0]
            return white + gauss_markov_mean_covariance(time_s, part, n_parts,
                                                        level * np.sqrt(unit), float(taus[0]))
        cov = part_covariance(time_s, part, n_parts, step_s, np.asarray(white_var, dtype=float),
                              processes, float(diffusion), after_s=after_s)
        return cov + self._rate_error_parts(part, n_parts, after_s)

    def _rate_error_parts(self, part: np.ndarray, n_parts: int, after_s: float | None
                          ) -> np.ndarray | float:
        """The covariance of parts' means of the fitted log's rows (``part``: each row's)
        that a carried rate error adds; 0 without one, and for a new log (``after_s``: its
        thermometer is not the fitted log's)."""
        carried = self.carried
        if carried is None or after_s is not None:
            return 0.0
        covariance = carried.row_covariance()
        rows = np.asarray(part)
        if rows.size != covariance.shape[0]:
            raise ValueError("the rate error's covariance is of the fitted log's rows: "
                             f"{covariance.shape[0]} rows, not {rows.size}")
        return parts_mean_covariance(covariance, rows, n_parts)


#: The noise models ``--noise`` offers, by name.
NOISE_MODELS: dict[str, NoiseModel] = {m.name: m for m in (
    NoiseModel("white", (SampleWhite(),)),
    NoiseModel("white+gm", (SampleWhite(), GaussMarkovBias())),
    NoiseModel("white+flicker+rw", (AngleRandomWalk(), Flicker(), RateRandomWalk())),
)}
#: The model a fit takes unless told (``--noise auto``, ``noise="auto"``): IEEE 952's.
DEFAULT_NOISE = "white+flicker+rw"
#: Why the default is the default, as a fit record says it.
DEFAULT_REASON = ("auto: {name}, always: the flicker and the rate random walk that every gyro "
                  "has are carried with priors that let them be negligible, since a log cannot "
                  "rule them out at the scales that decide the coefficients")


def noise_model(kind: str | NoiseModel | None) -> NoiseModel:
    """The noise model named ``kind`` (``auto``: :data:`DEFAULT_NOISE`; None: white; a
    model itself); a clear error for an unknown name."""
    if isinstance(kind, NoiseModel):
        return kind
    name = "white" if kind is None else DEFAULT_NOISE if kind == "auto" else kind
    if name not in NOISE_MODELS:
        raise GyroidInputError(f"--noise {kind!r}: use one of {', '.join(NOISE_MODELS)} "
                               "or auto")
    return NOISE_MODELS[name]


def noise_choice(kind: str | NoiseModel | None) -> str | None:
    """Why a fit has its noise model, when gyroid chose it (``auto``); None when asked."""
    if isinstance(kind, str) and kind == "auto":
        return DEFAULT_REASON.format(name=DEFAULT_NOISE)
    return None


def recorded_model(record: Mapping) -> NoiseModel:
    """The noise model a fit record's ``noise`` section names (``model``); an old record
    without it had white noise."""
    return noise_model(record.get("model"))
