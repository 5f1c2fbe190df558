"""Fit a bench log in one call: :func:`fit_log` builds a
:class:`~gyroid.bench.BenchProblem` and fits it."""

from __future__ import annotations

from dataclasses import replace

from gyroid.bench._options import BenchOptions
from gyroid.bench._problem import BenchProblem
from gyroid.bench._result import BenchFit
from gyroid.inference._emcee import Emcee
from gyroid.inference._fit import fit
from gyroid.inference._importance import Importance
from gyroid.inference._problem import AbstractSampler
from gyroid.io._logs import BenchLog, MeansOfBlocks
from gyroid.models._drift import DriftModel


def fit_log(
    log: BenchLog | MeansOfBlocks,
    terms: str | tuple[str, ...] | DriftModel,
    options: BenchOptions | None = None,
    *,
    seed: int = 0,
    sample: bool = True,
    sampler: AbstractSampler | None = None,
    progress: bool = True,
) -> BenchFit:
    """Fit ``terms`` to a bench log under ``options`` (:class:`BenchOptions`; None: every
    default): :meth:`BenchProblem.from_log`, then :func:`~gyroid.inference.fit` (the mode,
    with ``sample=True`` the posterior by ``sampler``, by default importance sampling where
    its weights are reliable, else emcee with a progress bar unless ``progress=False``; then
    the self-checks).

    The default noise model (``auto``, here as on the command line) is IEEE 952's white +
    flicker + rate random walk, whatever the log: its low-frequency processes are carried
    with priors that let them be negligible, since a log's whiteness tests have no power at
    the hour scales where flicker and a walk decide w0, w1 and w2. ``noise="white"`` is
    faster, and right only where the log's own noise is white at those scales.

    ``log`` may be a log already reduced to block means (:class:`MeansOfBlocks`, as a log
    too long to hold is read: :func:`gyroid.io.stream_block_means`)."""
    options = options or BenchOptions()
    problem = BenchProblem.from_log(log, terms, options)
    chosen = sampler or Importance(fallback=Emcee(progress=progress))
    result = fit(problem, sampler=chosen, seed=seed, sample=sample)
    why = options.noise_choice
    return result if why is None else replace(result, noise_choice=why)
