"""Writing a fit's files: fit.json, posterior.nc and its figures."""

from __future__ import annotations

from pathlib import Path

import jax.numpy as jnp
import numpy as np

from gyroid.effects import parameter
from gyroid.fit import FitResult
from gyroid.logs import BenchLog
from gyroid.outputs import json_text
from gyroid.plotting import fit_overview, pair_plot, save


def write_fit_outputs(folder: Path, log: BenchLog, result: FitResult,
                      truth: dict[str, float] | None = None) -> list[Path]:
    """Write fit.json, posterior.nc, fit.png and pair.png into ``folder``."""
    folder = Path(folder)
    (folder / "fit.json").write_text(json_text(result.to_json()))
    written = [folder / "fit.json"]
    if result.posterior is not None:
        result.posterior.idata.to_netcdf(str(folder / "posterior.nc"))
        written.append(folder / "posterior.nc")
    if result.fitted_log is not None:
        log = result.fitted_log  # e.g. the segment means, not the samples
    point_prediction = np.asarray(result.problem.predict(jnp.asarray(result.point.u)))
    written += save(fit_overview(log.time_s, log.drift_deg_h, result.predict_draws(),
                                 point_prediction), folder / "fit")
    if result.posterior is not None:
        names = list(result.model_names)
        flat = result.posterior.draws.reshape(-1, len(result.problem.names))[:, : len(names)]
        units = {n: parameter(n).unit for n in names}
        written += save(pair_plot(flat, names, units, truth), folder / "pair")
    return written
