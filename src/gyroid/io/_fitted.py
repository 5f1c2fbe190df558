"""A fit read back: its drift model and posterior draws, from a
:class:`gyroid.inference._bench_fit.FitResult`
in memory or from the folder ``gyroid fit`` wrote (fit.json, posterior.nc). What compensation
and propagation start from."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._arviz import arviz as az
from gyroid.models._derived import RATE_WINDOW_S
from gyroid.models._drift import DriftModel
from gyroid.models._inputs import T0_C


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

    @classmethod
    def from_result(cls, result) -> FittedDrift:
        """From a bench fit with a posterior (draws of the model's coefficients, noise
        parameters dropped)."""
        model = result.problem.model
        p = len(model.parameter_names)
        draws = np.asarray(result.posterior.draws).reshape(-1, len(result.problem.names))[:, :p]
        return cls(model=model, draws=draws, t0_C=result.t0_C,
                   rate_window_s=float(result.problem.rate_window_s),
                   trustworthy=result.trustworthy)

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
        fit = json.loads(fit_json.read_text())
        model = DriftModel.from_terms(fit["terms"])
        posterior = az.from_netcdf(str(netcdf)).posterior
        columns = [np.asarray(posterior[name]).reshape(-1) for name in model.parameter_names]
        return cls(model=model, draws=np.column_stack(columns), t0_C=fit.get("t0_C", T0_C),
                   rate_window_s=float(fit.get("rate_window_s", RATE_WINDOW_S)),
                   trustworthy=bool(fit.get("trustworthy", True)))


    @classmethod
    def _from_pool_dir(cls, folder: Path) -> FittedDrift:
        netcdf = folder / "posterior.nc"
        if not netcdf.exists():
            raise GyroidInputError(f"{folder} has no posterior.nc: give the --out folder of "
                                   "'gyroid pool'")
        pool = json.loads((folder / "pool.json").read_text())
        if not pool.get("terms"):
            raise GyroidInputError(f"{folder}/pool.json pools published estimates, not logs: "
                                   "it has no drift model to compensate with")
        model = DriftModel.from_terms(pool["terms"])
        posterior = az.from_netcdf(str(netcdf)).posterior
        columns = [np.asarray(posterior[f"new_run_{name}"]).reshape(-1)
                   for name in model.parameter_names]
        windows = [w for w in pool.get("rate_window_s", {}).values() if w is not None]
        return cls(model=model, draws=np.column_stack(columns), t0_C=pool.get("t0_C", T0_C),
                   rate_window_s=float(np.median(windows)) if windows else RATE_WINDOW_S,
                   trustworthy=bool(pool.get("trustworthy", True)),
                   source="pool: predictive for a new run")


def fitted_ranges_from(folder: str | Path) -> dict[str, list[float]]:
    """The input ranges a fit (fit.json) or a pool (pool.json: over all its runs) saw."""
    folder = Path(folder)
    record = folder / "fit.json" if (folder / "fit.json").exists() else folder / "pool.json"
    return json.loads(record.read_text()).get("input_ranges", {})
