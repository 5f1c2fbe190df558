"""What ``gyroid pool`` does: read the runs (each log a run, or with ``--instances`` each IMU
of one flight-controller, ROS or MATLAB log a run: several gyros of one type in one log
pool naturally, one gyro axis at a time, ``--axis``), pool them, write the result."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

from gyroid.bench._options import BenchOptions
from gyroid.errors import GyroidInputError
from gyroid.io._bench_reader import bench_log_from_table
from gyroid.io._logs import BenchLog, run_labels
from gyroid.io._outputs import output_dir
from gyroid.io._tables import read_log_table
from gyroid.io._units import ColumnMap
from gyroid.models._priors import Prior
from gyroid.pool._fit import fit_pool
from gyroid.pool._result import PoolFit
from gyroid.reports._write import write


def pool_to_dir(paths: tuple[Path, ...], terms: str, out: Path,
                options: BenchOptions | None = None, *, seed: int = 0,
                priors: Mapping[str, Prior] | None = None, maps: tuple[ColumnMap, ...] = (),
                axis: str | None = None, instances: str | None = None,
                say: Callable[[str], None] = lambda _m: None) -> PoolFit:
    """Pool ``terms`` over the runs read from ``paths`` (:func:`pool_runs`), each fitted under
    ``options`` before pooling, the population means' ``priors`` (:func:`fit_pool`), and
    write ``pool.json``, ``posterior.nc`` and ``forest.png`` to ``out``."""
    options = options or BenchOptions()
    loaded, labels = pool_runs(paths, terms, maps=maps, axis=axis, instances=instances)
    rows = sum(log.n for log in loaded)
    say(f"pooling {terms} over {len(loaded)} runs ({rows} rows), each fitted under "
        f"{options.noise_model.name} noise ...")
    result = fit_pool(loaded, labels, terms, options, seed=seed, priors=priors, progress=say)
    with output_dir(out) as stage:
        write(stage, result)
    return result


def pool_runs(paths: tuple[Path, ...], terms: str, *, maps: tuple[ColumnMap, ...] = (),
              axis: str | None = None, instances: str | None = None
              ) -> tuple[list[BenchLog], tuple[str, ...]]:
    """The runs to pool and their labels: one per log (named by :func:`run_labels`), or with
    ``instances`` (``all`` or ``0,2,...``) one per IMU instance of each native log, named
    ``STEM#N``. ``axis``: the gyro axis of logs of several."""
    if instances is None:
        tables = [read_log_table(path, maps) for path in paths]
        return ([bench_log_from_table(t, terms, axis=axis) for t in tables],
                run_labels(paths))
    logs, labels = [], []
    for path, stem in zip(paths, run_labels(paths), strict=True):
        if not _native(path):
            raise GyroidInputError(f"--instances: {Path(path).name} is a table, not a "
                                   "flight-controller, ROS or MATLAB log with several IMUs")
        first = read_log_table(path, maps, 0)
        count = int(first.picked.get("instances", 1))
        for instance in _chosen(instances, count, Path(path).name):
            table = first if instance == 0 else read_log_table(path, maps, instance)
            logs.append(bench_log_from_table(table, terms, axis=axis))
            labels.append(f"{stem}#{instance}")
    return logs, tuple(labels)


def _native(path) -> bool:
    from gyroid.io._native import is_native

    return is_native(Path(path))


def _chosen(text: str, count: int, name: str) -> list[int]:
    """The instances ``--instances`` names (``all``, or comma-separated numbers)."""
    if text.strip() == "all":
        return list(range(count))
    try:
        chosen = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise GyroidInputError(f"--instances {text!r}: give 'all' or numbers such as 0,1,2"
                               ) from None
    beyond = [i for i in chosen if not 0 <= i < count]
    if beyond:
        raise GyroidInputError(f"--instances: {name} has {count} IMU instance(s) (0 to "
                               f"{count - 1}); there is no instance {beyond[0]}")
    return chosen
