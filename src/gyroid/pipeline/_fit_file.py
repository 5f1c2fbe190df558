"""What ``gyroid fit`` does with one log, and ``gyroid batch`` with each of many: read it,
fit it, write its files. The options are one object (:class:`FitOptions`), so that both
commands take every option and check it before any log is read."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from gyroid.errors import GyroidInputError
from gyroid.inference._bench_density import NOISE_MODELS
from gyroid.inference._bench_fit import BenchFit, fit_log
from gyroid.inference._emcee import Emcee
from gyroid.io._bench_reader import bench_log_from_table
from gyroid.io._tables import read_log_table, table_source
from gyroid.io._units import ColumnMap
from gyroid.models._inputs import T0_C
from gyroid.models._prior_scales import PRIOR_SETS
from gyroid.models._priors import Prior
from gyroid.models._terms import resolve_terms
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

    def __post_init__(self) -> None:
        resolve_terms(self.terms)
        if self.noise not in (*NOISE_MODELS, "auto"):
            raise GyroidInputError(f"--noise {self.noise!r}: use one of "
                                   f"{', '.join(NOISE_MODELS)} or auto")
        if not 0 <= self.seed < 2**32:
            raise GyroidInputError(f"--seed {self.seed}: give a whole number from 0 to "
                                   f"{2**32 - 1}")
        if not math.isfinite(self.t0_C) or not -273.15 < self.t0_C < 1000.0:
            raise GyroidInputError(f"--t0 {self.t0_C}: give the reference temperature in "
                                   "degC, a finite number above -273.15")
        if self.prior_set not in PRIOR_SETS:
            raise GyroidInputError(f"--priors {self.prior_set!r}: use one of "
                                   f"{', '.join(PRIOR_SETS)} or a .toml file")


def fit_file(path: str | Path, options: FitOptions, out: str | Path,
             say: Callable[[str], None] | None = None) -> PerAxis[BenchFit]:
    """Read, fit and write one log, each of its gyro axes (``options.axes``) from one read
    of the file: with one axis its files go to ``out``, with several to ``out/AXIS/`` with
    ``out/axes.json``; they appear whole, or not at all."""
    table = read_log_table(path, options.maps, options.instance)
    fits = {}
    for axis in chosen_axes(table, options.axes):
        log = bench_log_from_table(table, options.terms, axis=axis)
        if say is not None:
            which = f" (axis {axis})" if axis is not None else ""
            say(f"fitting {options.terms} to {path}{which} ({log.n} rows) ...")
        fits[axis] = fit_log(log, options.terms, noise=options.noise, seed=options.seed,
                             priors=dict(options.priors), prior_set=options.prior_set,
                             t0_C=options.t0_C, rate_window_s=options.rate_window_s,
                             sampler=Emcee(progress=options.progress),
                             segment_means=options.segment_means)
    result = PerAxis(fits, table_source(table))
    write_per_axis(out, result)
    return result
