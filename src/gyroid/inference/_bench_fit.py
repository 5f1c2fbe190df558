"""Fit a bench log in one call: :func:`fit_log` builds a
:class:`~gyroid.inference.BenchProblem` and fits it."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from gyroid.inference._bench_problem import BenchProblem
from gyroid.inference._bench_result import BenchFit
from gyroid.inference._emcee import Emcee
from gyroid.inference._fit import fit
from gyroid.inference._importance import Importance
from gyroid.inference._problem import AbstractSampler
from gyroid.io._logs import BenchLog, MeansOfBlocks
from gyroid.models._drift import DriftModel
from gyroid.models._inputs import T0_C
from gyroid.models._priors import Prior
from gyroid.noise._model import NoiseModel, noise_choice, noise_model


def fit_log(
    log: BenchLog | MeansOfBlocks,
    terms: str | tuple[str, ...] | DriftModel,
    *,
    noise: str | NoiseModel | None = "auto",
    seed: int = 0,
    priors: Mapping[str, Prior] | None = None,
    prior_set: str = "default",
    flat_prior: bool = False,
    t0_C: float = T0_C,
    rate_window_s: float | None = None,
    sample: bool = True,
    sampler: AbstractSampler | None = None,
    segment_means: bool = False,
    progress: bool = True,
    errors_in_variables: bool = True,
) -> BenchFit:
    """Fit ``terms`` to a bench log: :meth:`BenchProblem.from_log` (``rate_window_s=None``
    chooses the dT/dt window from the data), then :func:`~gyroid.inference.fit` (the mode,
    with ``sample=True`` the posterior by ``sampler``, by default importance sampling where
    the problem has a collapsed form and its weights are reliable, else emcee with a
    progress bar unless ``progress=False``; then the self-checks).

    ``noise="auto"`` (the default, here as on the command line) is IEEE 952's white +
    flicker + rate random walk (:mod:`gyroid.noise._block_filter`), whatever the log: its
    low-frequency processes are carried with priors that let them be negligible. It used to keep
    white noise unless the residuals' whiteness or the held-out stretches said otherwise;
    those tests have no power at the hour scales where flicker and a walk decide w0, w1 and
    w2, and on FOG benches with them the white fits exited 0 with intervals 2-3x too narrow
    (issue 42).
    ``noise="white"`` (or ``None``) is white noise: faster, and right only where the log's
    own noise is white at the hour scales; the API's default was white until issue 42's
    review found scripts getting the over-confident fit the command line had left.

    ``log`` may be a log already reduced to block means (:class:`MeansOfBlocks`, as a log
    too long to hold is read: :func:`gyroid.io.stream_block_means`).
    ``errors_in_variables=False`` leaves the thermometer's noise in dT/dt out of the
    likelihood (:meth:`BenchProblem.from_log`)."""
    kind = noise_model(noise)
    # a model carrying the wander reads a log of bursts as it is: its flicker or walk is
    # the wander between bursts
    problem = BenchProblem.from_log(log, terms, noise=kind, priors=priors,
                                    prior_set=prior_set, flat_prior=flat_prior, t0_C=t0_C,
                                    rate_window_s=rate_window_s,
                                    segment_means=segment_means and not kind.wanders,
                                    errors_in_variables=errors_in_variables)
    chosen = sampler or Importance(fallback=Emcee(progress=progress))
    result = fit(problem, sampler=chosen, seed=seed, sample=sample)
    why = noise_choice(noise)
    if why is None:
        return result
    if segment_means and kind.wanders:
        why += " (on the samples: the noise model carries the wander between bursts)"
    return replace(result, noise_choice=why)
