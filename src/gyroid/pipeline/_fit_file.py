"""What ``gyroid fit`` does with one log, and ``gyroid batch`` with each of many: read it,
fit it, write its files. The options are one object (:class:`FitOptions`, the bench fit's
own a :class:`~gyroid.bench.BenchOptions` in it), so that both commands take every
option and check it before any log is read."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from gyroid.bench._fit import fit_log
from gyroid.bench._options import BenchOptions
from gyroid.bench._problem import IEEE_MAX_ROWS
from gyroid.bench._result import BenchFit, NoisePriorSource
from gyroid.errors import GyroidInputError
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
from gyroid.models._priors import Prior
from gyroid.models._terms import resolve_terms
from gyroid.noise._level_priors import priors_from_noise
from gyroid.noise._model import DEFAULT_NOISE, noise_model
from gyroid.pipeline._axes import PerAxis, chosen_axes, write_per_axis


@dataclass(frozen=True)
class GivenNoisePriors:
    """IEEE 952 noise priors given from outside the log: ``--noise DIR``, the posteriors of
    'gyroid noise' per axis (key None: one unnamed axis); or ``--noise FILE.toml``, a
    datasheet's, the same on every axis (``datasheet``). ``source``: that folder or file."""

    per_axis: Mapping[str | None, Mapping[str, Prior]]
    source: str
    datasheet: bool = False

    @classmethod
    def from_datasheet(cls, path: str | Path) -> GivenNoisePriors:
        """A gyro's datasheet (docs/formats.md section 6;
        :func:`~gyroid.io._datasheet.datasheet_priors`), the same on every axis."""
        return cls({None: datasheet_priors(read_datasheet(path))}, str(path), datasheet=True)

    @classmethod
    def from_noise_fit(cls, folder: str | Path) -> GivenNoisePriors:
        """The folder of 'gyroid noise' (one axis, or ``axes.json`` and a folder per axis).
        A noise fit that failed its own checks is refused: its posterior is no prior."""
        fitted = axes_of(folder, FittedNoise.from_dir)
        for axis, noise in fitted.items():
            if not noise.trustworthy:
                where = f"{folder}/{axis}" if axis is not None else str(folder)
                raise GyroidInputError(
                    f"--noise {where}: that noise fit is not trustworthy (it failed its own "
                    "checks), so its posterior cannot serve as a prior: fix what its "
                    "noise.json names, or use --noise auto")
        model = noise_model(DEFAULT_NOISE)
        return cls({axis: priors_from_noise(noise.terms, model)
                    for axis, noise in fitted.items()}, str(folder))

    def for_axis(self, axis: str | None, n_axes: int) -> dict[str, Prior]:
        """The priors of ``axis``: its own, the datasheet's, or a folder's one axis when one
        axis is fitted."""
        if self.datasheet:  # one gyro type on every axis
            return dict(next(iter(self.per_axis.values())))
        if axis in self.per_axis:
            return dict(self.per_axis[axis])
        if len(self.per_axis) == 1 and n_axes == 1:
            return dict(next(iter(self.per_axis.values())))
        have = [a for a in self.per_axis if a is not None]
        raise GyroidInputError(
            f"--noise {self.source} holds the noise of "
            + (f"axes {', '.join(have)}" if have else "one unnamed axis")
            + f", not of axis {axis}: choose the axes with --axes, or run 'gyroid noise' on "
            "the same axes")

    def described(self, model: str, names) -> str:
        """How a fit got its noise model ``model`` and the priors of its levels ``names``
        (fit.json's ``noise_choice``)."""
        given = "datasheet" if self.datasheet else "noise fit in"
        return (f"asked for: {model}, the priors of {', '.join(names)} from the {given} "
                f"{self.source}")


@dataclass(frozen=True)
class FitOptions:
    """Every option of ``gyroid fit`` and ``gyroid batch``, checked when made (a wrong option
    is one message before any log is read): the bench fit's own (``bench``,
    :class:`~gyroid.bench.BenchOptions`) and how the file is read and the fit seeded."""

    terms: str
    bench: BenchOptions = field(default_factory=BenchOptions)
    seed: int = 0
    maps: tuple[ColumnMap, ...] = ()
    progress: bool = True  # the sampler's progress bar
    #: Gyro axes to fit (``--axes``); None: every axis the log has.
    axes: tuple[str, ...] | None = None
    #: A native log's IMU (``--instance``); None: its first.
    instance: int | None = None
    #: ``--noise DIR`` or ``--noise FILE.toml``: the noise levels' priors (the noise model
    #: is then IEEE 952's).
    noise_priors: GivenNoisePriors | None = None

    def __post_init__(self) -> None:
        resolve_terms(self.terms)
        if not 0 <= self.seed < 2**32:
            raise GyroidInputError(f"--seed {self.seed}: give a whole number from 0 to "
                                   f"{2**32 - 1}")
        if self.noise_priors is None:
            return
        model = self.bench.noise_model
        given = {n for axis in self.noise_priors.per_axis.values() for n in axis}
        if not given <= set(model.level_names):
            raise GyroidInputError(f"noise priors from {self.noise_priors.source} are priors "
                                   f"of {', '.join(sorted(given))}, which the {model.name} "
                                   "noise model does not have")


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
    given = options.noise_priors
    noise_priors = {axis: {} if given is None else given.for_axis(axis, len(axes))
                    for axis in axes}
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
        bench = replace(options.bench, priors={**noise_priors[axis], **options.bench.priors})
        fit = fit_log(log, options.terms, bench, seed=options.seed,
                      sampler=Importance(fallback=Emcee(progress=options.progress)))
        if given is not None and noise_priors[axis]:
            fit = replace(fit, noise_priors_from=NoisePriorSource(given.source,
                                                                  tuple(noise_priors[axis])),
                          noise_choice=given.described(fit.problem.noise.name,
                                                        noise_priors[axis]))
        fits[axis] = fit
    result = PerAxis(fits, table_source(table))
    write_per_axis(out, result)
    return result
