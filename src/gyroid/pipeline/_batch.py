"""Many logs of one gyro type fitted at once, one fit per log, on Dask (docs/formats.md section 3,
``gyroid batch``): a production lot of gyros, repeated runs of one unit, or an SBC study.

Each log is fitted in a worker process exactly as ``gyroid fit`` fits it, and its files are
written to ``OUT/LABEL/`` (fit.json, posterior.nc, figures; ``LABEL`` is the file's stem,
or its folder's name when stems repeat). A log that cannot be read or
fitted fails alone: its message goes into ``batch.json``'s ``failed`` and the others finish.
The scheduler is a ``LocalCluster`` of single-threaded worker processes by default, or an
existing cluster given by address (its workers must see the same file system).
"""

from __future__ import annotations

import csv
import io
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from gyroid.errors import GyroidInputError
from gyroid.io._logs import run_labels
from gyroid.io._outputs import json_text, output_dir
from gyroid.pipeline._fit_file import FitOptions


@dataclass(frozen=True)
class LogOutcome:
    """What became of one log: its fit's summary, or why it failed."""

    log: str
    axis: str | None = None  # of a log of several gyro axes
    n_samples: int | None = None
    trustworthy: bool | None = None
    posterior: dict[str, dict[str, float]] = field(default_factory=dict)  # P: mean, sd
    message: str | None = None  # None when the fit was written

    @property
    def failed(self) -> bool:
        return self.message is not None


@dataclass(frozen=True)
class BatchResult:
    scheduler: str
    workers: int
    outcomes: list[LogOutcome]

    def to_json(self) -> dict:
        """``batch.json`` (docs/formats.md section 3)."""
        return {"scheduler": self.scheduler, "workers": self.workers,
                "logs": list(dict.fromkeys(o.log for o in self.outcomes)),
                "failed": [{"log": o.log, "message": o.message}
                           for o in self.outcomes if o.failed]}

    def csv_text(self) -> str:
        """``batch.csv``: one row per fitted log, ``P_mean`` and ``P_sd`` per parameter."""
        names = sorted({p for o in self.outcomes for p in o.posterior})
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        axes = any(o.axis is not None for o in self.outcomes)
        writer.writerow(["log", "n_samples", "trustworthy",
                         *(f"{p}_{stat}" for p in names for stat in ("mean", "sd")),
                         *(["axis"] if axes else [])])
        for o in self.outcomes:
            if o.failed:
                continue
            writer.writerow([o.log, o.n_samples, o.trustworthy,
                             *(repr(o.posterior[p][stat]) if p in o.posterior else ""
                               for p in names for stat in ("mean", "sd")),
                             *([o.axis or ""] if axes else [])])
        return out.getvalue()

    @property
    def trustworthy(self) -> bool:
        return all(o.trustworthy for o in self.outcomes if not o.failed)


def fit_one(path: str, options: FitOptions, folder: str) -> list[LogOutcome]:
    """Fit one log as ``gyroid fit`` would and write its files into ``folder`` (runs in a
    worker): an outcome per gyro axis."""
    from gyroid._config import configure
    from gyroid.pipeline._fit_file import fit_file

    configure()  # a worker process: float64 and the compilation cache, as the CLI's
    try:
        result = fit_file(path, replace(options, progress=False), Path(folder))
    except GyroidInputError as error:
        return [LogOutcome(path, message=str(error))]
    except Exception as error:  # noqa: BLE001 - one log's fault must not stop the lot
        return [LogOutcome(path, message=f"internal error: {type(error).__name__}: {error} "
                                         "(a bug in gyroid; fit this log alone with "
                                         "GYROID_DEBUG=1 for the traceback)")]
    return [LogOutcome(path, axis, n_samples=fit.n_samples, trustworthy=fit.trustworthy,
                       posterior={p: {"mean": s["mean"], "sd": s["sd"]}
                                  for p, s in fit.to_json()["posterior"].items()})
            for axis, fit in result.results.items()]


def run_batch(paths: Sequence[str | Path], options: FitOptions, out: Path, *,
              workers: int = 2, scheduler: str | None = None,
              progress: Callable[[str], None] | None = None) -> BatchResult:
    """Fit every log in ``paths`` into ``out/LABEL/`` on Dask (``LABEL`` as
    :func:`gyroid.io.run_labels` names runs: the file's stem, or its folder's name when
    stems repeat), every one with the same ``options`` (every option ``gyroid fit`` takes).
    See the module docstring."""
    from dask.distributed import Client, LocalCluster, as_completed

    say = progress or (lambda _msg: None)
    paths = [str(p) for p in paths]
    stems = run_labels(paths)
    if workers < 1:
        raise GyroidInputError("--workers must be at least 1")
    if scheduler:
        client = Client(scheduler)
        cluster = None
        where = scheduler
    else:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               # no dashboard (dask's stubs type the address str only)
                               dashboard_address=None,  # pyright: ignore[reportArgumentType]
                               silence_logs=logging.ERROR)
        client = Client(cluster)
        where = "LocalCluster"
    try:
        n_workers = len(client.scheduler_info()["workers"])
        futures = {client.submit(fit_one, p, options, str(out / s), pure=False): p
                   for p, s in zip(paths, stems, strict=True)}
        done: dict[str, list[LogOutcome]] = {}
        for future in as_completed(futures):
            outcomes = future.result()
            done[outcomes[0].log] = outcomes
            for outcome in outcomes:
                state = "failed" if outcome.failed else (
                    "written" if outcome.trustworthy else "written, NOT TRUSTWORTHY")
                which = f" (axis {outcome.axis})" if outcome.axis is not None else ""
                say(f"[{len(done)}/{len(paths)}] {outcome.log}{which}: {state}")
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    result = BatchResult(where, n_workers, [o for p in paths for o in done[p]])
    with output_dir(out) as stage:
        (stage / "batch.json").write_text(json_text(result.to_json()))
        (stage / "batch.csv").write_text(result.csv_text())
    return result
