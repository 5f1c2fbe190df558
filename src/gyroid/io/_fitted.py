"""A fit read back: its drift model and posterior draws, from the folder ``gyroid fit`` or
``gyroid pool`` wrote (fit.json or pool.json, posterior.nc), or from a fit in memory
(``BenchFit.fitted_drift()``), what compensation and propagation start from; a noise fit's
terms (noise.json), what the noise export starts from; a folder of several axes."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._arviz import read_posterior
from gyroid.models._derived import RATE_WINDOW_S
from gyroid.models._drift import DriftModel
from gyroid.models._inputs import T0_C
from gyroid.noise._base import predictive_level
from gyroid.noise._estimate import NoiseEstimate
from gyroid.noise._model import recorded_model


@dataclass(frozen=True)
class FittedDrift:
    """A fit's drift model and posterior draws (natural units)."""

    model: DriftModel
    draws: np.ndarray  # (m, p)
    t0_C: float
    rate_window_s: float = RATE_WINDOW_S  # the fit's dT/dt estimator window, s
    trustworthy: bool = True  # the fit's own verdict (fit.json)
    #: What the draws are: a fit's posterior, or a pool's predictive for a new run.
    source: str = "fit posterior"
    #: The range of every input the fit saw ([min, max] by name; see
    #: ``DriftModel.input_ranges``): compensation flags rows beyond them.
    input_ranges: dict[str, list[float]] = field(default_factory=dict)
    #: The fit's noise model and its levels: what the predictive check of a compensation
    #: needs (None: unknown, an old fit folder).
    noise: NoiseEstimate | None = None
    #: Each effect's contribution over the fitted rows (fit.json's
    #: ``effect_contributions_deg_h``: ``every``, ``rows``, ``effects``); empty: unknown.
    contributions: dict = field(default_factory=dict)

    @classmethod
    def from_dir(cls, folder: str | Path) -> FittedDrift:
        """From the folder of 'gyroid fit' (its posterior draws) or of 'gyroid pool' (its
        predictive draws for a new run: a unit that was not in the lot)."""
        folder = Path(folder)
        if (folder / "pool.json").exists() and not (folder / "fit.json").exists():
            return cls._from_pool_dir(folder)
        fit_json, netcdf = folder / "fit.json", folder / "posterior.nc"
        for path in (fit_json, netcdf):
            if not path.exists():
                raise GyroidInputError(f"{folder} has no {path.name}: give the --out folder "
                                       "of 'gyroid fit'")
        fit = _record(fit_json, "gyroid fit")
        model = DriftModel.from_terms(fit["terms"])
        posterior = _posterior(netcdf, "gyroid fit")
        columns = [_draws(posterior, name, netcdf) for name in model.parameter_names]
        return cls(model=model, draws=np.column_stack(columns), t0_C=fit.get("t0_C", T0_C),
                   rate_window_s=float(fit.get("rate_window_s", RATE_WINDOW_S)),
                   trustworthy=bool(fit.get("trustworthy", True)),
                   input_ranges=fit.get("input_ranges", {}), noise=_noise_of(fit),
                   contributions=fit.get("effect_contributions_deg_h", {}))


    @classmethod
    def _from_pool_dir(cls, folder: Path) -> FittedDrift:
        netcdf = folder / "posterior.nc"
        if not netcdf.exists():
            raise GyroidInputError(f"{folder} has no posterior.nc: give the --out folder of "
                                   "'gyroid pool'")
        pool = _record(folder / "pool.json", "gyroid pool")
        if not pool.get("terms"):
            raise GyroidInputError(f"{folder}/pool.json pools published estimates, not logs: "
                                   "it has no drift model to compensate with")
        model = DriftModel.from_terms(pool["terms"])
        posterior = _posterior(netcdf, "gyroid pool")
        columns = [_draws(posterior, f"new_run_{name}", netcdf)
                   for name in model.parameter_names]
        windows = [w for w in pool.get("rate_window_s", {}).values() if w is not None]
        return cls(model=model, draws=np.column_stack(columns), t0_C=pool.get("t0_C", T0_C),
                   rate_window_s=float(np.median(windows)) if windows else RATE_WINDOW_S,
                   trustworthy=bool(pool.get("trustworthy", True)),
                   source="pool: predictive for a new run",
                   input_ranges=pool.get("input_ranges", {}),
                   noise=_new_run_noise(pool))


@dataclass(frozen=True)
class FittedNoise:
    """A noise fit read back from ``noise.json``: each IEEE term's summary (``mean``, ``sd``,
    ``ci90``, ``resolved``, ``upper_bound_95``; datasheet units), the Allan deviation and the
    model's (deg/h at ``tau_s``), the sample interval (s) and the fit's verdict."""

    terms: dict[str, dict]
    tau_s: np.ndarray
    model_adev_deg_h: np.ndarray
    sample_s: float
    trustworthy: bool

    @classmethod
    def from_dir(cls, folder: str | Path) -> FittedNoise:
        """From the folder of 'gyroid noise' (one axis)."""
        path = Path(folder) / "noise.json"
        if not path.exists():
            raise GyroidInputError(f"{folder} has no noise.json: give the --out folder of "
                                   "'gyroid noise'")
        record = _record(path, "gyroid noise")
        try:
            return cls(terms=record["terms"], tau_s=np.asarray(record["allan"]["tau_s"], float),
                       model_adev_deg_h=np.asarray(record["allan"]["model_adev_deg_h"], float),
                       sample_s=float(record["sample_s"]),
                       trustworthy=bool(record.get("trustworthy", False)))
        except (KeyError, TypeError, ValueError) as error:
            raise GyroidInputError(f"{path} lacks {error} ('gyroid noise' writes it): run "
                                   "'gyroid noise' again") from None


Fitted = TypeVar("Fitted")


def axes_of(folder: str | Path, read: Callable[[Path], Fitted]) -> dict[str | None, Fitted]:
    """A result folder per axis, read by ``read``: ``{None: result}`` for one axis, every
    ``AXIS/`` that ``axes.json`` lists for several."""
    folder = Path(folder)
    record = folder / "axes.json"
    if not record.exists():
        return {None: read(folder)}
    try:
        axes = list(json.loads(record.read_text(encoding="utf-8"))["axes"])
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise GyroidInputError(f"{record} is damaged ({error}); run the command again"
                               ) from None
    return {axis: read(folder / axis) for axis in axes}


def axes_source(folder: str | Path) -> dict:
    """What the reader picked from a native log (``axes.json``'s ``source``; empty for a
    folder of one axis)."""
    record = Path(folder) / "axes.json"
    if not record.exists():
        return {}
    try:
        return dict(json.loads(record.read_text(encoding="utf-8")).get("source") or {})
    except (OSError, ValueError, TypeError):
        return {}


def _record(path: Path, command: str) -> dict:
    """A fit's JSON record, or one message saying it is damaged."""
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise GyroidInputError(f"{path} cannot be read ({error}): give a folder that "
                               f"'{command}' wrote whole, or run it again") from None
    if not isinstance(record, dict) or "terms" not in record:
        raise GyroidInputError(f"{path} is not a {command} record (no 'terms'): give the "
                               f"--out folder of '{command}'")
    return record


def _posterior(path: Path, command: str):
    try:
        return read_posterior(path)
    except Exception as error:  # noqa: BLE001 - a damaged or foreign netCDF file
        raise GyroidInputError(f"{path} cannot be read ({type(error).__name__}): give a "
                               f"folder that '{command}' wrote whole, or run it again") from None


def _draws(posterior, name: str, path: Path) -> np.ndarray:
    if name not in posterior:
        raise GyroidInputError(f"{path} has no draws of {name}: it does not belong to this "
                               "fit record; run the fit again")
    return np.asarray(posterior[name]).reshape(-1)


def _new_run_noise(pool: dict) -> NoiseEstimate | None:
    """A new run's noise from pool.json: the runs' estimates drawn up
    (:meth:`NoiseEstimate.of_runs`); None when it records none (published estimates)."""
    runs = pool.get("run_noise_levels") or {}
    return NoiseEstimate.of_runs([_noise_estimate(r) for r in runs.values()]) if runs else None


#: The keys of a noise estimate's record that are not levels.
_NOT_LEVELS = frozenset({"model", "white_sd_deg_h", "white_sample_s", "span_s"})


def _noise_estimate(record: dict) -> NoiseEstimate:
    """A noise estimate from its record (``NoiseEstimate.to_json``)."""
    return NoiseEstimate(recorded_model(record),
                         {k: float(v) for k, v in record.items() if k not in _NOT_LEVELS},
                         float(record["white_sd_deg_h"]), record.get("white_sample_s"),
                         record.get("span_s"))


def _noise_of(fit: dict) -> NoiseEstimate | None:
    """The noise model a fit.json records (each level the root mean square over its
    posterior, else the point estimate); None when it records none."""
    noise = fit.get("noise", {})
    levels = {k: predictive_level(v) for k, v in (noise.get("posterior") or {}).items()} or \
        dict(noise.get("point") or {})
    if not levels and "white_sd_deg_h" not in noise:
        return None
    model = recorded_model(noise)
    white = noise.get("white_sd_deg_h", levels.get("sigma_deg_h"))
    if white is None:
        return None
    return NoiseEstimate(model, levels, float(white), noise.get("white_sample_s"),
                         noise.get("span_s"))
