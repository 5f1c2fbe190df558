"""One entry point for writing a result's files: :func:`write` (the CLI, ``gyroid batch``
and the demo all call it). Per kind of result: a fit's fit.json, posterior.nc and figures;
a roll fit's; a pooled fit's; compensation; propagation; discrepancy.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gyroid.io._outputs import json_text

if TYPE_CHECKING:
    from gyroid.allan._fit import NoiseFit
    from gyroid.allan._unit import UnitNoise
    from gyroid.bench._result import BenchFit
    from gyroid.io._logs import BenchLog
    from gyroid.pool._result import PoolFit
    from gyroid.roll._result import RollFit
    from gyroid.workflows._compensate import Compensation
    from gyroid.workflows._datasheet import DatasheetExport
    from gyroid.workflows._discrepancy_report import DiscrepancyReport
    from gyroid.workflows._export import FirmwareExport
    from gyroid.workflows._noise_export import NoiseExport
    from gyroid.workflows._propagate import Propagation


def write(folder: str | Path, result, **context) -> list[Path]:
    """Write ``result``'s files into ``folder`` (which exists) and return their paths.
    ``result`` is a :class:`~gyroid.bench.BenchFit`, :class:`~gyroid.roll.RollFit`,
    :class:`~gyroid.pool.PoolFit`, :class:`~gyroid.workflows.Compensation`,
    :class:`~gyroid.workflows.Propagation` or :class:`~gyroid.workflows.DiscrepancyReport`;
    ``context`` is what only some figures take (``truth``: known values drawn in a fit's
    pair plot, or a simulated lot's ``truth()`` in its forest plot; ``title``: a forest
    plot's)."""
    for kind, writer in _writers():
        if isinstance(result, kind):
            return writer(Path(folder), result, **context)
    raise TypeError(f"gyroid does not know how to write a {type(result).__name__}")


def _bench_fit(folder: Path, result: BenchFit, truth: dict[str, float] | None = None
               ) -> list[Path]:
    """fit.json, posterior.nc, fit.png and pair.png; the figures drawn on a thread while
    the posterior's file is computed and written (:func:`_beside`)."""
    from gyroid.io._arviz import write_netcdf
    from gyroid.models._effects import parameter
    from gyroid.plotting import fit_overview, pair_plot, plot_step, save

    log = result.fitted_log  # e.g. the segment means, not the samples
    point_prediction = result.problem.predict(result.point.u)
    draws = result.predict_draws(every=plot_step(log.n))
    if result.block_means:
        label = f"means of {result.block_means['rows_per_mean']} logged samples"
    elif result.segment_means:
        label = "means of the logged segments"
    else:
        label = "logged drift"
    names = list(result.model_names)
    flat = (None if result.posterior is None else
            result.posterior.draws.reshape(-1, len(result.problem.names))[:, : len(names)])

    def figures() -> list[Path]:
        paths = save(fit_overview(log.time_s, log.drift_deg_h, draws, point_prediction,
                                  data_label=label), folder / "fit")
        if flat is not None:
            units = {n: parameter(n).unit for n in names}
            paths += save(pair_plot(flat, names, units, truth), folder / "pair")
        return paths

    def files() -> list[Path]:
        (folder / "fit.json").write_text(json_text(result.to_json()))
        if result.posterior is None:
            return [folder / "fit.json"]
        write_netcdf(result.inference_data(), folder / "posterior.nc")
        return [folder / "fit.json", folder / "posterior.nc"]

    return _beside(files, figures)


def _beside(files: Callable[[], list[Path]], figures: Callable[[], list[Path]]
            ) -> list[Path]:
    """Run ``figures`` (matplotlib, which holds Python's lock) on a thread while ``files``
    runs here (a posterior's pointwise log-likelihood is compiled code, which releases it):
    a fit's figures then cost little of its time. Only the thread touches matplotlib; an
    error in either is raised here, after both have stopped; the paths, files first."""
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="gyroid-figures") as pool:
        drawn = pool.submit(figures)
        written = files()
        return written + drawn.result()


def _roll_fit(folder: Path, result: RollFit) -> list[Path]:
    """roll_fit.json, posterior.nc, roll_fit.png (angle residuals) and pair.png."""
    from gyroid.io._arviz import write_netcdf
    from gyroid.plotting import pair_plot, roll_fit_figure, save

    summary = result.to_json()
    problem = result.problem
    (folder / "roll_fit.json").write_text(json_text(summary))
    write_netcdf(result.inference_data(), folder / "posterior.nc")
    written = [folder / "roll_fit.json", folder / "posterior.nc"]
    written += save(roll_fit_figure(problem.log.time_s, np.asarray(problem.gs_angle),
                                    np.asarray(problem.predict(result.point.u))),
                    folder / "roll_fit")
    loop = [n for n in ("D0", "D1", "D0gs", "D1gs", "enc_a", "enc_b") if n in problem.names]
    flat = result.sampled.draws.reshape(-1, len(problem.names))
    draws = flat[:, [problem.names.index(n) for n in loop]]
    written += save(pair_plot(draws, loop, summary["units"]), folder / "pair")
    return written


def _pool_fit(folder: Path, result: PoolFit, title: str | None = None,
              truth: dict | None = None) -> list[Path]:
    """pool.json, posterior.nc and forest.png (``truth``: a simulated lot's, drawn in it)."""
    from gyroid.io._arviz import write_netcdf
    from gyroid.plotting import save
    from gyroid.plotting._pool import forest_plot

    record = result.to_json()
    (folder / "pool.json").write_text(json_text(record))
    write_netcdf(result.inference_data(), folder / "posterior.nc")
    written = [folder / "pool.json", folder / "posterior.nc"]
    written += save(forest_plot(result, units=record["units"], title=title, truth=truth),
                    folder / "forest.png")
    return written


def _compensation(folder: Path, result: Compensation) -> list[Path]:
    """compensated.csv, compensated_means.csv, compensate.json, compensation.png and
    allan.png."""
    from gyroid.plotting import allan_figure, compensation_figure, save

    log = result.log
    write_compensated_csv(folder / "compensated.csv", log, result)
    (folder / "compensate.json").write_text(json_text(result.to_json()))
    written = [folder / "compensated.csv", folder / "compensate.json"]
    if result.window_means:
        (folder / "compensated_means.csv").write_text(_table_csv(result.window_means))
        written.append(folder / "compensated_means.csv")
    written += save(compensation_figure(log.time_s, log.drift_deg_h, result.compensated_deg_h),
                    folder / "compensation")
    written += save(allan_figure(result.adev_before, result.adev_after), folder / "allan")
    return written


def _propagation(folder: Path, result: Propagation) -> list[Path]:
    """propagate.json, dk_samples.csv, dk_distribution.png and drivers.png."""
    from gyroid.plotting import dk_distribution, save, sobol_bars

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


def _discrepancy(folder: Path, report: DiscrepancyReport) -> list[Path]:
    """discrepancy.json and discrepancy.png."""
    from gyroid.plotting import discrepancy_figure, roll_discrepancy_figure, save

    (folder / "discrepancy.json").write_text(json_text(report.to_json()))
    if report.log_kind == "roll":
        figure = roll_discrepancy_figure(report)
    else:
        name, values = report.regressor or ("elapsed time", None)
        figure = discrepancy_figure(report, values, name)
    return [folder / "discrepancy.json", *save(figure, folder / "discrepancy")]


def _export(folder: Path, result: FirmwareExport | NoiseExport) -> list[Path]:
    """The target's parameter or noise file (none for json) and export.json."""
    written = []
    if result.file_name:
        (folder / result.file_name).write_text(result.text())
        written.append(folder / result.file_name)
    (folder / "export.json").write_text(json_text(result.record))
    return [*written, folder / "export.json"]


def _noise(folder: Path, result: NoiseFit) -> list[Path]:
    """noise.json and allan.png."""
    from gyroid.plotting import noise_allan_figure, save

    (folder / "noise.json").write_text(json_text(result.to_json()))
    return [folder / "noise.json", *save(noise_allan_figure(result), folder / "allan")]


def _datasheet(folder: Path, result: DatasheetExport) -> list[Path]:
    """The estimator's noise file (none for json) and datasheet.json."""
    written = []
    if result.file is not None:
        (folder / result.file.file_name).write_text(result.file.text())
        written.append(folder / result.file.file_name)
    (folder / "datasheet.json").write_text(json_text(result.to_json()))
    return [*written, folder / "datasheet.json"]


def _unit_noise(folder: Path, result: UnitNoise) -> list[Path]:
    """unit.json and unit.png."""
    from gyroid.plotting import save, unit_noise_figure

    (folder / "unit.json").write_text(json_text(result.to_json()))
    shown = [folder / "unit.json"]
    return shown + (save(unit_noise_figure(result), folder / "unit") if result.terms else [])


#: The writer of each kind of result, by its class's full name: a command imports only the
#: figures and storage its own result needs (importing every kind took a second).
def _writers() -> tuple[tuple[type, Callable[..., list[Path]]], ...]:
    """Each kind of result and its writer, by type (the kinds imported when the first
    result is written: a result's own module is loaded by then)."""
    from gyroid.allan._fit import NoiseFit
    from gyroid.allan._unit import UnitNoise
    from gyroid.bench._result import BenchFit
    from gyroid.pool._result import PoolFit
    from gyroid.roll._result import RollFit
    from gyroid.workflows._compensate import Compensation
    from gyroid.workflows._datasheet import DatasheetExport
    from gyroid.workflows._discrepancy_report import DiscrepancyReport
    from gyroid.workflows._export import FirmwareExport
    from gyroid.workflows._noise_export import NoiseExport
    from gyroid.workflows._propagate import Propagation

    return ((BenchFit, _bench_fit), (RollFit, _roll_fit), (PoolFit, _pool_fit),
            (Compensation, _compensation), (Propagation, _propagation),
            (DiscrepancyReport, _discrepancy), (FirmwareExport, _export),
            (NoiseExport, _export), (NoiseFit, _noise), (UnitNoise, _unit_noise),
            (DatasheetExport, _datasheet))


def _table_csv(columns: dict[str, np.ndarray]) -> str:
    """Equal-length columns as CSV (integers as integers, floats to 10 significant digits,
    NaN as empty)."""
    names = list(columns)
    rows = [",".join(names)]
    for k in range(len(next(iter(columns.values())))):
        cells = []
        for name in names:
            value = columns[name][k]
            cells.append(str(int(value)) if np.issubdtype(type(value), np.integer) else
                         "" if not np.isfinite(value) else f"{value:.10g}")
        rows.append(",".join(cells))
    return "\n".join(rows) + "\n"


def dk_samples_csv(dk: np.ndarray) -> str:
    """The propagated dK samples as a one-column CSV."""
    return "dK\n" + "\n".join(f"{v:.10g}" for v in np.asarray(dk)) + "\n"


def write_compensated_csv(path: str | Path, log: BenchLog, result: Compensation) -> Path:
    """compensated.csv: the input's contract columns (those gyroid read, under their contract
    names) plus the three compensation columns, every value to full precision, by pyarrow's
    CSV writer a million rows at a time into the file (10^5 rows in 0.03 s, where formatting
    row by row in Python took a second; the whole text built in memory first took 5 GB
    at 10^7 rows)."""
    import pyarrow as pa

    from gyroid.io._log_writer import write_csv_rows
    from gyroid.io._logs import BENCH_COLUMNS

    names = [c for c in BENCH_COLUMNS if c in log.columns]
    columns = [log.columns[c] for c in names]
    names += ["drift_model_deg_h", "drift_model_sd_deg_h", "drift_compensated_deg_h"]
    columns += [result.model_deg_h, result.model_sd_deg_h, result.compensated_deg_h]
    with open(path, "wb") as handle:
        handle.write((",".join(names) + "\n").encode())
        write_csv_rows(handle, pa.table({name: np.asarray(column, dtype=float)
                                         for name, column in zip(names, columns, strict=True)}))
    return Path(path)
