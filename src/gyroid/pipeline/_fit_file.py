"""What ``gyroid fit`` does with one log, and ``gyroid batch`` with each of many: read it,
fit it, write its files. The options are one object (:class:`FitOptions`), so that both
commands take every option and check it before any log is read."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from gyroid.errors import GyroidInputError
from gyroid.inference._bench_fit import fit_log
from gyroid.inference._bench_problem import IEEE_MAX_ROWS
from gyroid.inference._bench_result import BenchFit, NoisePriorSource
from gyroid.inference._emcee import Emcee
from gyroid.inference._importance import Importance
from gyroid.io._bench_reader import bench_log_from_table
from gyroid.io._datasheet import datasheet_priors, read_datasheet
from gyroid.io._fitted import FittedNoise, axes_of
from gyroid.io._log_table import LogTable
from gyroid.io._logs import MeansOfBlocks
from gyroid.io._stream import STREAM_ROWS, stream_block_means, stream_rows
from gyroid.io._tables import read_header, read_log_table, table_source
from gyroid.io._units import ColumnMap
from gyroid.models._inputs import T0_C
from gyroid.models._prior_scales import PRIOR_SETS
from gyroid.models._priors import Prior
from gyroid.models._terms import resolve_terms
from gyroid.noise._level_priors import priors_from_noise
from gyroid.noise._model import DEFAULT_NOISE, NOISE_MODELS, noise_model
from gyroid.pipeline._axes import PerAxis, chosen_axes, write_per_axis


@dataclass(frozen=True)
class FitOptions:
    """Every option of a bench fit (``gyroid fit`` and ``gyroid batch``), checked when made:
    a wrong option is one message before any log is read."""

    terms: str
    noise: str = "auto"
    seed: int = 0
    t0_C: float = T0_C
    prior_set: str = "default"
    priors: Mapping[str, Prior] = field(default_factory=dict)
    rate_window_s: float | None = None  # None: chosen from the data
    segment_means: bool = False
    maps: tuple[ColumnMap, ...] = ()
    progress: bool = True  # the sampler's progress bar
    #: Gyro axes to fit (``--axes``); None: every axis the log has.
    axes: tuple[str, ...] | None = None
    #: A native log's IMU (``--instance``); None: its first.
    instance: int | None = None
    #: ``--noise DIR``: the IEEE 952 noise priors per axis from 'gyroid noise' (None: one
    #: axis, unnamed), and that folder; ``--noise FILE.toml``: a datasheet's, for every
    #: axis (``noise_from_datasheet``), and that file.
    noise_priors: Mapping[str | None, Mapping[str, Prior]] = field(default_factory=dict)
    noise_source: str = ""
    noise_from_datasheet: bool = False

    def __post_init__(self) -> None:
        resolve_terms(self.terms)
        try:
            model = noise_model(self.noise)
        except GyroidInputError:
            raise GyroidInputError(f"--noise {self.noise!r}: use one of "
                                   f"{', '.join(NOISE_MODELS)}, auto, a datasheet FILE.toml "
                                   "or the --out folder of 'gyroid noise'") from None
        given = {n for axis in self.noise_priors.values() for n in axis}
        if not given <= set(model.level_names):
            raise GyroidInputError(f"noise priors from {self.noise_source} are priors of "
                                   f"{', '.join(sorted(given))}, which the {model.name} "
                                   "noise model does not have")
        if not 0 <= self.seed < 2**32:
            raise GyroidInputError(f"--seed {self.seed}: give a whole number from 0 to "
                                   f"{2**32 - 1}")
        if not math.isfinite(self.t0_C) or not -273.15 < self.t0_C < 1000.0:
            raise GyroidInputError(f"--t0 {self.t0_C}: give the reference temperature in "
                                   "degC, a finite number above -273.15")
        if self.prior_set not in PRIOR_SETS:
            raise GyroidInputError(f"--priors {self.prior_set!r}: use one of "
                                   f"{', '.join(PRIOR_SETS)} or a .toml file")


def noise_datasheet_options(path: str | Path) -> dict:
    """``--noise FILE.toml``: the :class:`FitOptions` fields that fit IEEE 952 noise with its
    levels' priors from a gyro's datasheet (docs/formats.md section 6;
    :func:`~gyroid.io._datasheet.datasheet_priors`), the same on every axis."""
    sheet = read_datasheet(path)
    return {"noise": DEFAULT_NOISE, "noise_source": str(path), "noise_from_datasheet": True,
            "noise_priors": {None: datasheet_priors(sheet)}}


def noise_file_options(folder: str | Path) -> dict:
    """``--noise DIR``: the :class:`FitOptions` fields that fit IEEE 952 noise with priors
    from the folder of 'gyroid noise' (one axis, or ``axes.json`` and a folder per axis).
    A noise fit that failed its own checks is refused: its posterior is no prior."""
    fitted = axes_of(folder, FittedNoise.from_dir)
    for axis, noise in fitted.items():
        if not noise.trustworthy:
            where = f"{folder}/{axis}" if axis is not None else str(folder)
            raise GyroidInputError(
                f"--noise {where}: that noise fit is not trustworthy (it failed its own "
                "checks), so its posterior cannot serve as a prior: fix what its noise.json "
                "names, or use --noise auto")
    model = noise_model(DEFAULT_NOISE)
    return {"noise": model.name, "noise_source": str(folder),
            "noise_priors": {axis: priors_from_noise(noise.terms, model)
                             for axis, noise in fitted.items()}}


def _axis_noise_priors(options: FitOptions, axis: str | None, n_axes: int
                       ) -> dict[str, Prior]:
    """The noise priors ``--noise DIR`` gives ``axis``: its own, or a folder's one axis
    when one axis is fitted."""
    if not options.noise_priors:
        return {}
    if options.noise_from_datasheet:  # one gyro type on every axis
        return dict(next(iter(options.noise_priors.values())))
    if axis in options.noise_priors:
        return dict(options.noise_priors[axis])
    if len(options.noise_priors) == 1 and n_axes == 1:
        return dict(next(iter(options.noise_priors.values())))
    have = [a for a in options.noise_priors if a is not None]
    raise GyroidInputError(
        f"--noise {options.noise_source} holds the noise of "
        + (f"axes {', '.join(have)}" if have else "one unnamed axis")
        + f", not of axis {axis}: choose the axes with --axes, or run 'gyroid noise' on "
        "the same axes")


def fit_file(path: str | Path, options: FitOptions, out: str | Path,
             say: Callable[[str], None] | None = None) -> PerAxis[BenchFit]:
    """Read, fit and write one log, each of its gyro axes (``options.axes``) from one read
    of the file: with one axis its files go to ``out``, with several to ``out/AXIS/`` with
    ``out/axes.json``; they appear whole, or not at all."""
    counted = stream_rows(path)
    rows, exact = counted if counted is not None else (None, True)
    if rows is not None and rows > STREAM_ROWS:
        if options.instance is not None:
            raise GyroidInputError(f"--instance is for flight-controller, ROS and MATLAB "
                                   f"logs; {Path(path).name} is a table: choose its columns "
                                   "with --map")
        table = LogTable(Path(path), read_header(path), {}, 0, None, maps=options.maps)
        axes = chosen_axes(table, options.axes)
        per_mean = -(-rows // IEEE_MAX_ROWS)
        if say is not None:
            size = f"{rows} rows" if exact else f"at most about {rows} rows"
            say(f"reading {path} ({size}) as a stream, as means of {per_mean} samples ...")
        streamed = stream_block_means(path, options.terms, axes, options.maps, per_mean)
    else:
        table = read_log_table(path, options.maps, options.instance)
        axes = chosen_axes(table, options.axes)
        streamed = {}
    noise_priors = {axis: _axis_noise_priors(options, axis, len(axes)) for axis in axes}
    fits = {}
    for axis in axes:
        # one axis's samples at a time
        log = (streamed[axis] if streamed
               else bench_log_from_table(table, options.terms, axis=axis))
        if say is not None:
            which = f" (axis {axis})" if axis is not None else ""
            rows = (f"{log.log.n} means of {log.rows_per_mean} samples"
                    if isinstance(log, MeansOfBlocks) else f"{log.n} rows")
            say(f"fitting {options.terms} to {path}{which} ({rows}) ...")
        fit = fit_log(log, options.terms, noise=options.noise, seed=options.seed,
                      priors={**noise_priors[axis], **options.priors},
                      prior_set=options.prior_set, t0_C=options.t0_C,
                      rate_window_s=options.rate_window_s,
                      sampler=Importance(fallback=Emcee(progress=options.progress)),
                      segment_means=options.segment_means)
        if noise_priors[axis]:
            given = ("datasheet" if options.noise_from_datasheet else "noise fit in")
            fit = replace(fit, noise_priors_from=NoisePriorSource(options.noise_source,
                                                                  tuple(noise_priors[axis])),
                          noise_choice=f"asked for: {fit.problem.noise.name}, the priors of "
                                       f"{', '.join(noise_priors[axis])} from the {given} "
                                       f"{options.noise_source}")
        fits[axis] = fit
    result = PerAxis(fits, table_source(table))
    write_per_axis(out, result)
    return result
