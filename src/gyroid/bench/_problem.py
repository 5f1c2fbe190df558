"""A bench log's drift model as a problem to fit (:class:`BenchProblem`): the log, its model's
density (:class:`~gyroid.bench._density.BenchDensity`), the priors chosen for it,
and what the self-checks read."""

from __future__ import annotations

import math
from dataclasses import replace

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from gyroid._compiled_programs import release_if_crowded
from gyroid._exported import exported
from gyroid.bench._density import BenchDensity, predicted
from gyroid.bench._one_sided import weigh_one_sided, windows_in_one_form
from gyroid.bench._options import BenchOptions
from gyroid.bench._point import point_estimate
from gyroid.bench._point_profiled import collapsed_log_likelihood
from gyroid.bench._rate_window import choose_rate_window, reads_rate
from gyroid.bench._rate_window_marginal import marginal_window
from gyroid.bench._result import BenchFit, bench_result
from gyroid.bench._thermometer import carried_thermometer, thermometer_to_carry
from gyroid.errors import GyroidInputError
from gyroid.inference._check_report import FitEvidence
from gyroid.inference._emcee import Emcee
from gyroid.inference._importance import Importance
from gyroid.inference._marginal_target import MarginalTarget, marginal_target
from gyroid.inference._mode import Optimum
from gyroid.inference._posterior import Posterior
from gyroid.inference._problem import AbstractProblem, PointEstimate
from gyroid.io._logs import BenchLog, MeansOfBlocks, SampleDeviations, contiguous_segments
from gyroid.io._logs import segment_means as means_of_segments
from gyroid.models._derived import (
    RATE_WINDOW_S,
    temperature_rate_deg_c_per_h,
)
from gyroid.models._drift import DriftModel
from gyroid.models._prior_scales import (
    PriorBasis,
    choose_priors,
    identifiability_hints,
    log_scales,
    reference_sd,
)
from gyroid.models._priors import Prior
from gyroid.noise._model import NoiseModel, noise_model

#: The most rows a correlated noise model filters, and the most a fit carrying the
#: thermometer's noise holds its covariance over (longer logs: block means).
IEEE_MAX_ROWS = 1000


class BenchProblem(AbstractProblem[BenchFit]):
    """The posterior of a drift model given a bench log. Build it with :meth:`from_log`."""

    density: BenchDensity
    log: BenchLog  # what the model is fitted to (a burst log's segment means when asked)
    prior_set: str
    prior_basis: PriorBasis
    rate_window_choice: str  # "auto" (and how), "given", or why the default was kept
    segments: SampleDeviations | None = None
    #: Samples per row of a fit of block means (white+flicker+rw on a long log), else 1.
    block_rows: int = 1
    #: The thermometer's white noise, a sample's sd in degC, when it is carried into the
    #: likelihood through dT/dt (errors in variables); 0 otherwise.
    thermometer_sd_C: float = 0.0
    #: The wD (deg/h per degC/h, least squares) that scales the thermometer's noise
    #: carried; 0 when none is carried.
    rate_error_wd: float = 0.0
    #: The noise levels' marginal mode found while choosing the dT/dt window (sampling
    #: coordinates; :mod:`gyroid.bench._rate_window_marginal`): a linear model's mode
    #: is there, a model with time constants starts its profile from its own guess.
    noise_mode: Optimum | None = eqx.field(static=True, default=None)

    @classmethod
    def from_log(
        cls,
        log: BenchLog | MeansOfBlocks,
        terms: str | tuple[str, ...] | DriftModel,
        options: BenchOptions | None = None,
        *,
        fast: bool = True,
        max_rows: int | None = None,
    ) -> BenchProblem:
        """The problem of fitting ``terms`` to ``log`` under ``options``
        (:class:`~gyroid.bench.BenchOptions`; None: every default).

        The priors: the options' ``prior_set`` (:mod:`gyroid.models._prior_scales`), single
        parameters overridden by name. An automatic dT/dt window is chosen from the data
        (:mod:`gyroid.bench._rate_window`). ``segment_means`` fits one row per contiguous
        segment of a burst-sampled log (its mean), so that the bias's wander between bursts
        is the noise the model estimates rather than a correlation it ignores, unless the
        noise model carries that wander itself (then the samples are fitted); the samples
        are still checked for spikes, which the means would hide. ``fast=False``: no
        sufficient statistics (for tests). Under correlated noise a log of more than
        ``max_rows`` rows (default :data:`IEEE_MAX_ROWS`) is fitted as at most that many
        means of blocks of consecutive samples (not with segment means; exact likelihood, a
        linear model loses little; the samples are checked for spikes). A
        :class:`~gyroid.io._logs.MeansOfBlocks` (a log read as a stream) is fitted as its
        means under any noise model.

        Errors in variables (unless the options' ``errors_in_variables`` is False): a model
        reading dT/dt on a log with a noisy thermometer carries that noise through the rate
        estimator (:mod:`gyroid.bench._thermometer`) as a term of the noise model (more
        than ``max_rows`` rows: block means; :meth:`~gyroid.noise.NoiseModel.with_rate_error`).
        Under correlated noise the automatic window is the marginal likelihood's
        (:mod:`gyroid.bench._rate_window_marginal`)."""
        options = options or BenchOptions()
        noise, t0_C, segment_means = (options.noise_model, options.t0_C,
                                      options.fits_segment_means)
        rate_window_s = options.rate_window_s
        release_if_crowded()  # the build compiles most of a fit's programs
        cap = IEEE_MAX_ROWS if max_rows is None else max_rows
        model = terms if isinstance(terms, DriftModel) else DriftModel.from_terms(terms)
        # the thermometer's noise to carry (degC^2, a sample's), the filter's wD scaling it
        thermometer_var, wd = (0.0, 0.0) if (
            segment_means or not options.errors_in_variables or not reads_rate(model)) else (
            thermometer_to_carry(log, model, rate_window_s, t0_C, cap))
        log, block_rows, samples = _rows_fitted(log, noise, segment_means,
                                                carry_thermometer=thermometer_var > 0, cap=cap)
        thermometer_var_row = thermometer_var / block_rows  # a row's (a block mean's)
        base = inputs = log.inputs(t0_C=t0_C)  # the one set built (10^7 rows: 0.8 GB)
        if rate_window_s is None:
            rate_window_s, _ = choose_rate_window(log, model, t0_C=t0_C, inputs=inputs,
                                                  thermometer_var_C2=thermometer_var_row)
            choice = "auto" if reads_rate(model) else "default (the model reads no dT/dt)"
        else:
            choice = "given"
        inputs = _with_rate_window(log, inputs, rate_window_s)
        model.check_identifiable(inputs, frozenset(log.columns))
        chosen, basis = choose_priors(model, inputs, np.asarray(log.drift_deg_h),
                                      _noise_priors(noise, log, inputs, block_rows,
                                                    options.prior_set,
                                                    log.sigma_deg_h is not None),
                                      prior_set=options.prior_set, overrides=options.priors)

        def density_at(window_s: float) -> BenchDensity:
            # the search tries no window wider than the first (rate_window_s)
            return _density(log, model, chosen, _with_rate_window(log, base, window_s), noise,
                            window_s=window_s, block_rows=block_rows, wd=wd,
                            thermometer_var_row=thermometer_var_row, fast=fast,
                            widest_s=rate_window_s)

        # the windows compared in one form (the one-sided rows weighed at a guess), the
        # chosen one's weighed at its mode
        form_at, exact_at = windows_in_one_form(density_at, rate_window_s)
        density, noise_mode, choice = _by_marginal(form_at, log, rate_window_s, choice)
        density, noise_mode = weigh_one_sided(
            density, exact_at(float(density.rate_window_s)), noise_mode)
        return cls(density=density, log=log, prior_set=options.prior_set, prior_basis=basis,
                   rate_window_choice=choice, block_rows=block_rows, segments=samples,
                   thermometer_sd_C=math.sqrt(thermometer_var), rate_error_wd=wd,
                   noise_mode=noise_mode)

    def under_noise(self, noise: str | NoiseModel) -> BenchProblem:
        """This problem on the same rows (the same block means, dT/dt window, coefficients'
        priors and carried thermometer noise) under another noise model, its levels' priors
        by this problem's prior set: what the log allows under each can then be compared."""
        noise = noise_model(noise)
        noise_priors = _noise_priors(noise, self.log, self.inputs, self.block_rows,
                                     self.prior_set, self.sigma_known)
        density = _density(self.log, self.model,
                           (*self.priors[:self.n_model], *noise_priors.values()), self.inputs,
                           noise, window_s=self.rate_window_s, block_rows=self.block_rows,
                           wd=self.rate_error_wd,
                           thermometer_var_row=self.thermometer_sd_C**2 / self.block_rows)
        return replace(self, density=density, noise_mode=None)

    @property
    def reads_segment_means(self) -> bool:
        """Whether each row is a burst log's segment mean (``segment_means=True``)."""
        return self.segments is not None and self.block_rows == 1

    # ----- description (the density's) -------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        return self.density.names

    @property
    def positive(self) -> tuple[bool, ...]:
        return self.density.positive

    @property
    def priors(self) -> tuple[Prior, ...]:
        return self.density.priors

    @property
    def n_model(self) -> int:
        return self.density.n_model

    @property
    def model(self) -> DriftModel:
        return self.density.model

    @property
    def inputs(self):
        return self.density.inputs

    @property
    def noise(self) -> NoiseModel:
        return self.density.noise

    @property
    def noise_names(self) -> tuple[str, ...]:
        return self.density.noise_names

    @property
    def n(self) -> int:
        return self.density.n

    @property
    def t0_C(self) -> float:
        return self.density.inputs.t0_C

    @property
    def rate_window_s(self) -> float:
        return float(self.density.rate_window_s)

    @property
    def samples_behind(self) -> SampleDeviations:
        """The samples behind a fit of means (of blocks or a burst log's segments)."""
        if self.segments is None:
            raise ValueError("this fit reads the log's samples, not means of them")
        return self.segments

    @property
    def sigma_known(self) -> bool:
        return self.density.sigma is not None

    def predict(self, u) -> np.ndarray:
        """Modelled drift at every row, deg/h, for sampling coordinates ``u``."""
        return np.asarray(predicted(self.density, jnp.asarray(u)))

    def standardised_residuals(self, u) -> np.ndarray:
        """Residuals over their modelled sd (Kalman innovations under white+gm)."""
        return np.asarray(_standardised(self.density, jnp.asarray(u)))

    # ----- fitting ------------------------------------------------------------------------------
    def result(self, point: PointEstimate, posterior: Posterior | None, *,
               seed: int) -> BenchFit:
        """The fit's frozen :class:`~gyroid.bench.BenchFit`, its self-checks first."""
        return bench_result(self, point, posterior, seed=seed)

    def mode(self) -> PointEstimate:
        return point_estimate(self.density, noise_mode=self.noise_mode)

    def log_likelihood(self, u) -> float:
        """The log-likelihood at sampling coordinates ``u``, from the collapsed form's
        filter (one compilation for every model of as many coefficients)."""
        return collapsed_log_likelihood(self.density, u)

    def collapsed(self):
        from gyroid.inference._collapsed import collapse

        return collapse(self.density)

    def marginal_target(self) -> MarginalTarget:
        return marginal_target(self.density)

    def evidence(self, point: PointEstimate, posterior) -> FitEvidence:
        """What the self-checks read of a fit of this problem."""
        model, inputs, log = self.model, self.inputs, self.log
        return FitEvidence(
            names=self.names,
            n_model=self.n_model,
            point_u=np.asarray(point.u),
            point_converged=point.converged,
            point_message=point.message,
            priors=self.priors,
            reference_sd=reference_sd(model, inputs, np.asarray(log.drift_deg_h)),
            residuals=self.standardised_residuals(point.u),
            sigma_given=self.sigma_known,
            # the gyro's noise: a carried thermometer's correlates no wander of its own
            correlated_noise=self.noise.without_rate_error().correlated,
            draws_u=None if posterior is None else self.to_sampling_host(posterior.draws),
            summary=None if posterior is None else posterior.summary,
            hints=identifiability_hints(model, inputs),
            segments=tuple(contiguous_segments(np.asarray(log.time_s))),
            where=log.where,
        )

    def default_sampler(self) -> Importance:
        return Importance(fallback=Emcee())

    # ----- storage ------------------------------------------------------------------------------
    def observed_data(self) -> dict[str, np.ndarray]:
        return {"drift_deg_h": np.asarray(self.density.drift)}

    def constant_data(self) -> dict[str, np.ndarray]:
        return {"time_h": np.asarray(self.inputs.time_h),
                "loo_block": np.asarray(self.density.block)}

    def idata_attrs(self) -> dict[str, str]:
        return {
            "terms": ",".join(self.model.terms),
            "noise_model": self.noise.name,
            "log_likelihood_note": "log_likelihood holds sums over blocks of rows "
                                   "(constant_data.loo_block): LOO leaves out whole blocks",
        }


def _density(log: BenchLog, model: DriftModel, priors, inputs, noise: NoiseModel, *,
             window_s: float, block_rows: int, wd: float, thermometer_var_row: float,
             fast: bool = True, widest_s: float | None = None) -> BenchDensity:
    """The density of ``model`` on ``log``'s rows (each the mean of ``block_rows`` samples)
    under ``noise``, dT/dt estimated over ``window_s`` (s) in ``inputs``, the thermometer's
    noise carried through it (a row's variance, degC^2, times ``wd**2``; ``widest_s``: the
    widest window the fit tries, s, whose shapes every window's carried term takes): one
    construction for a fit's windows and for its rows under another noise model
    (:meth:`BenchProblem.under_noise`)."""
    return BenchDensity.from_log(log, model, priors, inputs, noise=noise,
                                 rate_window_s=window_s, fast=fast, rows_per_mean=block_rows,
                                 thermometer=carried_thermometer(log, window_s, wd,
                                                                 thermometer_var_row,
                                                                 widest_s))


def _by_marginal(density_at, log: BenchLog, window_s: float, choice: str
                 ) -> tuple[BenchDensity, Optimum | None, str]:
    """The density at ``window_s`` (s) or, for an automatic window (``choice`` "auto")
    under correlated noise (a collapsed form), at the window of highest marginal likelihood
    (:mod:`gyroid.bench._rate_window_marginal`), with the noise levels' marginal mode
    found there; and how the window was chosen."""
    built: dict[float, BenchDensity] = {}

    def at(window: float) -> BenchDensity:
        if window not in built:
            built[window] = density_at(window)
        return built[window]

    density = at(window_s)
    # under white noise (a carried thermometer's aside) the least-squares window stands:
    # the marginal's chose 1528-2157 s on paper A's bench, nothing absorbing the smearing
    if (choice != "auto" or not density.noise.without_rate_error().correlated
            or not log.has("temperature_C")):
        return density, None, choice
    better = marginal_window(at, window_s, float(np.median(np.diff(np.asarray(log.time_s)))))
    if better is None:
        return density, None, choice
    density = at(better[0])
    scored = ", ".join(f"{w:.0f}" for w in sorted(better[1]))
    return density, better[2], (
        f"auto: the marginal likelihood's of {scored} s (least squares' {window_s:.0f} s)")


def _rows_fitted(log: BenchLog | MeansOfBlocks, noise: NoiseModel, segment_means: bool, *,
                 carry_thermometer: bool, cap: int
                 ) -> tuple[BenchLog, int, SampleDeviations | None]:
    """The rows a fit reads (the log, its block means or its segments' means), the samples
    per row, and the samples behind the means (for the spike check); see
    :meth:`BenchProblem.from_log`."""
    samples, block_rows = None, 1
    if isinstance(log, MeansOfBlocks):
        if segment_means:
            raise GyroidInputError(
                f"--segment-means: {log.log.source} is fitted as the means of blocks of "
                f"{log.rows_per_mean} samples (it was read as a stream); leave "
                "--segment-means out")
        log, block_rows, samples = log.log, log.rows_per_mean, log.samples
    if (carry_thermometer or (noise.correlated and not segment_means)) and log.n > cap:
        reduced = MeansOfBlocks.of(log, -(-log.n // cap))
        log, block_rows, samples = reduced.log, reduced.rows_per_mean, reduced.samples
    if segment_means:
        log, samples = means_of_segments(log, contiguous_segments(np.asarray(log.time_s)))
    return log, block_rows, samples


def _with_rate_window(log: BenchLog, inputs, rate_window_s: float):
    """``inputs`` with dT/dt estimated over ``rate_window_s`` (s) when that is not the
    default window the inputs were built with."""
    if rate_window_s == RATE_WINDOW_S or "temperature_C" not in log.columns:
        return inputs
    rate = temperature_rate_deg_c_per_h(np.asarray(log.time_s),
                                        np.asarray(log.columns["temperature_C"]), rate_window_s)
    return eqx.tree_at(lambda x: x.rate_C_h, inputs, jnp.asarray(rate))


def _noise_priors(noise: NoiseModel, log: BenchLog, inputs, rows_per_mean: int,
                  prior_set: str, sigma_known: bool) -> dict[str, Prior]:
    """The noise levels' priors, in sampling order: paper A's FOG priors under
    ``paper_a_fog``, else scaled to the log (its rows' high-frequency level and step)."""
    if prior_set == "paper_a_fog":
        priors = noise.fog_priors()
    else:
        _, level = log_scales(np.asarray(log.drift_deg_h))
        time_s = 3600.0 * np.asarray(inputs.time_h)
        step = float(np.median(np.diff(time_s))) if time_s.size > 1 else 1.0
        priors = noise.default_priors(level, step, rows_per_mean)
    return {name: priors[name] for name in noise.names(sigma_known)}


@exported
def _standardised(density, u):
    """The standardised residuals, compiled once per log shape (eager: 0.2 s a call)."""
    return density.standardised_residuals(u)
