"""Writing each step's files (the CLI and the demo both call these): a fit's fit.json,
posterior.nc and figures; a roll fit's; compensation; propagation; discrepancy."""

from __future__ import annotations

from pathlib import Path

import jax.numpy as jnp
import numpy as np

from gyroid.inference._bench_fit import FitResult
from gyroid.io._arviz import write_netcdf
from gyroid.io._logs import BENCH_COLUMNS, BenchLog
from gyroid.io._outputs import json_text
from gyroid.models._effects import parameter
from gyroid.plotting import (
    allan_figure,
    compensation_figure,
    discrepancy_figure,
    dk_distribution,
    fit_overview,
    pair_plot,
    plot_step,
    roll_discrepancy_figure,
    roll_residual_figure,
    save,
    sobol_bars,
)
from gyroid.workflows._compensate import Compensation
from gyroid.workflows._propagate import Propagation


def write_fit_outputs(folder: Path, log: BenchLog, result: FitResult,
                      truth: dict[str, float] | None = None) -> list[Path]:
    """Write fit.json, posterior.nc, fit.png and pair.png into ``folder``."""
    folder = Path(folder)
    (folder / "fit.json").write_text(json_text(result.to_json()))
    written = [folder / "fit.json"]
    if result.posterior is not None:
        write_netcdf(result.posterior.idata, folder / "posterior.nc")
        written.append(folder / "posterior.nc")
    if result.fitted_log is not None:
        log = result.fitted_log  # e.g. the segment means, not the samples
    point_prediction = np.asarray(result.problem.predict(jnp.asarray(result.point.u)))
    draws = result.predict_draws(every=plot_step(log.n))
    written += save(fit_overview(log.time_s, log.drift_deg_h, draws, point_prediction),
                    folder / "fit")
    if result.posterior is not None:
        names = list(result.model_names)
        flat = result.posterior.draws.reshape(-1, len(result.problem.names))[:, : len(names)]
        units = {n: parameter(n).unit for n in names}
        written += save(pair_plot(flat, names, units, truth), folder / "pair")
    return written


def write_roll_fit_outputs(folder: Path, log, result) -> list[Path]:
    """Write roll_fit.json, posterior.nc, roll_fit.png (angle residuals) and pair.png."""
    folder = Path(folder)
    summary = result.to_json()
    problem = result.problem
    (folder / "roll_fit.json").write_text(json_text(summary))
    write_netcdf(result.posterior.idata, folder / "posterior.nc")
    written = [folder / "roll_fit.json", folder / "posterior.nc"]
    residual = np.asarray(problem.gs_angle - problem.predict(jnp.asarray(result.point.u)))
    written += save(roll_residual_figure(log.time_s, residual), folder / "roll_fit")
    loop = [n for n in ("D0", "D1", "D0gs", "D1gs", "enc_a", "enc_b") if n in problem.names]
    flat = result.posterior.draws.reshape(-1, len(problem.names))
    draws = flat[:, [problem.names.index(n) for n in loop]]
    units = summary["units"] | {"enc_a": "deg", "enc_b": "deg"}
    written += save(pair_plot(draws, loop, units), folder / "pair")
    return written


def write_pool_outputs(folder: Path, result, title: str | None = None) -> list[Path]:
    """Write pool.json, posterior.nc and forest.png (a :class:`PoolResult`)."""
    from gyroid.plotting._pool import forest_plot

    folder = Path(folder)
    record = result.to_json()
    (folder / "pool.json").write_text(json_text(record))
    write_netcdf(result.idata(), folder / "posterior.nc")
    written = [folder / "pool.json", folder / "posterior.nc"]
    written += save(forest_plot(result, units=record["units"], title=title),
                    folder / "forest.png")
    return written


def write_compensate_outputs(folder: Path, log: BenchLog, result) -> list[Path]:
    """Write compensated.csv, compensate.json, compensation.png and allan.png."""
    folder = Path(folder)
    (folder / "compensated.csv").write_text(compensated_csv(log, result))
    (folder / "compensate.json").write_text(json_text(result.summary))
    written = [folder / "compensated.csv", folder / "compensate.json"]
    written += save(compensation_figure(log.time_s, log.drift_deg_h, result.compensated_deg_h),
                    folder / "compensation")
    written += save(allan_figure(result.adev_before, result.adev_after), folder / "allan")
    return written


def write_propagate_outputs(folder: Path, result: Propagation) -> list[Path]:
    """Write propagate.json, dk_samples.csv, dk_distribution.png and drivers.png."""
    folder = Path(folder)
    summary = result.to_json()
    (folder / "propagate.json").write_text(json_text(summary))
    (folder / "dk_samples.csv").write_text(dk_samples_csv(result.samples["dK"]))
    written = [folder / "propagate.json", folder / "dk_samples.csv"]
    written += save(dk_distribution(result.samples["dK"], result.dk_eq7,
                                    summary["closed_form"]["dK_printed"]),
                    folder / "dk_distribution")
    written += save(sobol_bars(summary["drivers_first_order"], summary["drivers_total"],
                               summary["interactions"]), folder / "drivers")
    return written


def write_discrepancy_outputs(folder: Path, report, log: BenchLog | None = None,
                              t0_C: float | None = None) -> list[Path]:
    """Write discrepancy.json and discrepancy.png (a bench log's figure also shows the
    regressor the first added effect follows, so it needs the log)."""
    from gyroid.workflows._residual_structure import regressors

    folder = Path(folder)
    (folder / "discrepancy.json").write_text(json_text(report.to_json()))
    if report.log_kind == "roll":
        return [folder / "discrepancy.json",
                *save(roll_discrepancy_figure(report), folder / "discrepancy")]
    if log is None:
        raise ValueError("a bench log's discrepancy figure needs the log")
    kwargs = {} if t0_C is None else {"t0_C": t0_C}
    searched = report.searched_log if report.searched_log is not None else log
    regs = regressors(searched.inputs(rate_window_s=report.rate_window_s, **kwargs))
    name = (report.steps[0].regressor if report.steps
            else next(iter(report.lines_up_with), "elapsed time"))
    return [folder / "discrepancy.json",
            *save(discrepancy_figure(report, regs.get(name), name), folder / "discrepancy")]


def dk_samples_csv(dk: np.ndarray) -> str:
    """The propagated dK samples as a one-column CSV."""
    return "dK\n" + "\n".join(f"{v:.10g}" for v in np.asarray(dk)) + "\n"


def compensated_csv(log: BenchLog, result: Compensation) -> str:
    """The input's contract columns (those gyroid read, under their contract names) plus
    the three compensation columns."""
    names = [c for c in BENCH_COLUMNS if c in log.columns]
    columns = [log.columns[c] for c in names]
    names += ["drift_model_deg_h", "drift_model_sd_deg_h", "drift_compensated_deg_h"]
    columns += [result.model_deg_h, result.model_sd_deg_h, result.compensated_deg_h]
    data = np.column_stack(columns)
    lines = [",".join(names)] + [",".join(f"{v:.10g}" for v in row) for row in data]
    return "\n".join(lines) + "\n"
